"""Store version 3 (the current one): exact vectors only where something reads them, compact scores.

Resume does not read vectors: it replays the optimiser and looks each vector up by its key, the SHA-1 of its
exact float64 bytes. What reads exact vectors is the best evaluation (``best_params.json``, a refinement's start,
export, uncertainty, the report), the initial population (the report) and the population checkpoint
(``--rescore``, kept whole in ``generations``). So an evaluation keeps its exact vector (column ``x``) when it is
of generation 0 or of the first generation stored, or when it is at least as good as every stable evaluation of
the generations before its own; every other one keeps a float32 copy (``x32``, half the bytes: for analysis,
about 7 significant digits). Few later ones keep it: in 6 generations of the 53-parameter ``cube`` run, 5 of the
318 after generation 0 (each 212 bytes more). The best evaluation always keeps it: stable evaluations are never
removed (failed ones are, to be retried), and it is at least as good as each of them; judged against earlier
generations only, what is kept does not depend on the order in which a batch's results arrive (processes,
threads and a resumed run keep the same), and a vector stored again (only outside the Evaluator, which looks
every vector up first) keeps its exact value. float32 rather than no vector: the measured store fits the 20 MB
goal with it (``benchmarks/store_size.py``: 17.5 MB per 1000 generations of the 53-parameter run, 7.9 MB with
the default 29; version 2 34.8 and 14.4 MB), and the vectors of a run stay there to be looked at.

Further, per evaluation: a one-task score whose parts are at their defaults but its step count (most of them) is
stored as that integer, and any other as version 2's compact JSON less the task names where they are those of
the store's first score (``meta`` ``score_tasks``) and with a pruned task's message as its time alone; the wall
time is whole milliseconds (``wall_ms``) and the time it finished whole seconds (what export reads); the
generation checkpoints leave out their best point (nothing reads it, and it is the best evaluation up to there,
exact). About 330 bytes per evaluation of the 53-parameter run, 650 in version 2.
"""

from __future__ import annotations

import json
import sqlite3
import time
from collections.abc import Sequence

import numpy as np

from simtune.fitness import Score, pruned_message
from simtune.store.codec import (
    BinaryCodec,
    Committed,
    compact_json,
    decode_score,
    float_bytes,
    floats,
    side_tables,
    task_parts,
)

SCHEMA = (
    side_tables("BLOB")
    + """
CREATE TABLE IF NOT EXISTS evaluations (
    id INTEGER PRIMARY KEY, key BLOB UNIQUE NOT NULL, x BLOB, x32 BLOB, fitness REAL NOT NULL,
    wrist_error REAL, object_error REAL, stable INTEGER NOT NULL, pruned INTEGER NOT NULL DEFAULT 0,
    score NOT NULL, generation INTEGER NOT NULL, wall_ms INTEGER NOT NULL, finished_at INTEGER NOT NULL
);
CREATE TABLE IF NOT EXISTS generations (
    generation INTEGER PRIMARY KEY, best_fitness REAL NOT NULL, population BLOB, energies BLOB,
    evaluations INTEGER NOT NULL, elapsed_s REAL NOT NULL, finished_at REAL NOT NULL, digest BLOB NOT NULL
);
"""
)
# x: the exact vector (float64) or NULL, x32: its float32 copy where x is NULL; score without a type (no
# conversion): an integer (steps) or JSON text; wall_ms: milliseconds; finished_at: whole seconds (epoch)


