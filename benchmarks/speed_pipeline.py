"""Time to a good fit: the default pipeline (`--optimizer auto`) against the paper's differential evolution.

    python benchmarks/speed_pipeline.py [--data ../shared/datasets/qrg2019/mocap] [--optimizers auto,de]
        [--seeds 0] [--tasks cube:0.03,single:0.01] [--spaces extended] [--max-seconds 150] [--workers 2]
        [--milestones 0.1,0.05,0.04,0.03,0.025] [--reference aligned|mean] [--out FILE]

For each task:target, space, optimiser and seed: `simtune tune --engine mujoco --space S --workers 2` on
the real recordings, stopped at the target fitness or after --max-seconds.  Printed: the wall time at
which the best fitness first reached the target (from the run store's generation checkpoints: the
run's elapsed time after each batch; "not reached" if it did not), the evaluations used by then, and
the best fitness at the end, and when it passed the --milestones on the way (those above the target; a
target of 0 runs every run for its whole time).  The load average is printed
beside each run: the host is shared, and a
run on a busy host is slower.  With --out the lines are appended to that file as well.
"""

from __future__ import annotations

import os
import statistics
import tempfile
import time
from pathlib import Path

from common import Transcript, add_data_option, make_parser

from simtune.runs import RunConfig, start_run
from simtune.store import RunStore

#: fitness levels whose times are printed on the way to the target
MILESTONES = (0.1, 0.05, 0.04, 0.03, 0.025)


def time_to_target(run_dir: Path, target: float) -> tuple[float | None, int | None, float]:
    """Elapsed seconds and evaluations when the best fitness first reached ``target``; the final best."""
    store = RunStore.open_read_only(run_dir)
    try:
        generations = store.generations()
    finally:
        store.close()
    for g in generations:
        if g["best_fitness"] <= target:
            return g["elapsed_s"], g["evaluations"], generations[-1]["best_fitness"]
    return None, None, generations[-1]["best_fitness"] if generations else float("inf")


def main() -> None:
    parser = make_parser(__doc__)
    add_data_option(parser)
    parser.add_argument("--optimizers", default="auto,de")
    parser.add_argument("--seeds", default="0")
    parser.add_argument("--tasks", default="cube:0.03,single:0.01")
    parser.add_argument("--spaces", default="extended")
    parser.add_argument("--max-seconds", type=float, default=150.0)
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--reference", default=None, help="aligned or mean (default: a new run's, aligned)")
    parser.add_argument("--milestones", default=",".join(f"{m:g}" for m in MILESTONES))
    parser.add_argument("--out", type=Path)
    args = parser.parse_args()
    milestones = [float(m) for m in args.milestones.split(",")]

    transcript = Transcript(args.out)
    say = transcript.say

    say(
        f"# speed_pipeline: mujoco, {args.workers} workers, reference {args.reference or 'default'}, data {args.data}, "
        f"{os.cpu_count()} cores, {time.strftime('%Y-%m-%d %H:%M UTC', time.gmtime())}"
    )
    runs = [
        (*item.split(":"), space, optimizer)
        for item in args.tasks.split(",")
        for space in args.spaces.split(",")
        for optimizer in args.optimizers.split(",")
    ]
    for task, target, space, optimizer in runs:
        times = []
        for seed in [int(s) for s in args.seeds.split(",")]:
            with tempfile.TemporaryDirectory() as tmp:
                config = RunConfig(
                    engine="mujoco",
                    tasks=task,
                    space=space,
                    data=str(args.data),
                    seed=seed,
                    workers=args.workers,
                    max_seconds=args.max_seconds,
                    target_fitness=float(target),
                    optimizer=optimizer,
                    max_generations=100_000,
                    **({"reference": args.reference} if args.reference else {}),
                )
                load = os.getloadavg()[0]
                run_dir = Path(tmp) / "run"
                result = start_run(config, run_dir, show_progress=False)
                seconds, evaluations, best = time_to_target(run_dir, float(target))
                load = max(load, os.getloadavg()[0])
                reached = f"{seconds:.1f} s ({evaluations} evaluations)" if seconds is not None else "not reached"
                passed = [(level, *time_to_target(run_dir, level)[:2]) for level in milestones if level > float(target)]
                on_the_way = ", ".join(
                    f"<= {level:g} at {t:.0f} s, {n} evaluations" if t is not None else f"<= {level:g} never"
                    for level, t, n in passed
                )
            say(
                f"{task} {space} {optimizer} seed {seed}: fitness <= {target}: {reached}; best {best:.4f} after "
                f"{result.wall_s:.0f} s, {result.evaluations} evaluations ({on_the_way}); load average {load:.2f}"
            )
            times.append(seconds if seconds is not None else float("inf"))
        say(f"{task} {space} {optimizer}: median time to fitness <= {target}: {statistics.median(times):.1f} s")
    transcript.save()


if __name__ == "__main__":
    main()
