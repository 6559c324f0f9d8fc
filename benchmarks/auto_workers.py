"""How well the default optimiser (`--optimizer auto`) keeps its workers busy: evaluations per second at 1 and 2
workers, and the schedule's efficiency at 1, 2 and 16 workers.

    python benchmarks/auto_workers.py [--data ../shared/datasets/qrg2019/mocap] [--task cube] [--space shared]
        [--max-seconds 120] [--seeds 0] [--workers 1,2,16] [--threads none|on|off] [--out FILE]

For each seed and worker count: `simtune tune --engine mujoco --task T --space S --workers W --max-seconds 120`
on the real recordings (the run's other settings at their defaults), then, from its run store:

- evaluations per second over the run (simulated evaluations / the run's elapsed time), and its ratio to
  1 worker's (the issue's target: >= 1.8 at 2 workers);
- the schedule at W workers, simulated from the run's batches (each a DE generation, a least-squares trial
  batch or a Jacobian; every member of a batch given the batch's mean time, which is what the run store
  knows of a batch run on one thread): the share of worker time that does work, sum(n) / (W * sum(ceil(n/W)))
  weighted by the batches' times - idle slots are the members a batch lacks to fill its last round.  The
  batches depend on the worker count (least squares sends a trial point out with as many columns of its next
  Jacobian as there are workers besides it), so each run's schedule is simulated at its own worker count
  and at 1.  A run with more workers than this machine has cores (16 here) runs them as threads of one
  process: its schedule is what it is measured for, not its evaluations per second;
- the coordinator's share: elapsed time outside the batches' evaluations (the solver, the store, checks),
  which no worker count shortens.

The load average is printed beside each run: the host is shared.  With --out the lines are appended to FILE.
"""

from __future__ import annotations

import math
import os
import statistics
import tempfile
import time
from collections import defaultdict
from pathlib import Path

from common import Transcript, add_data_option, make_parser

from simtune.runs import RunConfig, start_run
from simtune.store import RunStore


def batches(run_dir: Path) -> tuple[list[tuple[int, float]], float]:
    """(members, seconds) of each batch of the run (its evaluations grouped by generation); the run's elapsed
    time."""
    store = RunStore.open_read_only(run_dir)
    try:
        sizes: dict[int, int] = defaultdict(int)
        seconds: dict[int, float] = defaultdict(float)
        for evaluation in store.evaluations():
            sizes[evaluation["generation"]] += 1
            seconds[evaluation["generation"]] += evaluation["wall_s"]
        generations = store.generations()
    finally:
        store.close()
    elapsed = generations[-1]["elapsed_s"] if generations else 0.0
    return [(sizes[g], seconds[g]) for g in sorted(sizes)], elapsed


def schedule_efficiency(run: list[tuple[int, float]], workers: int) -> float:
    """Share of ``workers``' time spent evaluating when each batch of ``run`` runs on them in rounds."""
    busy = sum(seconds for _, seconds in run)
    held = sum(seconds / n * math.ceil(n / workers) * workers for n, seconds in run if n)
    return busy / held if held else 1.0


def main() -> None:
    parser = make_parser(__doc__)
    add_data_option(parser)
    parser.add_argument("--task", default="cube")
    parser.add_argument("--space", default="shared")
    parser.add_argument("--max-seconds", type=float, default=120.0)
    parser.add_argument("--seeds", default="0")
    parser.add_argument("--workers", default="1,2,16")
    parser.add_argument(
        "--threads", choices=("none", "on", "off"), default="none", help="RunConfig.threads (none: its default)"
    )
    parser.add_argument("--out", type=Path)
    args = parser.parse_args()

    transcript = Transcript(args.out)
    say = transcript.say

    say(
        f"# auto_workers: mujoco, {args.task}, {args.space}, {args.max_seconds:g} s, threads {args.threads}, "
        f"data {args.data}, {os.cpu_count()} cores, {time.strftime('%Y-%m-%d %H:%M UTC', time.gmtime())}"
    )
    rates: dict[int, list[float]] = defaultdict(list)
    worker_counts = [int(w) for w in args.workers.split(",")]
    for seed in [int(s) for s in args.seeds.split(",")]:
        for workers in worker_counts:
            extra = {} if args.threads == "none" else {"threads": args.threads == "on"}
            oversubscribed = workers > (os.cpu_count() or 1)
            if oversubscribed:
                extra = {"threads": True}
            config = RunConfig(
                engine="mujoco",
                tasks=args.task,
                space=args.space,
                data=str(args.data),
                seed=seed,
                workers=workers,
                max_seconds=args.max_seconds,
                max_generations=1_000_000,
                optimizer="auto",  # `simtune tune`'s defaults
                eval_timeout=600.0,
                **extra,
            )
            with tempfile.TemporaryDirectory() as tmp:
                load = os.getloadavg()[0]
                run_dir = Path(tmp) / "run"
                result = start_run(config, run_dir, show_progress=False)
                load = max(load, os.getloadavg()[0])
                run, elapsed = batches(run_dir)
            simulated = sum(n for n, _ in run)
            evaluating = sum(seconds for _, seconds in run)
            rate = simulated / elapsed
            if not oversubscribed:
                rates[workers].append(rate)
            sizes = sorted(n for n, _ in run)
            schedule = ", ".join(f"{w}: {schedule_efficiency(run, w):.2f}" for w in sorted({1, workers}))
            threads = " (threads of one process: the schedule, not the rate)" if oversubscribed else ""
            say(
                f"seed {seed}, {workers} worker(s){threads}: {simulated} evaluations in {elapsed:.1f} s = "
                f"{rate:.1f} eval/s; "
                f"best {result.fitness:.4f}; {len(run)} batches (sizes median {statistics.median(sizes):g}, "
                f"min {sizes[0]}, max {sizes[-1]}); schedule efficiency at {schedule}; coordinator "
                f"{max(0.0, elapsed - evaluating) / elapsed:.0%} of the wall time (1 worker's evaluation time is "
                f"its batches' sum); load average {load:.2f}"
            )
    base = statistics.median(rates[worker_counts[0]])
    for workers in [w for w in worker_counts[1:] if rates[w]]:
        say(
            f"{workers} workers / {worker_counts[0]}: x{statistics.median(rates[workers]) / base:.2f} the "
            f"evaluations per second (medians over seeds {args.seeds})"
        )
    transcript.save()


if __name__ == "__main__":
    main()
