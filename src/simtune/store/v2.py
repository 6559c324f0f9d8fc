"""Store version 2: every vector as float64 bytes, keys as SHA-1 bytes, each score's per-task parts as compact
JSON, only the latest population kept.

Read, and resumed in its own format (as :mod:`simtune.store.v1`).
"""

from __future__ import annotations

import json
from collections.abc import Sequence

from simtune.fitness import Score
from simtune.store.codec import (
    BinaryCodec,
    Committed,
    compact_json,
    decode_score,
    float_bytes,
    floats,
    nothing_to_follow,
    side_tables,
    task_parts,
)
from simtune.store.v1 import write_exact_evaluation

SCHEMA = (
    side_tables("BLOB")
    + """
CREATE TABLE IF NOT EXISTS evaluations (
    id INTEGER PRIMARY KEY, key BLOB UNIQUE NOT NULL, x BLOB NOT NULL, fitness REAL NOT NULL,
    wrist_error REAL, object_error REAL, stable INTEGER NOT NULL, pruned INTEGER NOT NULL DEFAULT 0,
    score TEXT NOT NULL, generation INTEGER NOT NULL, wall_s REAL NOT NULL, finished_at REAL NOT NULL
);
CREATE TABLE IF NOT EXISTS generations (
    generation INTEGER PRIMARY KEY, best_fitness REAL NOT NULL, best_x BLOB NOT NULL, population BLOB, energies BLOB,
    evaluations INTEGER NOT NULL, elapsed_s REAL NOT NULL, finished_at REAL NOT NULL, digest BLOB NOT NULL
);
"""
)


class Float64Codec(BinaryCodec):
    """Version 2: every vector exact."""

    version = 2
    schema = SCHEMA
    vector_columns = "x, NULL"
    wall_column = "wall_s"

    def vector_in(self, exact, copy) -> list[float] | None:
        return floats(exact).tolist()

    def score_in(self, row: Sequence) -> Score:
        return decode_score(row[0], row[1], row[2], json.loads(row[3]))

    def write_evaluation(self, x, score: Score, generation: int, wall_s: float) -> Committed:
        stored_score = compact_json(task_parts(score))
        write_exact_evaluation(self.db, self.key(x), float_bytes(x), score, stored_score, generation, wall_s)
        return nothing_to_follow

    def generation_extras(self, best_x) -> dict:
        return {"best_x": float_bytes(best_x)}
