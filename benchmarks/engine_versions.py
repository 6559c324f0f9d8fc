"""Do two versions of an engine give the same rollouts?  Measured, not assumed, before a shipped probe or a stored run
made under one is trusted under the other (issue 66: MuJoCo 4.0.0 and 4.0.1).

Run it once in an environment with each version: ``--save FILE`` writes, for each bundled task (each target set),
the rollouts of the inactive-parameter probe's base points (the generic point and its seeded random points of the
task's default space) - every sample of the marker, the hand's axes and the object, the joint angles - and the
fitness of the generic point against the shipped reference recording; ``--against FILE`` measures the same in this
environment and prints, per task, the largest difference of each against the saved file's.

    .venv/bin/python benchmarks/engine_versions.py --save /tmp/mujoco-4.0.0.npz
    .venv-latest/bin/python benchmarks/engine_versions.py --against /tmp/mujoco-4.0.0.npz

Writes ``engine-versions-<date>.md`` to --results with ``--against``.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
from common import QRG2019_DATA, add_results_option, make_parser, today, write_result

from simtune.activity import base_points, task_samples, visible_track
from simtune.engines import engine_class, make_engine
from simtune.run_config import RunConfig
from simtune.run_plan import plan_run
from simtune.tasks import TARGETS


def measure(engine: str, tasks: list[str], space: str) -> dict[str, np.ndarray]:
    """Per task and target set: the base points' visible tracks and joint angles, stacked; the generic fitness."""
    found: dict[str, np.ndarray] = {}
    for task_name in tasks:
        for targets in TARGETS:
            plan = plan_run(RunConfig(engine=engine, tasks=task_name, space=space, targets=targets))
            (task,) = plan.tasks
            sim = make_engine(engine, task)
            tracks, angles = [], []
            for params in base_points(plan.full_space):
                rollout = sim.rollout(params, task_samples(task))
                tracks.append(visible_track(rollout, params))
                angles.append(rollout.joint_angles)
            sim.close()
            label = f"{task_name}/{targets}"
            found[f"{label}/track"] = np.stack(tracks)
            found[f"{label}/angles"] = np.stack(angles)
            fitness = np.nan  # no recordings of it here (qrg2019's double is kept back)
            if (QRG2019_DATA / task_name).is_dir():
                scored = RunConfig(engine=engine, tasks=task_name, space=space, targets=targets, data=str(QRG2019_DATA))
                fitness = plan_run(scored).objective().score({}).fitness
            found[f"{label}/generic_fitness"] = np.array([fitness])
    return found


def main() -> int:
    parser = make_parser(__doc__)
    parser.add_argument("--engine", default="mujoco")
    parser.add_argument("--tasks", default="single,cube,double")
    parser.add_argument("--space", default="calibrated", help="the space whose probe base points are rolled out")
    what = parser.add_mutually_exclusive_group(required=True)
    what.add_argument("--save", type=Path, help="write this environment's rollouts to FILE (.npz)")
    what.add_argument("--against", type=Path, help="compare this environment's rollouts with FILE's")
    add_results_option(parser)
    args = parser.parse_args()
    version = engine_class(args.engine).version()
    found = measure(args.engine, args.tasks.split(","), args.space)
    if args.save:
        np.savez_compressed(args.save, version=np.array(version), **found)
        print(f"{len(found)} arrays of {args.engine} {version} -> {args.save}")
        return 0
    saved = np.load(args.against)
    before = str(saved["version"])
    lines = [
        f"# {args.engine} {before} against {version} ({today()})",
        "",
        f"Rollouts of the probe's base points ({args.space} space), `python benchmarks/engine_versions.py`.",
        "",
        "| task / targets | base points | largest track difference [m] | largest joint-angle difference [rad] "
        "| generic fitness, before -> after |",
        "|---|---:|---:|---:|---|",
    ]
    for label in sorted({key.rsplit("/", 1)[0] for key in found}):
        track = float(np.abs(found[f"{label}/track"] - saved[f"{label}/track"]).max())
        angles = float(np.abs(found[f"{label}/angles"] - saved[f"{label}/angles"]).max())
        fit_before, fit_after = float(saved[f"{label}/generic_fitness"][0]), float(found[f"{label}/generic_fitness"][0])
        points = found[f"{label}/track"].shape[0]
        lines.append(f"| {label} | {points} | {track:.3g} | {angles:.3g} | {fit_before!r} -> {fit_after!r} |")
    text = "\n".join(lines) + "\n"
    print(text)
    write_result(args.results, "engine-versions", "md", text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
