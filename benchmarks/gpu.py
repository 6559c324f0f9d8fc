"""Evaluations per second of the mujoco-warp engine's batches against the MuJoCo engine on 2 worker processes.

    python benchmarks/gpu.py [--sizes 53,530,5300] [--seconds S] [--target 0.03] [--max-seconds 900]
        [--data ../shared/datasets/qrg2019/mocap] [--seed 0]

Prints the device Warp found first.  Then, on `cube`, for batches of --sizes rollouts of uniform points of the
`extended` space (time steps 1-50 ms, as a tuning population has them): the wall time of one mujoco-warp
``rollout_batch`` call and its evaluations per second, against the same rollouts on the MuJoCo engine in
2 worker processes (timed on a sample of the batch: its rate does not depend on the batch size).  Both
simulate the first --seconds of the task (default: all 20 s on a GPU; 0.25 s on a CPU, where Warp steps
one world at a time and a minute is all the benchmark may take).  The first batch of each size is
timed after a warm-up batch, so Warp's kernel builds (about a minute on a CPU, cached after) are not
counted; they are printed apart.

With --target, then: the wall time until a search on the real `cube` recordings reaches that fitness
(SciPy's differential evolution, each generation one batch: ``vectorized=True``), or the best reached
within --max-seconds.  On a CPU that search takes hours (about 20,000 evaluations of 20 s of `cube`):
it runs only when asked, and the estimate from the measured rate is printed instead.
"""

from __future__ import annotations

import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import numpy as np
from common import add_data_option, make_parser, today

from simtune.engines import make_engine
from simtune.engines.mujoco_warp.engine import MujocoWarpEngine
from simtune.params import get_space
from simtune.tasks import get_task

#: evaluations the MuJoCo engine's 2-worker tune needed to pass fitness 0.03 on `cube`, estimated from docs/results.md
#: (2026-11-23): it passed 0.03 after about 4 of its 15 minutes, which held 22,631 evaluations
MUJOCO_EVALUATIONS_TO_003 = 6000

_worker_engine = None


def _mujoco_rollout(job: tuple[dict[str, float], int]) -> bool:
    global _worker_engine
    if _worker_engine is None:
        _worker_engine = make_engine("mujoco", get_task("cube"))
    params, n = job
    return _worker_engine.rollout(params, n).stable


def population(size: int, seed: int) -> list[dict[str, float]]:
    space = get_space("extended", MujocoWarpEngine.supported())
    rng = np.random.default_rng(seed)
    return [{p.name: float(rng.uniform(p.low, p.high)) for p in space.parameters} for _ in range(size)]


def mujoco_rate(params: list[dict[str, float]], n: int, pool: ProcessPoolExecutor) -> float:
    """Evaluations per second of the MuJoCo engine on the pool's 2 processes."""
    list(pool.map(_mujoco_rollout, [(p, n) for p in params[:2]]))  # each worker builds its scene
    start = time.perf_counter()
    list(pool.map(_mujoco_rollout, [(p, n) for p in params]))
    return len(params) / (time.perf_counter() - start)


def search_to_target(engine: MujocoWarpEngine, data: Path, target: float, max_seconds: float, seed: int) -> None:
    from scipy.optimize import differential_evolution

    from simtune.fitness import rollout_joint_names, score_rollout
    from simtune.objective import load_references

    task = engine.task
    reference = load_references(data, [task])[task.name]
    n = len(reference.times)
    space = get_space("extended", engine.supported())
    start = time.perf_counter()
    best = [float("inf"), 0]

    def fitness(xs: np.ndarray) -> np.ndarray:  # (dimensions, members): one batch
        members = [space.to_dict(x) for x in xs.T]
        scores = np.full(len(members), 1e6)
        for i, roll in engine.rollout_batch(members, n):
            if not isinstance(roll, Exception) and roll.stable:
                score = score_rollout(roll, reference, members[i], joint_names=rollout_joint_names(task))
                scores[i] = score.fitness
        best[0] = min(best[0], float(scores.min()))
        best[1] += len(members)
        print(f"  {time.perf_counter() - start:8.1f} s  {best[1]:6d} evaluations  best {best[0]:.4f}", flush=True)
        return scores

    def stop(*_args) -> bool:
        return best[0] <= target or time.perf_counter() - start > max_seconds

    differential_evolution(
        fitness, space.bounds, popsize=1, vectorized=True, updating="deferred", seed=seed, callback=stop, polish=False
    )
    elapsed = time.perf_counter() - start
    if best[0] <= target:
        print(f"reached fitness {target} in {elapsed:.0f} s ({best[1]} evaluations)")
    else:
        print(f"fitness {target} not reached: best {best[0]:.4f} after {elapsed:.0f} s ({best[1]} evaluations)")


