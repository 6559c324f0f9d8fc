"""Why `extended` on the real `cube` is slow to pass 0.03: the cube slides only where two frictions are low at once.

    python benchmarks/friction_pair.py [--data ../shared/datasets/qrg2019/mocap]

From the point `--optimizer auto` opens with (the generic parameters, the command delay aligned to the
recordings), the floor's lateral friction is lowered alone, then with the plastic's.  MuJoCo gives a contact
the larger of its two geoms' frictions, so the cube-floor friction moves only when both do: a search sees
no change along either parameter alone, and a forward-difference Jacobian none below the generic values.
The real cube ends about 10 cm from its start; the generic simulation pushes it 9 mm.
"""

from __future__ import annotations

from common import add_data_option, make_parser

from simtune.optimize.pipeline import aligned_generic_start
from simtune.run_plan import plan_run
from simtune.runs import RunConfig

FRICTIONS = (1.0, 0.5, 0.2, 0.1, 0.05, 0.02, 0.005)


def main() -> None:
    parser = make_parser(__doc__)
    add_data_option(parser)
    args = parser.parse_args()
    config = RunConfig(optimizer="de", engine="mujoco", tasks="cube", space="extended", data=str(args.data))
    objective = plan_run(config).objective()
    start = objective.vector_space().to_dict(aligned_generic_start(objective))
    print("real cube, mujoco, extended, from auto's opening point (generic, delay aligned)")
    print(f"{'lateral friction':>18} {'floor alone':>24} {'floor and plastic':>24}")
    for friction in FRICTIONS:
        alone = objective.score({**start, "lateral_friction_floor": friction})
        both = objective.score({**start, "lateral_friction_floor": friction, "lateral_friction_plastic": friction})
        print(
            f"{friction:>18g} {alone.fitness:>10.4f} (obj {alone.object_error:.4f})"
            f" {both.fitness:>10.4f} (obj {both.object_error:.4f})"
        )


if __name__ == "__main__":
    main()
