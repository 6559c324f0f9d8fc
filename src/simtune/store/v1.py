"""Store version 1 (simtune 0.x): keys, vectors, scores and every generation's population as JSON text.

Read, and resumed in its own format: a resumed run appends rows as version 1 wrote them, so the store stays one
version throughout and the simtune that made it still reads it.
"""

from __future__ import annotations

import hashlib
import json
import sqlite3
import time
from collections.abc import Sequence

import numpy as np

from simtune.fitness import Score
from simtune.store.codec import Checkpoint, Committed, float_bytes, nothing_to_follow, side_tables

SCHEMA = (
    side_tables("TEXT")
    + """
CREATE TABLE IF NOT EXISTS evaluations (
    id INTEGER PRIMARY KEY, key TEXT UNIQUE NOT NULL, x TEXT NOT NULL, fitness REAL NOT NULL,
    wrist_error REAL, object_error REAL, stable INTEGER NOT NULL, pruned INTEGER NOT NULL DEFAULT 0,
    score TEXT NOT NULL, generation INTEGER NOT NULL, wall_s REAL NOT NULL, finished_at REAL NOT NULL
);
CREATE TABLE IF NOT EXISTS generations (
    generation INTEGER PRIMARY KEY, best_fitness REAL NOT NULL, best_x TEXT NOT NULL,
    population TEXT NOT NULL, energies TEXT NOT NULL,
    evaluations INTEGER NOT NULL, elapsed_s REAL NOT NULL, finished_at REAL NOT NULL
);
"""
)


class JsonCodec:
    """Version 1: JSON text everywhere, hex keys, every generation's population kept."""

    version = 1
    schema = SCHEMA
    vector_columns = "x, NULL"
    wall_column = "wall_s"

    def __init__(self, db: sqlite3.Connection):
        self.db = db

    def key(self, x) -> str | bytes:
        return hashlib.sha1(float_bytes(x)).hexdigest()

    def vector_in(self, exact, copy) -> list[float] | None:
        return json.loads(exact)

    def score_in(self, row: Sequence) -> Score:
        return Score.from_dict(json.loads(row[3]))

    def write_evaluation(self, x, score: Score, generation: int, wall_s: float) -> Committed:
        vector, stored_score = json.dumps([float(v) for v in x]), json.dumps(score.to_dict())
        write_exact_evaluation(self.db, self.key(x), vector, score, stored_score, generation, wall_s)
        return nothing_to_follow

    def write_generation(self, checkpoint: Checkpoint, keep_population: bool) -> None:
        """Every generation's population is kept (``keep_population`` aside), as version 1 always did."""
        generation, population = checkpoint.generation, checkpoint.population
        population_json = json.dumps(population.tolist())
        energies_json = json.dumps([float(e) for e in checkpoint.energies])
        stored = self.db.execute(
            "SELECT population, energies FROM generations WHERE generation = ?", (generation,)
        ).fetchone()
        if stored == (population_json, energies_json):
            return
        if stored is not None:
            self.db.execute("DELETE FROM generations WHERE generation >= ?", (generation,))
        self.db.execute(
            "INSERT INTO generations VALUES (?, ?, ?, ?, ?, ?, ?, ?)",
            (
                generation,
                float(checkpoint.best_fitness),
                json.dumps([float(v) for v in checkpoint.best_x]),
                population_json,
                energies_json,
                checkpoint.evaluations,
                checkpoint.elapsed_s,
                time.time(),
            ),
        )

    def checkpoint_in(self, population, energies) -> tuple[np.ndarray, np.ndarray]:
        return np.array(json.loads(population)), np.array(json.loads(energies))


def write_exact_evaluation(
    db: sqlite3.Connection, key, vector, score: Score, stored_score: str, generation: int, wall_s: float
) -> None:
    """An evaluation row of versions 1 and 2 (every vector exact, the wall time in seconds)."""
    db.execute(
        "INSERT INTO evaluations (key, x, fitness, wrist_error, object_error, stable, pruned, score,"
        " generation, wall_s, finished_at) VALUES (?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?)"
        " ON CONFLICT(key) DO UPDATE SET fitness = excluded.fitness, wrist_error = excluded.wrist_error,"
        " object_error = excluded.object_error, stable = excluded.stable, pruned = excluded.pruned,"
        " score = excluded.score, generation = excluded.generation, wall_s = excluded.wall_s,"
        " finished_at = excluded.finished_at",
        (
            key,
            vector,
            score.fitness,
            score.wrist_error,
            score.object_error,
            int(score.stable),
            int(score.pruned),
            stored_score,
            generation,
            wall_s,
            time.time(),
        ),
    )
