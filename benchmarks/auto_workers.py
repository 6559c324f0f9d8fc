"""How well the default optimiser (`--optimizer auto`) keeps its workers busy: evaluations per second at 1 and 2
workers, and the schedule's efficiency at 1, 2 and 16 workers.

    python benchmarks/auto_workers.py [--data ../shared/datasets/qrg2019/mocap] [--task cube] [--space shared]
        [--max-seconds 120] [--seeds 0] [--workers 1,2,16] [--threads none|on|off] [--same-search] [--out FILE]

For each seed and worker count: `simtune tune --engine mujoco --task T --space S --workers W --max-seconds 120`
on the real recordings (the run's other settings at their defaults), then, from its run store:

- evaluations per second over the run (simulated evaluations / the run's elapsed time), and its ratio to
  1 worker's (the issue's target: >= 1.8 at 2 workers);
- the schedule at W workers, simulated from the run's batches (each a DE generation, a least-squares trial
  batch or a Jacobian; every member of a batch given the batch's mean time, which is what the run store
  knows of a batch run on one thread): the share of worker time that does work, sum(n) / (W * sum(ceil(n/W)))
  weighted by the batches' times - idle slots are the members a batch lacks to fill its last round.  The
  batches depend on the worker count (least squares sends a trial point out with as many of the trials that
  follow its rejection as there are workers besides it), so each run's schedule is simulated at its own worker count
  and at 1.  A run with more workers than this machine has cores (16 here) runs them as threads of one
  process: its schedule is what it is measured for, not its evaluations per second;
- the coordinator's share: elapsed time outside the Evaluator's batches (the solver, DE, the checks, the store between
  batches), which no worker count shortens; beside it the time outside the stored evaluations' walls, which also
  counts what those walls miss.

With --same-search the runs at more workers do not stop at --max-seconds but where the first worker count's run
stopped its search (its used evaluations, `max_evaluations`: the search takes the same path on any number of
workers, and points scored ahead are not counted until the search asks for them).  Evaluations per second over
120 s compare different work - the faster run gets further, to phases whose evaluations cost more (least
squares runs each rollout to its end; DE's trials are mostly pruned early) - so the speed-up on the same search,
the first run's time over this one's, is the like-for-like figure; the evaluations scored ahead and never asked
for are printed beside it.

First (and again after the runs), the host's own ceiling (--ceiling-repeats, 0 to skip): a batch of 7 members of
the middle of the space scored over and over by one process alone, then by two processes at once (three turns
each, alternating), each on its own (no pool, no coordinator, nothing shared): work that parallelises perfectly,
so the ratio is what two workers can give at most on this machine (2 x alone / together, medians; below 2 where
two cores are not two cores' worth).  By makespan it is what a batch split in two halves gets, waiting for the
later one: 2 x one process's turn alone / the later of the two processes' turns at once (a core the hypervisor
stalls holds the whole batch back).  With a ceiling and 2 workers the last line is the bound the run's batches
and this host set together: the schedule's efficiency at 2 x the ceiling by makespan.

The load average is printed beside each run: the host is shared.  With --out the lines are appended to FILE.
"""

from __future__ import annotations

import math
import os
import statistics
import tempfile
import time
from collections import defaultdict
from dataclasses import dataclass
from pathlib import Path

from common import Transcript, add_data_option, make_parser, middle_batch

from simtune.runs import RunConfig, start_run
from simtune.store import RunStore


def batches(run_dir: Path) -> tuple[list[tuple[int, float]], float, float | None]:
    """(members, seconds) of each batch of the run (its evaluations grouped by generation); the run's elapsed
    time at its last checkpoint; the seconds the search spent inside its batches by then (None from a store written
    before simtune kept them)."""
    store = RunStore.open_read_only(run_dir)
    try:
        sizes: dict[int, int] = defaultdict(int)
        seconds: dict[int, float] = defaultdict(float)
        for evaluation in store.evaluations():
            sizes[evaluation["generation"]] += 1
            seconds[evaluation["generation"]] += evaluation["wall_s"]
        generations = store.generations()
        simulating = store.get("session_simulating_s")
    finally:
        store.close()
    elapsed = generations[-1]["elapsed_s"] if generations else 0.0
    return [(sizes[g], seconds[g]) for g in sorted(sizes)], elapsed, simulating


