"""Where a tuned run's residual is: per phase of the task and per axis, for runs of several spaces.

For each run folder given, the run's best parameters are simulated on its task and engine, and the
simulated marker is compared with the mean recorded wrist: the mean absolute difference per axis
(x, y, z) and the mean 3-D distance, over each phase of the schedule (shifted by the run's command
delay; "rest" is before the first command), plus the object's final error.  Printed as Markdown.

    python benchmarks/calibration_residuals.py RUN_DIR [RUN_DIR ...] --data ROOT
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
from common import add_data_option, load_best, make_parser

from simtune.fitness import marker_positions
from simtune.objective import Objective, load_references


def residuals(run: Path, data: Path | None) -> tuple[str, list[tuple[str, np.ndarray, float]], float | None]:
    best, task = load_best(run)  # names the run's engine, tasks and space
    params = best["params"]
    references = load_references(data, [task])
    objective = Objective(best["engine"], [task], references)
    try:
        rollout = objective.rollouts(params)[task.name]
    finally:
        objective.close()
    ref = references[task.name]
    assert ref.wrist_mean is not None, "a wrist-tracking task"
    diff = marker_positions(rollout, params) - ref.wrist_mean
    delay = params.get("command_delay", 0.0)
    edges = [0.0, *(delay + p.start for p in task.phases), float(ref.times[-1]) + 1.0]
    names = ["rest", *(f"phase {i}" for i in range(1, len(task.phases) + 1))]
    rows = []
    for name, lo, hi in zip(names, edges[:-1], edges[1:]):
        mask = (ref.times >= lo) & (ref.times < hi)
        if mask.any():
            rows.append((name, np.abs(diff[mask]).mean(axis=0), float(np.linalg.norm(diff[mask], axis=1).mean())))
    rows.append(("all", np.abs(diff).mean(axis=0), float(np.linalg.norm(diff, axis=1).mean())))
    obj = None
    if rollout.object_pos is not None and ref.object_final is not None:
        obj = float(np.linalg.norm(rollout.object_pos[-1] - ref.object_final_mean))
    return f"{best['engine']} {task.name} {best['space']} ({run.name})", rows, obj


def main() -> int:
    parser = make_parser(__doc__.split("\n\n")[0])
    parser.add_argument("runs", nargs="+", type=Path)
    add_data_option(parser, default=None, help="the recordings' root (default: the tasks' own)")
    args = parser.parse_args()
    for run in args.runs:
        label, rows, obj = residuals(run, args.data)
        print(f"\n#### {label}\n")
        print("| part | x [mm] | y [mm] | z [mm] | 3-D [mm] |")
        print("|---|---:|---:|---:|---:|")
        for name, axes, dist in rows:
            print(
                f"| {name} | {axes[0] * 1000:.1f} | {axes[1] * 1000:.1f} | {axes[2] * 1000:.1f} | {dist * 1000:.1f} |"
            )
        if obj is not None:
            print(f"\nObject final error: {obj * 1000:.1f} mm.")
    return 0


if __name__ == "__main__":
    sys.exit(main())
