"""Evaluations per second of one batch: one process, a pool of 2 worker processes, 2 threads (MuJoCo's batch path).

    python benchmarks/batch_threads.py [--data ../shared/datasets/qrg2019/mocap] [--evals 40] [--repeats 3]

The real `cube` recordings, MuJoCo, the `extended` space; the batch is --evals random points of the middle
of the space (stable simulations with differing masses and time steps, as a DE population has).  Each way is
warmed up first (workers started, engines and their per-member copies built), then timed on the same batch;
the three ways take turns, --repeats times, and the median [min, max] is printed with the load average: the
host is shared.  "1 process" is the evaluator without a pool: the engine's batch path on one thread (MuJoCo's
lockstep control periods, engines/mujoco/batch.py), where the pool's workers score one evaluation at a time.
The share of the time inside ``mj_step`` is printed for both: what the GIL leaves to a second thread.
"""

from __future__ import annotations

import os
import statistics
import tempfile
import time
from pathlib import Path

import numpy as np
from common import add_data_option, make_parser, middle_batch

from simtune.objective import Objective
from simtune.optimize.evaluator import Evaluator
from simtune.store import RunStore

WAYS = {"1 process": (1, False), "2 processes": (2, False), "2 threads": (2, True)}


def rate(objective: Objective, batch: np.ndarray, workers: int, threads: bool) -> float:
    with tempfile.TemporaryDirectory() as tmp:
        store = RunStore(Path(tmp), create=True)
        with Evaluator(objective, store, workers, threads=threads) as evaluator:
            evaluator(None, batch + 1e-9)  # warm-up: workers started, engines and one copy per member built
            t0 = time.perf_counter()
            evaluator(None, batch)
            seconds = time.perf_counter() - t0
        store.close()
    return len(batch) / seconds


def stepping_share(objective: Objective, batch: np.ndarray, batched: bool) -> float:
    """Share of the evaluation time spent inside ``mj_step`` (which runs without the GIL): one evaluation at a time,
    or (``batched``) the batch at once on one thread (the batch path; the same as one at a time where there is none)."""
    import mujoco

    step, inside = mujoco.mj_step, [0.0]

    def timed_step(*args, **kwargs) -> None:
        t0 = time.perf_counter()
        step(*args, **kwargs)
        inside[0] += time.perf_counter() - t0

    space = objective.vector_space()
    mujoco.mj_step = timed_step
    try:
        t0 = time.perf_counter()
        if batched:
            list(objective.score_batch([space.to_dict(x) for x in batch]))
        else:
            for x in batch:
                objective.score_vector(x)
        total = time.perf_counter() - t0
    finally:
        mujoco.mj_step = step
    return inside[0] / total


def main() -> None:
    parser = make_parser(__doc__)
    add_data_option(parser)
    parser.add_argument("--evals", type=int, default=40)
    parser.add_argument("--repeats", type=int, default=3)
    args = parser.parse_args()
    objective, batch = middle_batch(args.data, "cube", "extended", args.evals)
    print(f"batch throughput, real cube, mujoco, extended, {args.evals} evaluations per batch, {os.cpu_count()} cores")
    rates: dict[str, list[float]] = {way: [] for way in WAYS}
    loads = []
    for _ in range(args.repeats):
        for way, (workers, threads) in WAYS.items():
            rates[way].append(rate(objective, batch, workers, threads))
            loads.append(os.getloadavg()[0])
    for way, values in rates.items():
        print(f"  {way}: {statistics.median(values):.2f} [{min(values):.2f}, {max(values):.2f}] eval/s")
    for what, batched in (("one at a time", False), ("the batch on one thread", True)):
        share = stepping_share(objective, batch, batched)
        print(
            f"  share inside mj_step (GIL released), {what}: {share:.2f}; the rest holds the GIL, so 2 threads "
            f"can at best run {1 / ((1 - share) + share / 2):.2f} x as fast as one (Amdahl)"
        )
    one = statistics.median(rates["1 process"])
    print(
        f"  speed-up over 1 process: 2 processes x{statistics.median(rates['2 processes']) / one:.2f}, "
        f"2 threads x{statistics.median(rates['2 threads']) / one:.2f}; "
        f"1-min load average {min(loads):.2f}-{max(loads):.2f} during the runs"
    )


if __name__ == "__main__":
    main()