def schedule_efficiency(run: list[tuple[int, float]], workers: int) -> float:
    """Share of ``workers``' time spent evaluating when each batch of ``run`` runs on them in rounds."""
    busy = sum(seconds for _, seconds in run)
    held = sum(seconds / n * math.ceil(n / workers) * workers for n, seconds in run if n)
    return busy / held if held else 1.0


def coordinator_share(elapsed: float, simulating: float | None, evaluating: float) -> str:
    """The coordinator's share of a run's wall time, in words: the time outside the Evaluator's batches (the
    solver, DE, the checks, the store between batches), and beside it the older reading, outside the stored
    evaluations' walls, which also counts what those walls miss (a point simulated again for its residuals, each
    batch's last store write)."""
    by_walls = f"{max(0.0, elapsed - evaluating) / elapsed:.1%} outside the stored evaluations' walls"
    if simulating is None:
        return f"{by_walls} of the wall time"
    return f"{max(0.0, elapsed - simulating) / elapsed:.1%} of the wall time outside the batches ({by_walls})"


#: turns of one process alone and two together in the ceiling's measurement
ROUNDS = 3


def _batch_seconds(data: str, task: str, space: str, repeats: int, ready, go) -> tuple[float, float]:
    """Median seconds of one 7-member batch of ``task`` (the middle of ``space``), scored ``repeats`` times after
    ``ready`` is set and ``go`` arrives, and the seconds of all of them (a process of :func:`parallel_ceiling`)."""
    objective, points = middle_batch(data, task, space, 7)
    params = [objective.vector_space().to_dict(x) for x in points]
    list(objective.score_batch(params))  # warm-up: engines and per-member copies built
    ready.set()
    go.wait()
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        list(objective.score_batch(params))
        times.append(time.perf_counter() - t0)
    return statistics.median(times), sum(times)


@dataclass
class Ceiling:
    """What two processes give on this host, on work that parallelises perfectly."""

    alone: float  # median seconds of a batch in one process alone
    together: float  # median seconds of a batch in each of two processes at once
    by_makespan: float  # 2 x one process's turn / the later of two processes' turns (medians over the turns)

    @property
    def by_medians(self) -> float:
        return 2 * self.alone / self.together


