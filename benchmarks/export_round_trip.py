"""How closely exported models reproduce their runs: `simtune export`, loaded back with each engine's own API.

For each engine and seed: a short random-search run over the whole space on
the shipped `cube` recording (every parameter away from its generic value),
exported, loaded from the files alone (:mod:`simtune.export.replay`), driven
with controller.yaml's commands and scored.  Printed per run: the largest
distance between the exported model's and simtune's own wrist and object
paths, and the difference of the fitness from the run's stored fitness.

    python benchmarks/export_round_trip.py [--engines mujoco,pybullet,dart,drake] [--seeds 0,1,2]
                                           [--space extended] [--evaluations 3]
"""

from __future__ import annotations

import json
import tempfile
from pathlib import Path

import numpy as np
from common import add_engines_option, make_parser

from simtune.engines import make_engine
from simtune.export import export_run
from simtune.export.replay import replay_task
from simtune.objective import load_references
from simtune.reference import REFERENCE_DIR
from simtune.runs import RunConfig, start_run
from simtune.tasks import get_task


def main() -> None:
    parser = make_parser(__doc__)
    add_engines_option(parser, "mujoco,pybullet,dart,drake")
    parser.add_argument("--evaluations", type=int, default=3)
    parser.add_argument("--seeds", default="0,1,2")
    parser.add_argument("--space", default="extended")
    args = parser.parse_args()
    task = get_task("cube")
    reference = load_references(REFERENCE_DIR, [task])["cube"]
    n = len(reference.times)
    print("| engine | seed | time step [s] | wrist [m] | object [m] | fitness [m] | stable |")
    print("|---|---|---|---|---|---|---|")
    with tempfile.TemporaryDirectory() as tmp:
        for engine in args.engines.split(","):
            for seed in (int(s) for s in args.seeds.split(",")):
                folder = Path(tmp) / f"{engine}-{seed}"
                config = RunConfig(
                    engine=engine,
                    tasks="cube",
                    space=args.space,
                    data=str(REFERENCE_DIR),
                    seed=seed,
                    optimizer="random",
                    max_evaluations=args.evaluations,
                )
                start_run(config, folder / "run", show_progress=False)
                best = json.loads((folder / "run" / "best_params.json").read_text())
                export_run(folder / "run", folder / "export")
                own = make_engine(engine, task)
                try:
                    tuned = own.rollout(best["params"], n)
                finally:
                    own.close()
                rollout, score = replay_task(engine, folder / "export", task, reference)
                wrist = np.linalg.norm(rollout.wrist_pos - tuned.wrist_pos, axis=1).max()
                obj = np.linalg.norm(rollout.object_pos - tuned.object_pos, axis=1).max()
                print(
                    f"| {engine} | {seed} | {best['params']['timestep']:.4f} | {wrist:.2g} | {obj:.2g} | "
                    f"{abs(score.fitness - best['fitness']):.2g} | {rollout.stable and tuned.stable} |",
                    flush=True,
                )


if __name__ == "__main__":
    main()