def main() -> None:
    parser = make_parser(__doc__)
    parser.add_argument("--sizes", default=None, help="batch sizes (default 53,530,5300; on a CPU 53,530)")
    parser.add_argument("--seconds", type=float, default=None, help="simulated seconds of `cube` per rollout")
    parser.add_argument("--mujoco-sample", type=int, default=32, help="rollouts timed on the MuJoCo engine")
    parser.add_argument("--target", type=float, default=None, help="run the search to this fitness (e.g. 0.03)")
    parser.add_argument("--max-seconds", type=float, default=900.0)
    add_data_option(parser)
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args()

    device = MujocoWarpEngine.device()
    on_gpu = device.startswith("GPU")
    print(f"{today()}  mujoco-warp {MujocoWarpEngine.version()} on {device}")
    if not on_gpu:
        print("NOTE: no GPU: these are CPU figures (Warp's CPU device), not GPU figures")
    sizes = [int(s) for s in (args.sizes or ("53,530,5300" if on_gpu else "53,530")).split(",")]
    task = get_task("cube")
    seconds = args.seconds if args.seconds is not None else (task.duration if on_gpu else 0.25)
    n = int(round(seconds * 20)) + 1
    print(f"cube, first {seconds:g} s ({n} samples), uniform points of `extended`")

    engine = MujocoWarpEngine(task)
    start = time.perf_counter()
    list(engine.rollout_batch(population(2, args.seed + 1), 3))
    print(f"warm-up (Warp's kernel builds, or loading them from its cache): {time.perf_counter() - start:.1f} s")

    with ProcessPoolExecutor(2) as pool:
        base = mujoco_rate(population(args.mujoco_sample, args.seed), n, pool)
    header = ("batch", "mujoco-warp [s]", "evals/s", "world-steps/s", "mujoco x2 evals/s", "ratio")
    print(" ".join(f"{h:>{w}}" for h, w in zip(header, (6, 16, 10, 14, 18, 7), strict=True)))
    rate = 0.0
    for size in sizes:
        params = population(size, args.seed)
        start = time.perf_counter()
        rollouts = dict(engine.rollout_batch(params, n))
        elapsed = time.perf_counter() - start
        steps = sum(r.steps for r in rollouts.values() if not isinstance(r, Exception))
        rate = size / elapsed
        print(f"{size:6d} {elapsed:16.2f} {rate:10.2f} {steps / elapsed:14.0f} {base:18.2f} {rate / base:7.2f}")

    if args.target is None:
        full = rate * seconds / task.duration  # a 20 s rollout costs 20 / seconds as many steps
        print(
            f"time to fitness 0.03 on real cube: not run (--target 0.03 runs it); at {full:.3g} evaluations/s of "
            f"the full task, the ~{MUJOCO_EVALUATIONS_TO_003} evaluations MuJoCo needed would take about "
            f"{MUJOCO_EVALUATIONS_TO_003 / full / 3600:.2g} h here"
        )
        return
    print(f"search on the real cube recordings to fitness {args.target} (at most {args.max_seconds:g} s):")
    search_to_target(engine, args.data, args.target, args.max_seconds, args.seed)


if __name__ == "__main__":
    main()
