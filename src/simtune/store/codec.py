"""What a run store's schema version decides, behind one small protocol, and the encodings the versions share.

A :class:`Codec` knows its version's tables and how a key, a vector, a score and a generation checkpoint are held
in them; :class:`~simtune.store.runstore.RunStore` asks the codec of the store it opened and never the version.
"""

from __future__ import annotations

import hashlib
import json
import sqlite3
import time
from collections.abc import Callable, Sequence
from dataclasses import MISSING, asdict, dataclass, fields
from typing import Protocol

import numpy as np

from simtune.fitness import Score, TaskScore

#: what :meth:`Codec.write_evaluation` returns: run once its transaction has committed (a codec's caches follow
#: the store only after a write that happened)
Committed = Callable[[], None]


@dataclass(frozen=True)
class Checkpoint:
    """A generation as the optimiser checkpoints it: its population and their energies as float64 arrays, its
    best point and fitness, the evaluations used and the run's elapsed time then."""

    generation: int
    population: np.ndarray
    energies: np.ndarray
    best_x: np.ndarray | Sequence[float]
    best_fitness: float
    evaluations: int
    elapsed_s: float


def side_tables(key_type: str) -> str:
    """The tables every version has alike but for the type of its keys: meta, residuals, retried."""
    return f"""
CREATE TABLE IF NOT EXISTS meta (key TEXT PRIMARY KEY, value TEXT NOT NULL);
CREATE TABLE IF NOT EXISTS residuals (key {key_type} PRIMARY KEY, r BLOB NOT NULL);
CREATE TABLE IF NOT EXISTS retried (key {key_type} PRIMARY KEY);
"""


class Codec(Protocol):
    """One schema version of the run store: its tables, and how each value is held in them.

    ``write_*`` methods run inside the store's transaction; they never commit.
    """

    version: int
    #: the version's tables, as simtune creates them (``CREATE TABLE IF NOT EXISTS``: an existing store keeps its)
    schema: str
    #: the columns of a row's vector, read back by :meth:`vector_in`
    vector_columns: str
    #: the column expression of an evaluation's wall time in seconds
    wall_column: str

    def key(self, x) -> str | bytes:
        """An evaluation's key: the SHA-1 of its exact float64 bytes, as this version holds it."""
        ...

    def vector_in(self, exact, copy) -> list[float] | None:
        """A row's vector from its :attr:`vector_columns`: exact, else a copy (as floats), else None."""
        ...

    def score_in(self, row: Sequence) -> Score:
        """The score of a row (fitness, wrist_error, object_error, score)."""
        ...

    def write_evaluation(self, x, score: Score, generation: int, wall_s: float) -> Committed:
        """Store an evaluation, replacing one stored earlier for the same vector in its place (same id)."""
        ...

    def write_generation(self, checkpoint: Checkpoint, keep_population: bool) -> None:
        """Checkpoint a generation (see :meth:`~simtune.store.runstore.RunStore.record_generation`)."""
        ...

    def checkpoint_in(self, population, energies) -> tuple[np.ndarray, np.ndarray]:
        """A checkpoint's stored population and energies as arrays."""
        ...


def nothing_to_follow() -> None:
    """The :data:`Committed` of a codec that keeps no cache."""


def float_bytes(values) -> bytes:
    return np.ascontiguousarray(values, dtype=np.float64).tobytes()


def floats(blob: bytes) -> np.ndarray:
    return np.frombuffer(blob, dtype=np.float64).copy()


def vector_key(x) -> str:
    """A key for a parameter vector: the hash of its exact float64 bytes (hex; version 1 stores hold it so)."""
    return hashlib.sha1(float_bytes(x)).hexdigest()


def compact_json(value) -> str:
    return json.dumps(value, separators=(",", ":"))


#: defaults of a task's score parts: left out of the stored JSON (most evaluations are stable, unpruned, silent)
_TASK_DEFAULTS = {f.name: f.default for f in fields(TaskScore) if f.default is not MISSING}


