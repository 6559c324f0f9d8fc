"""Calibration recovery: do injected encoder offsets and a joint compliance come back from tuning?

MuJoCo runs task ``cube`` with known calibration errors (encoder zero offsets of 1-2 degrees on
joints 2, 3 and 5, joint 2's compliance at half its range, a command delay of 1.5 s; everything
else generic), 10 repeats with 2 mm motion-capture noise and +-0.05 s start jitter (``simtune
synth``).  MuJoCo is then tuned on it in the ``calibrated`` space with ``--only`` the calibration
parameters and ``command_delay`` (a small budget), and each tuned value is compared with the
truth as a fraction of the parameter's range (the issue's bar: injected ones within 10 %).

    python benchmarks/calibration_recovery.py [--budget-evals 400] [--seed 0] [--workers 2] [--out DIR]

The table is printed as Markdown; runs go to ``--out`` (default: a temporary folder).
"""

from __future__ import annotations

import json
import sys
import tempfile
from pathlib import Path

from common import add_search_options, make_parser, start_or_resume

from simtune.objective import Objective, load_references
from simtune.params import get_space
from simtune.runs import RunConfig
from simtune.studies.synth import make_synthetic
from simtune.tasks import parse_tasks

TASK = "cube"
NOISE_M = 0.002
SPACE = get_space("calibrated")
RANGES = {p.name: p for p in SPACE.parameters}
TUNED = ["command_delay", *(n for n in SPACE.names if n.startswith(("joint_offset_", "compliance_joint_")))]
TRUTH = {
    "command_delay": 1.5,
    "joint_offset_2": 1.5,
    "joint_offset_3": -2.0,
    "joint_offset_5": 1.0,
    "compliance_joint_2": 0.5 * RANGES["compliance_joint_2"].high,
}
#: the bar of issue 18: an injected parameter within this fraction of its range of the truth
BAR = 0.10


def score(data: Path, params: dict) -> float:
    tasks = parse_tasks(TASK)
    objective = Objective("mujoco", tasks, load_references(data, tasks))
    try:
        return objective.score(params).fitness
    finally:
        objective.close()


def main() -> int:
    parser = make_parser(__doc__.split("\n\n")[0])
    add_search_options(parser, budget_evals=400)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--out", type=Path, default=None)
    args = parser.parse_args()
    out = args.out or Path(tempfile.mkdtemp(prefix="simtune-calibration-"))
    data = out / "data"
    if not (data / "truth.json").exists():
        make_synthetic("mujoco", TASK, data, truth=dict(TRUTH), noise_m=NOISE_M, repeats=10, seed=0)
    config = RunConfig(
        engine="mujoco",
        tasks=TASK,
        space="calibrated",
        data=str(data),
        seed=args.seed,
        workers=args.workers,
        optimizer=args.optimizer,
        refine=not args.no_refine,
        max_evaluations=args.budget_evals,
        only=TUNED,
    )
    result = start_or_resume(config, out / f"run-seed-{args.seed}")
    floor = score(data, TRUTH)
    untuned = score(data, {"command_delay": TRUTH["command_delay"]})

    print(
        f"\n### MuJoCo recovers calibration errors on synthetic `{TASK}` ({args.optimizer}"
        f"{'' if args.no_refine else ' + least squares'}, {result.evaluations} evaluations, "
        f"{result.wall_s:.0f} s, {args.workers} workers, seed {args.seed})\n"
    )
    print(
        f"Fitness: tuned {result.fitness:.4f}; the truth scored against the noisy data {floor:.4f} (noise floor); "
        f"the true delay without calibration {untuned:.4f}.\n"
    )
    print("| parameter | unit | range | truth | tuned | error / range | within 10 % |")
    print("|---|---|---:|---:|---:|---:|:---:|")
    rows = []
    for name in TUNED:
        p = RANGES[name]
        truth = TRUTH.get(name, 0.0)
        tuned = result.params[name]
        error = abs(tuned - truth) / (p.high - p.low)
        injected = name in TRUTH
        rows.append({"name": name, "truth": truth, "tuned": tuned, "error": error, "injected": injected})
        mark = ("yes" if error <= BAR else "NO") if injected else ("(yes)" if error <= BAR else "(no)")
        print(
            f"| {name}{' *' if injected else ''} | {p.unit} | {p.low:.4g} .. {p.high:.4g} | {truth:.4g} | "
            f"{tuned:.4g} | {error:.3f} | {mark} |"
        )
    injected = [r for r in rows if r["injected"]]
    print(
        f"\n* injected.  {sum(r['error'] <= BAR for r in injected)} of {len(injected)} injected parameters within "
        f"{BAR:.0%} of their range; {sum(r['error'] <= BAR for r in rows)} of {len(rows)} in all."
    )
    (out / "calibration-recovery.json").write_text(
        json.dumps({"truth": TRUTH, "floor": floor, "fitness": result.fitness, "rows": rows}, indent=1)
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())