def parallel_ceiling(data: str, task: str, space: str, repeats: int) -> Ceiling:
    """The host's ceiling for two workers: a batch scored ``repeats`` times by one process alone, then by two
    processes at once, taking turns.  By medians it is what each of two processes does beside the other; by
    makespan, what a batch split in two halves gets, as it waits for the later half (the host's stalls of one
    core included)."""
    import multiprocessing
    from concurrent.futures import ProcessPoolExecutor

    context = multiprocessing.get_context("spawn")
    manager = context.Manager()
    seconds: dict[int, list[float]] = {1: [], 2: []}
    turns: dict[int, list[float]] = {1: [], 2: []}  # a turn's seconds: alone, or the later of the two
    for _ in range(ROUNDS):  # alone and together take turns: the host's load drifts
        for count in (1, 2):
            ready, go = [manager.Event() for _ in range(count)], manager.Event()
            with ProcessPoolExecutor(count, mp_context=context) as pool:
                futures = [pool.submit(_batch_seconds, data, task, space, repeats, r, go) for r in ready]
                for r in ready:  # both built and warm before either starts timing
                    r.wait()
                go.set()
                results = [f.result() for f in futures]
            seconds[count] += [median for median, _ in results]
            turns[count].append(max(total for _, total in results))
    manager.shutdown()
    alone, together = statistics.median(seconds[1]), statistics.median(seconds[2])
    makespan = 2 * statistics.median(turns[1]) / statistics.median(turns[2])
    return Ceiling(alone, together, makespan)


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
    parser.add_argument("--same-search", action="store_true", help="later worker counts stop where the first stopped")
    parser.add_argument("--ceiling-repeats", type=int, default=20, help="batches per process for the ceiling")
    parser.add_argument("--out", type=Path)
    args = parser.parse_args()

    transcript = Transcript(args.out)
    say = transcript.say

    say(
        f"# auto_workers: mujoco, {args.task}, {args.space}, {args.max_seconds:g} s, threads {args.threads}, "
        f"data {args.data}, {os.cpu_count()} cores, {time.strftime('%Y-%m-%d %H:%M UTC', time.gmtime())}"
    )
    ceilings: list[Ceiling] = []

    def measure_ceiling(when: str) -> None:
        ceiling = parallel_ceiling(str(args.data), args.task, args.space, args.ceiling_repeats)
        ceilings.append(ceiling)
        say(
            f"host ceiling ({when}): a 7-member batch takes {ceiling.alone * 1e3:.0f} ms in one process alone, "
            f"{ceiling.together * 1e3:.0f} ms in each of two at once: two workers can give at most "
            f"x{ceiling.by_medians:.2f}; a batch split between them, which waits for the later half, "
            f"x{ceiling.by_makespan:.2f} (load average {os.getloadavg()[0]:.2f})"
        )

    if args.ceiling_repeats > 0:
        measure_ceiling("before the runs")
    rates: dict[int, list[float]] = defaultdict(list)
    speedups: dict[int, list[float]] = defaultdict(list)
    packing: dict[int, list[float]] = defaultdict(list)  # each run's schedule efficiency at its worker count
    worker_counts = [int(w) for w in args.workers.split(",")]
    for seed in [int(s) for s in args.seeds.split(",")]:
        first: tuple[int, float, int] | None = None  # the first worker count's used evaluations, time, simulated
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
                max_seconds=None if args.same_search and first else args.max_seconds,
                max_evaluations=first[0] if args.same_search and first else None,
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
                run, elapsed, simulating = batches(run_dir)
            simulated = sum(n for n, _ in run)
            evaluating = sum(seconds for _, seconds in run)
            rate = simulated / elapsed
            efficiency = {w: schedule_efficiency(run, w) for w in sorted({1, workers})}
            if not oversubscribed:
                rates[workers].append(rate)
                packing[workers].append(efficiency[workers])
            sizes = sorted(n for n, _ in run)
            schedule = ", ".join(f"{w}: {e:.2f}" for w, e in efficiency.items())
            threads = " (threads of one process: the schedule, not the rate)" if oversubscribed else ""
            if first is None:
                first = (result.used_evaluations, elapsed, simulated)
            elif args.same_search and not oversubscribed:
                speedups[workers].append(first[1] / elapsed)
                threads += (
                    f" on the same search ({first[0]} used evaluations: x{first[1] / elapsed:.2f} the first run's "
                    f"speed; {simulated - first[2]} scored ahead and never asked for)"
                )
            say(
                f"seed {seed}, {workers} worker(s){threads}: {simulated} evaluations in {elapsed:.1f} s = "
                f"{rate:.1f} eval/s; "
                f"best {result.fitness:.4f}; {len(run)} batches (sizes median {statistics.median(sizes):g}, "
                f"min {sizes[0]}, max {sizes[-1]}); schedule efficiency at {schedule}; coordinator "
                f"{coordinator_share(elapsed, simulating, evaluating)}; load average {load:.2f}"
            )
    base = statistics.median(rates[worker_counts[0]])
    for workers in [w for w in worker_counts[1:] if rates[w]]:
        say(
            f"{workers} workers / {worker_counts[0]}: x{statistics.median(rates[workers]) / base:.2f} the "
            f"evaluations per second (medians over seeds {args.seeds})"
        )
    for workers, values in speedups.items():
        say(
            f"{workers} workers / {worker_counts[0]} on the same search: x{statistics.median(values):.2f} the speed "
            f"(median over seeds {args.seeds})"
        )
    if ceilings and packing.get(2):
        measure_ceiling("after the runs")  # the host drifts: the bound is given for both
        efficiency = statistics.median(packing[2])
        low, high = sorted(c.by_makespan for c in ceilings)
        say(
            f"2 workers' bound here: the schedule's efficiency at 2 ({efficiency:.2f}, median) x the host's ceiling by "
            f"makespan (x{low:.2f}-x{high:.2f}, before and after) = x{efficiency * low:.2f}-x{efficiency * high:.2f} "
            f"the evaluations per second of 1 worker, with no coordinator's time and no cost of splitting a batch"
        )
    transcript.save()


if __name__ == "__main__":
    main()