#: a task's parts that a score of one task holds as its totals (the columns): not stored twice
_TOTALS = ("fitness", "wrist_error", "object_error")


def task_parts(score: Score) -> list[dict]:
    """A score's per-task parts: parts at their default value left out, and with one task, its totals (they are
    the score's, stored in their columns)."""
    tasks = []
    for task in score.tasks:
        parts = {k: v for k, v in asdict(task).items() if k not in _TASK_DEFAULTS or v != _TASK_DEFAULTS[k]}
        if len(score.tasks) == 1 and all(parts[k] == getattr(score, k) for k in _TOTALS):
            parts = {k: v for k, v in parts.items() if k not in _TOTALS}
        tasks.append(parts)
    return tasks


def decode_score(fitness: float, wrist_error: float, object_error: float | None, tasks: list[dict]) -> Score:
    """A score from its columns and its per-task parts as :func:`task_parts` left them."""
    totals = {"fitness": fitness, "wrist_error": wrist_error, "object_error": object_error}
    parts = [TaskScore(**{**totals, **t}) for t in tasks]
    # the joint error (joint logs) has no column: it is the sum of the tasks' own, as Score.combine makes it
    joint = [t.joint_error for t in parts if t.joint_error is not None]
    return Score(fitness, wrist_error, object_error, parts, float(sum(joint)) if joint else None)


def population_digest(population: np.ndarray, energies: np.ndarray) -> bytes:
    """What identifies a checkpoint's population and energies (a replayed generation has the same)."""
    digest = hashlib.sha1(float_bytes(population))
    digest.update(b"|")
    digest.update(float_bytes(energies))
    return digest.digest()


class BinaryCodec:
    """What versions 2 and 3 share: keys, vectors and populations as bytes; a checkpoint known by its digest,
    and only the latest population kept."""

    def __init__(self, db: sqlite3.Connection):
        self.db = db

    def key(self, x) -> str | bytes:
        return hashlib.sha1(float_bytes(x)).digest()

    def checkpoint_in(self, population, energies) -> tuple[np.ndarray, np.ndarray]:
        energy_values = floats(energies)
        return floats(population).reshape(len(energy_values), -1), energy_values

    def write_generation(self, checkpoint: Checkpoint, keep_population: bool) -> None:
        generation, population, energies = checkpoint.generation, checkpoint.population, checkpoint.energies
        digest = population_digest(population, energies)
        stored = self.db.execute("SELECT digest FROM generations WHERE generation = ?", (generation,)).fetchone()
        if stored is not None and stored[0] == digest:
            if keep_population:  # a replay reached the latest population again: keep it (it may be dropped)
                self.db.execute(
                    "UPDATE generations SET population = ?, energies = ? WHERE generation = ?",
                    (float_bytes(population), float_bytes(energies), generation),
                )
                self._drop_populations_before(generation)
            return
        if stored is not None:
            self.db.execute("DELETE FROM generations WHERE generation >= ?", (generation,))
        if keep_population:
            self._drop_populations_before(generation)
        row = {
            "generation": generation,
            "best_fitness": float(checkpoint.best_fitness),
            "population": float_bytes(population) if keep_population else None,
            "energies": float_bytes(energies) if keep_population else None,
            "evaluations": checkpoint.evaluations,
            "elapsed_s": checkpoint.elapsed_s,
            "finished_at": time.time(),
            "digest": digest,
            **self.generation_extras(checkpoint.best_x),
        }
        self.db.execute(
            f"INSERT INTO generations ({', '.join(row)}) VALUES ({', '.join('?' * len(row))})", tuple(row.values())
        )

    def generation_extras(self, best_x) -> dict:
        """Columns of a checkpoint row that only some versions have."""
        return {}

    def _drop_populations_before(self, generation: int) -> None:
        self.db.execute("UPDATE generations SET population = NULL, energies = NULL WHERE generation < ?", (generation,))
