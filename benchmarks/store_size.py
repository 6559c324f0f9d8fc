"""How large a run store grows: bytes per 1000 generations of the real `cube`, store version 1 against 2.

    python benchmarks/store_size.py [--data ../shared/datasets/qrg2019/mocap] [--generations 8] [--workers 2]

Runs differential evolution (the paper's settings, simtune's deferred updating) on the real `cube`
recordings with MuJoCo and the `extended` space for --generations generations.  It then writes the
run's evaluations and generation checkpoints, in their order, through the store's own API into two
fresh stores: one of version 2 (this simtune: float64 and digest bytes, the latest population alone)
and one of version 1 (JSON text, every generation's population, as simtune wrote before).  Each
store's file size is read after every generation (after a WAL checkpoint, the size a finished run
leaves); a least-squares line through size against generation gives bytes per generation, and

    size of 1000 generations = size after the first (initial) generation + 999 x bytes per generation.

A generation of DE is one trial per population member (61 in `extended`), every one stored, pruned or
not, so the growth per generation holds for any later generation; the extrapolation assumes only that.
"""

from __future__ import annotations

import argparse
import os
import sqlite3
import tempfile
import time
from pathlib import Path

import numpy as np

from simtune.runs import RunConfig, start_run
from simtune.store import STORE_FILE, RunStore

DEFAULT_DATA = Path(__file__).resolve().parents[2] / "shared/datasets/qrg2019/mocap"

#: the tables of a version 1 store, as simtune created them before store version 2
VERSION_1_SCHEMA = """
CREATE TABLE meta (key TEXT PRIMARY KEY, value TEXT NOT NULL);
CREATE TABLE evaluations (
    id INTEGER PRIMARY KEY, key TEXT UNIQUE NOT NULL, x TEXT NOT NULL, fitness REAL NOT NULL,
    wrist_error REAL, object_error REAL, stable INTEGER NOT NULL, pruned INTEGER NOT NULL DEFAULT 0,
    score TEXT NOT NULL, generation INTEGER NOT NULL, wall_s REAL NOT NULL, finished_at REAL NOT NULL
);
CREATE TABLE generations (
    generation INTEGER PRIMARY KEY, best_fitness REAL NOT NULL, best_x TEXT NOT NULL, population TEXT NOT NULL,
    energies TEXT NOT NULL, evaluations INTEGER NOT NULL, elapsed_s REAL NOT NULL, finished_at REAL NOT NULL
);
CREATE TABLE residuals (key TEXT PRIMARY KEY, r BLOB NOT NULL);
CREATE TABLE retried (key TEXT PRIMARY KEY);
INSERT INTO meta VALUES ('schema_version', '1');
"""


def tune(data: Path, generations: int, workers: int, folder: Path) -> tuple[list, list, float]:
    """A real run; every evaluation and every generation checkpoint as the store was asked to record them."""
    evaluations: list[tuple] = []
    checkpoints: list[tuple] = []
    record_evaluation, record_generation = RunStore.record_evaluation, RunStore.record_generation

    def keep_evaluation(self, x, score, generation, wall_s):
        evaluations.append((np.array(x, dtype=float), score, generation, wall_s))
        return record_evaluation(self, x, score, generation, wall_s)

    def keep_generation(self, generation, population, energies, *args, **kwargs):
        checkpoints.append((generation, np.array(population, dtype=float), np.array(energies, dtype=float), args))
        return record_generation(self, generation, population, energies, *args, **kwargs)

    RunStore.record_evaluation, RunStore.record_generation = keep_evaluation, keep_generation  # type: ignore[method-assign]
    try:
        config = RunConfig(
            engine="mujoco",
            tasks="cube",
            space="extended",
            data=str(data),
            seed=0,
            workers=workers,
            max_generations=generations,
        )
        t0 = time.perf_counter()
        start_run(config, folder, show_progress=False)
        wall = time.perf_counter() - t0
    finally:
        RunStore.record_evaluation, RunStore.record_generation = record_evaluation, record_generation  # type: ignore[method-assign]
    return evaluations, checkpoints, wall


def sizes_per_generation(folder: Path, version: int, evaluations: list, checkpoints: list) -> list[int]:
    """File size of a fresh store of ``version`` after each generation's evaluations and checkpoint."""
    folder.mkdir()
    if version == 1:
        db = sqlite3.connect(folder / STORE_FILE)
        db.executescript(VERSION_1_SCHEMA)
        db.close()
        store = RunStore(folder)
    else:
        store = RunStore(folder, create=True)
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


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--data", type=Path, default=DEFAULT_DATA)
    parser.add_argument("--generations", type=int, default=8)
    parser.add_argument("--workers", type=int, default=2)
    args = parser.parse_args()
    load = " ".join(f"{v:.2f}" for v in os.getloadavg())
    print(
        f"store size benchmark: real cube, mujoco, extended, DE seed 0, {args.generations} generations, "
        f"{args.workers} workers; load average {load} (2 cores, shared), {time.strftime('%Y-%m-%d %H:%M')}"
    )
    with tempfile.TemporaryDirectory() as tmp:
        root = Path(tmp)
        evaluations, checkpoints, wall = tune(args.data, args.generations, args.workers, root / "run")
        print(f"  run: {len(evaluations)} evaluations, {len(checkpoints)} generation checkpoints, {wall:.0f} s")
        results = {}
        for version in (1, 2):
            sizes = sizes_per_generation(root / f"v{version}", version, evaluations, checkpoints)
            generations = np.arange(1, len(sizes) + 1)
            per_generation = float(np.polyfit(generations, sizes, 1)[0]) if len(sizes) > 1 else float(sizes[0])
            results[version] = sizes[0] + 999 * per_generation
            per_evaluation = (sizes[-1] - sizes[0]) / max(
                1, len(evaluations) - sum(1 for e in evaluations if e[2] <= checkpoints[0][0])
            )
            print(
                f"  version {version}: {sizes[-1] / 1e6:.2f} MB after {len(sizes)} generations, "
                f"{per_generation / 1e3:.1f} kB per generation ({per_evaluation:.0f} B per evaluation with "
                f"its share of the checkpoint) -> {results[version] / 1e6:.1f} MB per 1000 generations"
            )
        print(f"  version 2 / version 1: {results[2] / results[1]:.3f}")


if __name__ == "__main__":
    main()