class CompactCodec(BinaryCodec):
    """Version 3: exact vectors where read, float32 copies elsewhere, scores as small as they go."""

    version = 3
    schema = SCHEMA
    vector_columns = "x, x32"
    wall_column = "wall_ms / 1000.0"

    def __init__(self, db: sqlite3.Connection):
        super().__init__(db)
        #: the task names of the first score stored (left out of every score with the same names)
        self._task_names: list[str] | None = None
        #: the best fitness of a stable evaluation in each generation (read on the first write)
        self._generation_best: dict[int, float] | None = None
        self._best_before: tuple[int, float | None] | None = None

    def vector_in(self, exact, copy) -> list[float] | None:
        if exact is not None:
            return floats(exact).tolist()
        return None if copy is None else np.frombuffer(copy, dtype=np.float32).tolist()

    def score_in(self, row: Sequence) -> Score:
        return decode_score(row[0], row[1], row[2], decode_tasks(row[3], self._names()))

    def _names(self) -> list[str]:
        """The task names of the first score stored (read again while not known: a writer may store it)."""
        if self._task_names is None:
            row = self.db.execute("SELECT value FROM meta WHERE key = 'score_tasks'").fetchone()
            self._task_names = None if row is None else json.loads(row[0])
        return self._task_names or []

    def write_evaluation(self, x, score: Score, generation: int, wall_s: float) -> Committed:
        key = self.key(x)
        # a row stored again (a test, a caller outside the Evaluator) keeps its exact vector, and the best fitness
        # of each generation is read anew afterwards
        replaced = self.db.execute("SELECT 1 FROM evaluations WHERE key = ?", (key,)).fetchone() is not None
        exact = replaced or self._keeps_exact(generation, score.fitness)
        names = self._names()
        first = self._task_names is None  # the first score stored: its task names are the store's
        if first:
            names = [t.task for t in score.tasks]
            self.db.execute("INSERT OR REPLACE INTO meta VALUES ('score_tasks', ?)", (json.dumps(names),))
        self.db.execute(
            "INSERT INTO evaluations (key, x, x32, fitness, wrist_error, object_error, stable, pruned, score,"
            " generation, wall_ms, finished_at) VALUES (?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?)"
            " ON CONFLICT(key) DO UPDATE SET x = excluded.x, x32 = excluded.x32, fitness = excluded.fitness,"
            " wrist_error = excluded.wrist_error, object_error = excluded.object_error, stable = excluded.stable,"
            " pruned = excluded.pruned, score = excluded.score, generation = excluded.generation,"
            " wall_ms = excluded.wall_ms, finished_at = excluded.finished_at",
            (
                key,
                float_bytes(x) if exact else None,
                None if exact else np.ascontiguousarray(x, dtype=np.float32).tobytes(),
                score.fitness,
                score.wrist_error,
                score.object_error,
                int(score.stable),
                int(score.pruned),
                encode_tasks(score, names),
                generation,
                round(wall_s * 1000),
                int(time.time()),
            ),
        )

        def committed() -> None:
            self._task_names = names
            if replaced:
                self._generation_best = None
            elif score.stable:
                self._note_stable(generation, score.fitness)

        return committed

    def _keeps_exact(self, generation: int, fitness: float) -> bool:
        """Whether an evaluation keeps its exact vector: one of generation 0, or of the first generation stored,
        or one at least as good as every stable evaluation of the generations before its own.

        The best evaluation is such a one whatever came later: stable evaluations are never removed (only failed
        ones are, to be retried), and it is at least as good as each.  Judged against earlier generations only,
        the choice does not depend on the order in which a batch's results arrive.
        """
        if generation == 0:
            return True
        if self._generation_best is None:
            self._generation_best = dict(
                self.db.execute(
                    "SELECT generation, MIN(fitness) FROM evaluations WHERE stable = 1 GROUP BY generation"
                ).fetchall()
            )
            self._best_before = None
        if self._best_before is None or self._best_before[0] != generation:
            earlier = [f for g, f in self._generation_best.items() if g < generation]
            self._best_before = (generation, min(earlier) if earlier else None)
        best = self._best_before[1]
        return best is None or fitness <= best

    def _note_stable(self, generation: int, fitness: float) -> None:
        if self._generation_best is None:
            return  # read from the store when next needed
        if fitness < self._generation_best.get(generation, np.inf):
            self._generation_best[generation] = fitness
            if self._best_before is not None and generation < self._best_before[0]:
                self._best_before = None


def encode_tasks(score: Score, names: list[str]) -> int | str:
    """A score's per-task parts as version 3 stores them: as version 2, and further

    - the task names left out where they are the store's (``names``, those of the first score it stored);
    - a pruned task's message as the time it was pruned at (``"t"``): the rest of it is always the same;
    - a task of which nothing but its steps is left as the number of steps; a score of one such task as that
      integer alone (no JSON: most evaluations of a one-task run are one small integer).
    """
    tasks: list[int | dict] = []
    same_names = [t.task for t in score.tasks] == names
    for parts in task_parts(score):
        if same_names:
            del parts["task"]
        at = _pruned_at(parts.get("message", ""))
        if parts.get("pruned") and at is not None:
            del parts["message"], parts["pruned"]
            parts = {"t": at, **parts}
        tasks.append(parts["steps"] if list(parts) == ["steps"] and type(parts["steps"]) is int else parts)
    if len(tasks) == 1 and isinstance(tasks[0], int):
        return tasks[0]
    return compact_json(tasks)


def _pruned_at(message: str) -> str | None:
    """The time of a message that :func:`~simtune.fitness.pruned_message` wrote (None for any other)."""
    prefix, _, suffix = pruned_message("\0").partition("\0")
    if message.startswith(prefix) and message.endswith(suffix):
        at = message[len(prefix) : len(message) - len(suffix)]
        if pruned_message(at) == message:
            return at
    return None


def decode_tasks(stored: int | str, names: list[str]) -> list[dict]:
    """The per-task parts of :func:`encode_tasks`, as :func:`~simtune.store.codec.task_parts` made them."""
    tasks = [stored] if isinstance(stored, int) else json.loads(stored)
    decoded = []
    for i, task in enumerate(tasks):
        parts: dict = {"steps": task} if isinstance(task, int) else dict(task)
        if "t" in parts:
            parts["message"], parts["pruned"] = pruned_message(parts.pop("t")), True
        if "task" not in parts:
            parts["task"] = names[i]
        decoded.append(parts)
    return decoded
