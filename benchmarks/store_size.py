"""How large a run store grows: bytes per 1000 generations of the real `cube`, store versions 1, 2 and 3.

    python benchmarks/store_size.py [--data ../shared/datasets/qrg2019/mocap] [--generations 8] [--workers 2]
                                    [--search both|default|keep-inactive]

Runs differential evolution (the paper's settings, simtune's deferred updating) on the real `cube`
recordings with MuJoCo and the `extended` space for --generations generations, once with the default
search vector (parameters without effect in MuJoCo left out: 29) and once with --keep-inactive (all
53, as the paper searched; --search picks one).  It then writes each run's evaluations and generation
checkpoints, in their order, through the store's own API into fresh stores of each version:

- 3 (this simtune): the exact float64 vector only for generation 0 and each evaluation that could be the
  best, a float32 copy for the others; a one-task score as its step count; times in whole units;
- 2: every vector float64, keys SHA-1 bytes, scores compact JSON, the latest population alone;
- 1: JSON text everywhere and every generation's population, as simtune wrote before version 2.

Each store's file size is read after every generation (after a WAL checkpoint, the size a finished run
leaves); a least-squares line through size against generation gives bytes per generation, and

    size of 1000 generations = size after the first (initial) generation + 999 x bytes per generation.

A generation of DE is one trial per population member (as many as parameters), every one stored, pruned
or not, so the growth per generation holds for any later generation; the extrapolation assumes only that
(and, for version 3, that as few of a later generation's trials become the best as of these).
"""

from __future__ import annotations

import argparse
import os
import tempfile
import time
from pathlib import Path

import numpy as np
from common import add_data_option, make_parser

from simtune.runs import RunConfig, start_run
from simtune.store import READABLE_VERSIONS, STORE_FILE, RunStore


def tune(data: Path, generations: int, workers: int, keep_inactive: bool, folder: Path) -> tuple[list, list, float]:
    """A real run; every evaluation and every generation checkpoint as the store was asked to record them."""
    evaluations: list[tuple] = []
    checkpoints: list[tuple] = []
    record_evaluation, record_generation = RunStore.record_evaluation, RunStore.record_generation

    def keep_evaluation(self, x, score, generation, wall_s, residuals=None):
        if self.run_dir == folder:  # not the scratch stores of the uncertainty at the end
            evaluations.append((np.array(x, dtype=float), score, generation, wall_s))
        return record_evaluation(self, x, score, generation, wall_s, residuals)

    def keep_generation(self, generation, population, energies, *args, **kwargs):
        checkpoints.append((generation, np.array(population, dtype=float), np.array(energies, dtype=float), args))
        return record_generation(self, generation, population, energies, *args, **kwargs)

    RunStore.record_evaluation, RunStore.record_generation = keep_evaluation, keep_generation  # type: ignore[method-assign]
    try:
        config = RunConfig(
            optimizer="de",
            engine="mujoco",
            tasks="cube",
            space="extended",
            data=str(data),
            seed=0,
            workers=workers,
            max_generations=generations,
            keep_inactive=keep_inactive,
        )
        t0 = time.perf_counter()
        start_run(config, folder, show_progress=False)
        wall = time.perf_counter() - t0
    finally:
        RunStore.record_evaluation, RunStore.record_generation = record_evaluation, record_generation  # type: ignore[method-assign]
    return evaluations, checkpoints, wall


def sizes_per_generation(folder: Path, version: int, evaluations: list, checkpoints: list) -> list[int]:
    """File size of a fresh store of ``version`` after each generation's evaluations and checkpoint."""
    store = RunStore(folder, create=True, version=version)
    assert store.version == version
    sizes, done = [], 0
    for generation, population, energies, args in checkpoints:
        while done < len(evaluations) and evaluations[done][2] <= generation:
            store.record_evaluation(*evaluations[done])
            done += 1
        store.record_generation(generation, population, energies, *args)
        store.db.execute("PRAGMA wal_checkpoint(TRUNCATE)")
        sizes.append(os.path.getsize(folder / STORE_FILE))
    store.close()
    return sizes


def measure(root: Path, args: argparse.Namespace, keep_inactive: bool) -> None:
    name = "keep-inactive" if keep_inactive else "default"
    evaluations, checkpoints, wall = tune(args.data, args.generations, args.workers, keep_inactive, root / name)
    dimension = len(evaluations[0][0])
    print(
        f"  {name} search vector, D = {dimension}: {len(evaluations)} evaluations, "
        f"{len(checkpoints)} generation checkpoints, {wall:.0f} s"
    )
    results = {}
    for version in sorted(READABLE_VERSIONS):
        sizes = sizes_per_generation(root / f"{name}-v{version}", version, evaluations, checkpoints)
        generations = np.arange(1, len(sizes) + 1)
        per_generation = float(np.polyfit(generations, sizes, 1)[0]) if len(sizes) > 1 else float(sizes[0])
        results[version] = sizes[0] + 999 * per_generation
        print(
            f"    version {version}: {sizes[-1] / 1e6:.2f} MB after {len(sizes)} generations, "
            f"{per_generation / 1e3:.1f} kB per generation ({per_generation / dimension:.0f} B per evaluation with "
            f"its share of the checkpoint) -> {results[version] / 1e6:.1f} MB per 1000 generations"
        )
    store = RunStore.open_read_only(root / f"{name}-v3")
    exact = store.db.execute("SELECT COUNT(*) FROM evaluations WHERE x IS NOT NULL AND generation > 0").fetchone()[0]
    store.close()
    print(
        f"    version 3 keeps the exact vector of generation 0 and of {exact} of the "
        f"{sum(1 for e in evaluations if e[2] > 0)} later evaluations (those that could be the best)"
    )
    newest = max(results)
    ratios = [f"version {newest} / version {v}: {results[newest] / results[v]:.3f}" for v in results if v < newest]
    print("    " + ", ".join(ratios))


def main() -> None:
    parser = make_parser(__doc__)
    add_data_option(parser)
    parser.add_argument("--generations", type=int, default=8)
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--search", choices=("both", "default", "keep-inactive"), default="both")
    args = parser.parse_args()
    load = " ".join(f"{v:.2f}" for v in os.getloadavg())
    print(
        f"store size benchmark: real cube, mujoco, extended, DE seed 0, {args.generations} generations, "
        f"{args.workers} workers; load average {load} (2 cores, shared), {time.strftime('%Y-%m-%d %H:%M')}"
    )
    with tempfile.TemporaryDirectory() as tmp:
        for keep_inactive in (False, True):
            if args.search in ("both", "keep-inactive" if keep_inactive else "default"):
                measure(Path(tmp), args, keep_inactive)


if __name__ == "__main__":
    main()
