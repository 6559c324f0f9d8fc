"""The run store: one SQLite file per run folder, holding every evaluation.

Tables
- ``meta``: key -> JSON value (the run's configuration, versions, command line, status);
- ``evaluations``: one row per finished evaluation: its key, the parameter vector
  (see below), its fitness and parts, generation, wall time, whether the simulation
  was stable, and whether it was pruned (stopped once it could not beat its parent:
  its fitness is then a lower bound);
- ``generations``: one row per generation: the best fitness, the evaluation count and
  the run's elapsed time, a digest of the population and its energies (a replayed
  generation is recognised by it), and the population itself only where ``resume
  --rescore`` may need it: the latest checkpoint that holds a population;
- ``residuals``: for the evaluations of a least-squares refinement, the residual
  vector (float64 bytes), so a resumed refinement replays without simulating;
- ``retried``: the keys of failed evaluations already given their one retry
  (:meth:`RunStore.release_failures`).

Store version 3 (this one) keeps an evaluation's exact float64 vector only where
something reads it. Resume does not: it replays the optimiser and looks each vector up
by its key, the SHA-1 of its exact float64 bytes. What reads exact vectors is the best
evaluation (:meth:`RunStore.best_evaluation`: ``best_params.json``, a refinement's
start, export, uncertainty, the report), the initial population
(:meth:`RunStore.initial_population`, the report) and the population checkpoint
(``--rescore``, kept whole in ``generations``). So an evaluation keeps its exact vector
(column ``x``) when it is of generation 0 or of the first generation stored, or when it
is at least as good as every stable evaluation of the generations before its own; every
other one keeps a float32 copy (``x32``, half the bytes: for analysis, about 7
significant digits). Few later ones keep it: in 6 generations of the 53-parameter
``cube`` run, 5 of the 318 after generation 0 (each 212 bytes more). The best evaluation
always keeps it: stable evaluations are never removed (failed ones are, to be retried),
and it is at least as good as each of them; judged against earlier generations only,
what is kept does not depend on the order in which a batch's results arrive (processes,
threads and a resumed run keep the same), and a vector stored again (only outside the
Evaluator, which looks every vector up first) keeps its exact value. float32 rather than
no vector: the measured store fits the 20 MB goal with it (``benchmarks/store_size.py``:
17.5 MB per 1000 generations of the 53-parameter run, 7.9 MB with the default 29;
version 2 34.8 and 14.4 MB), and the vectors of a run stay there to be looked at.
Further, per evaluation: a one-task score whose parts are at their defaults but its step
count (most of them) is stored as that integer, and any other as version 2's compact
JSON less the task names where they are those of the store's first score (``meta``
``score_tasks``) and with a pruned task's message as its time alone; the wall time is
whole milliseconds (``wall_ms``) and the time it finished whole seconds (what export
reads); the generation checkpoints leave out their best point (nothing reads it, and it
is the best evaluation up to there, exact). About 330 bytes per evaluation of the
53-parameter run, 650 in version 2.

Version 2 stores (every vector float64, keys SHA-1 bytes, each score's per-task parts
as compact JSON, one population) and version 1 stores (JSON text everywhere, every
generation's population) are read, resumed and written in their own format.

Every evaluation is committed as soon as it finishes (WAL journal), so a kill
loses at most the evaluations still running.  Evaluations are keyed by the
exact bytes of their parameter vector: a resumed run replays the optimiser
with the same seed and takes every evaluation it already has from here
instead of simulating it again.
"""

from __future__ import annotations

import hashlib
import json
import shutil
import sqlite3
import time
from collections.abc import Callable
from contextlib import contextmanager
from dataclasses import MISSING, asdict, fields
from pathlib import Path

import numpy as np

from simtune.errors import SimtuneError
from simtune.fitness import Score, TaskScore, pruned_message

STORE_FILE = "run.sqlite"
SCHEMA_VERSION = 3
#: store versions this simtune reads and writes (1: vectors and populations as JSON text; 2: every vector as float64)
READABLE_VERSIONS = (1, 2, 3)
MIN_FREE_BYTES = 50_000_000


def _schema(version: int) -> str:
    """The tables of a store of ``version`` as simtune creates them (an older version: to compare formats, in
    tests and benchmarks; a store is always written in its own version)."""
    text = "TEXT" if version == 1 else "BLOB"  # keys, vectors and populations: JSON text in version 1, else bytes
    if version >= 3:
        # x: the exact vector (float64) or NULL, x32: its float32 copy where x is NULL; score without a type (no
        # conversion): an integer (steps) or JSON text; wall_ms: milliseconds; finished_at: whole seconds (epoch)
        vector, score, times = "x BLOB, x32 BLOB", "score", "wall_ms INTEGER NOT NULL, finished_at INTEGER NOT NULL"
    else:
        vector, score, times = f"x {text} NOT NULL", "score TEXT", "wall_s REAL NOT NULL, finished_at REAL NOT NULL"
    best_x = "" if version >= 3 else f"best_x {text} NOT NULL, "
    population = "population BLOB, energies BLOB"  # version 1 kept every generation's
    if version == 1:
        population = "population TEXT NOT NULL, energies TEXT NOT NULL"
    digest = "" if version == 1 else ", digest BLOB NOT NULL"
    return f"""
CREATE TABLE IF NOT EXISTS meta (key TEXT PRIMARY KEY, value TEXT NOT NULL);
CREATE TABLE IF NOT EXISTS evaluations (
    id INTEGER PRIMARY KEY, key {text} UNIQUE NOT NULL, {vector}, fitness REAL NOT NULL,
    wrist_error REAL, object_error REAL, stable INTEGER NOT NULL, pruned INTEGER NOT NULL DEFAULT 0,
    {score} NOT NULL, generation INTEGER NOT NULL, {times}
);
CREATE TABLE IF NOT EXISTS generations (
    generation INTEGER PRIMARY KEY, best_fitness REAL NOT NULL, {best_x}{population},
    evaluations INTEGER NOT NULL, elapsed_s REAL NOT NULL, finished_at REAL NOT NULL{digest}
);
CREATE TABLE IF NOT EXISTS residuals (key {text} PRIMARY KEY, r BLOB NOT NULL);
CREATE TABLE IF NOT EXISTS retried (key {text} PRIMARY KEY);
"""


#: the tables of a store of this version
_SCHEMA = _schema(SCHEMA_VERSION)
_OWN_TABLES = frozenset({"meta", "evaluations", "generations", "residuals", "retried"})


def check_store_file(path: Path) -> bool:
    """Refuse a file that is not a run store of this simtune's schema, reading it only (one line naming it).

    A foreign SQLite file (or any other file) named ``run.sqlite`` is left exactly as it was.  False for a
    store that was never set up: an empty database, or one holding only simtune's tables and no schema
    version yet (its process died while creating it; nothing of a user's is in it, so it may be replaced).
    """
    path = Path(path)
    try:
        db = sqlite3.connect(path.resolve().as_uri() + "?mode=ro", uri=True)
        try:
            tables = {row[0] for row in db.execute("SELECT name FROM sqlite_master WHERE type = 'table'")}
            row = None
            if {"meta", "evaluations", "generations"} <= tables:
                row = db.execute("SELECT value FROM meta WHERE key = 'schema_version'").fetchone()
        finally:
            db.close()
    except sqlite3.DatabaseError as exc:
        raise SimtuneError(f"{path} cannot be read as a run store ({exc}); it was left unchanged") from None
    if row is None:
        if tables <= _OWN_TABLES:
            return False
        raise SimtuneError(f"{path} is not a simtune run store (no simtune tables in it); it was left unchanged")
    try:
        version = json.loads(row[0])
    except ValueError:
        version = row[0]
    _check_version(path, version)
    return True


def _check_version(path: Path, version) -> None:
    if version not in READABLE_VERSIONS:
        readable = ", ".join(str(v) for v in READABLE_VERSIONS)
        raise SimtuneError(f"{path}: run store version {version}, this simtune reads versions {readable}")


def _float_bytes(values) -> bytes:
    return np.ascontiguousarray(values, dtype=np.float64).tobytes()


def _floats(blob: bytes) -> np.ndarray:
    return np.frombuffer(blob, dtype=np.float64).copy()


def vector_key(x) -> str:
    """A key for a parameter vector: the hash of its exact float64 bytes (hex; version 1 stores hold it so)."""
    return hashlib.sha1(_float_bytes(x)).hexdigest()


#: defaults of a task's score parts: left out of the stored JSON (most evaluations are stable, unpruned, silent)
_TASK_DEFAULTS = {f.name: f.default for f in fields(TaskScore) if f.default is not MISSING}


#: a task's parts that a score of one task holds as its totals (the columns): not stored twice
_TOTALS = ("fitness", "wrist_error", "object_error")


def _task_parts(score: Score) -> list[dict]:
    """A score's per-task parts: parts at their default value left out, and with one task, its totals (they are
    the score's, stored in their columns)."""
    tasks = []
    for task in score.tasks:
        parts = {k: v for k, v in asdict(task).items() if k not in _TASK_DEFAULTS or v != _TASK_DEFAULTS[k]}
        if len(score.tasks) == 1 and all(parts[k] == getattr(score, k) for k in _TOTALS):
            parts = {k: v for k, v in parts.items() if k not in _TOTALS}
        tasks.append(parts)
    return tasks


def _json(value) -> str:
    return json.dumps(value, separators=(",", ":"))


def _encode_tasks(score: Score) -> str:
    """A score's per-task parts as compact JSON (version 2)."""
    return _json(_task_parts(score))


def _encode_tasks_v3(score: Score, names: list[str]) -> int | str:
    """A score's per-task parts as version 3 stores them: as version 2, and further

    - the task names left out where they are the store's (``names``, those of the first score it stored);
    - a pruned task's message as the time it was pruned at (``"t"``): the rest of it is always the same;
    - a task of which nothing but its steps is left as the number of steps; a score of one such task as that
      integer alone (no JSON: most evaluations of a one-task run are one small integer).
    """
    tasks: list[int | dict] = []
    same_names = [t.task for t in score.tasks] == names
    for parts in _task_parts(score):
        if same_names:
            del parts["task"]
        at = _pruned_at(parts.get("message", ""))
        if parts.get("pruned") and at is not None:
            del parts["message"], parts["pruned"]
            parts = {"t": at, **parts}
        tasks.append(parts["steps"] if list(parts) == ["steps"] and type(parts["steps"]) is int else parts)
    if len(tasks) == 1 and isinstance(tasks[0], int):
        return tasks[0]
    return _json(tasks)


def _pruned_at(message: str) -> str | None:
    """The time of a message that :func:`~simtune.fitness.pruned_message` wrote (None for any other)."""
    prefix, _, suffix = pruned_message("\0").partition("\0")
    if message.startswith(prefix) and message.endswith(suffix):
        at = message[len(prefix) : len(message) - len(suffix)]
        if pruned_message(at) == message:
            return at
    return None


def _decode_tasks_v3(stored: int | str, names: list[str]) -> list[dict]:
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


def _decode_score(fitness: float, wrist_error: float, object_error: float | None, tasks: list[dict]) -> Score:
    totals = {"fitness": fitness, "wrist_error": wrist_error, "object_error": object_error}
    parts = [TaskScore(**{**totals, **t}) for t in tasks]
    # the joint error (joint logs) has no column: it is the sum of the tasks' own, as Score.combine makes it
    joint = [t.joint_error for t in parts if t.joint_error is not None]
    return Score(fitness, wrist_error, object_error, parts, float(sum(joint)) if joint else None)


def _population_digest(population: np.ndarray, energies: np.ndarray) -> bytes:
    """What identifies a checkpoint's population and energies (a replayed generation has the same)."""
    digest = hashlib.sha1(_float_bytes(population))
    digest.update(b"|")
    digest.update(_float_bytes(energies))
    return digest.digest()


class RunStore:
    """SQLite store of one run.  Only the coordinating process writes to it.

    ``RunStore(run_dir)`` opens it for writing; :meth:`open_read_only` for reading alone.  A store of an
    older version is read and written in its own format (``self.version``); ``RunStore(run_dir, create=True,
    version=2)`` creates one (to compare formats).
    """

    read_only = False
    version = SCHEMA_VERSION

    def __init__(self, run_dir: Path, create: bool = False, filename: str = STORE_FILE, version: int | None = None):
        self.run_dir = Path(run_dir)
        self.path = self.run_dir / filename
        if create:
            try:
                self.run_dir.mkdir(parents=True, exist_ok=True)
            except OSError as exc:
                raise SimtuneError(f"cannot create run folder {self.run_dir}: {exc.strerror}") from None
            free = shutil.disk_usage(self.run_dir).free
            if free < MIN_FREE_BYTES:  # refuse before any compute is spent, not halfway through
                raise SimtuneError(
                    f"only {free / 1e6:.0f} MB free at {self.run_dir}: a run store needs "
                    f"{MIN_FREE_BYTES / 1e6:.0f} MB or more"
                )
        elif not self.path.exists():
            raise SimtuneError(f"{self.run_dir} is not a run folder (no {filename})")
        elif not check_store_file(self.path):  # read-only: nothing is written into a foreign file
            raise SimtuneError(
                f"{self.run_dir}: the run was never set up (its process died while creating it): "
                f"`simtune tune --out {self.run_dir}` starts it afresh"
            )
        self._reset_caches()
        try:
            self.db = sqlite3.connect(self.path, timeout=30)
            self.db.execute("PRAGMA journal_mode=WAL")
            self.db.execute("PRAGMA synchronous=NORMAL")
            stored = self._stored_version()
            self.version = stored if stored is not None else (version or SCHEMA_VERSION)
            _check_version(self.path, self.version)
            # an existing store has its tables already: left as they are (one its version lacks is added)
            self.db.executescript(_schema(self.version))
        except sqlite3.Error as exc:
            raise SimtuneError(f"{self.path}: cannot open run store ({exc})") from None
        if stored is None:
            self.set(schema_version=self.version)

    def _stored_version(self):
        try:
            row = self.db.execute("SELECT value FROM meta WHERE key = 'schema_version'").fetchone()
        except sqlite3.OperationalError:  # no meta table yet: a store being created
            return None
        return None if row is None else json.loads(row[0])

    def _reset_caches(self) -> None:
        #: version 3: the task names of the first score stored (left out of every score with the same names)
        self._task_names: list[str] | None = None
        #: version 3: the best fitness of a stable evaluation in each generation (read on the first write)
        self._generation_best: dict[int, float] | None = None
        self._best_before: tuple[int, float | None] | None = None

    @classmethod
    def open_read_only(cls, run_dir: Path, filename: str = STORE_FILE) -> RunStore:
        """The store in ``run_dir`` opened read-only (SQLite ``mode=ro``): every query works, every write fails.

        Reading leaves the run folder as it was.  A store closed cleanly has no ``-wal`` file: all of it
        is in its one file, which is then opened ``immutable`` so that SQLite creates no side files (it
        assumes no writer appears while it reads: stores of finished runs have none).  A store with a
        ``-wal`` file (a run being written, or one that was killed) is read through that file.  A file
        that is not a SQLite database raises :class:`sqlite3.DatabaseError`, here or at a later query.
        """
        store = cls.__new__(cls)
        store.run_dir = Path(run_dir)
        store.path = store.run_dir / filename
        store.read_only = True
        store._reset_caches()
        if not store.path.is_file():
            raise SimtuneError(f"{store.run_dir} is not a run folder (no {filename})")
        wal = store.path.with_name(store.path.name + "-wal")
        flags = "mode=ro" if wal.exists() else "mode=ro&immutable=1"
        store.db = sqlite3.connect(f"{store.path.resolve().as_uri()}?{flags}", uri=True, timeout=30)
        try:
            store.version = store.get("schema_version")
        except sqlite3.Error:
            store.db.close()
            raise
        try:
            _check_version(store.path, store.version)
        except SimtuneError:
            store.db.close()
            raise
        return store

    # --- the formats: version 1 (JSON text, hex keys), 2 (float64 and digest bytes), 3 (exact vectors where read) ---
    @property
    def _legacy(self) -> bool:
        return self.version == 1

    def _key(self, x) -> str | bytes:
        digest = hashlib.sha1(_float_bytes(x))
        return digest.hexdigest() if self._legacy else digest.digest()

    def _vector_out(self, x) -> str | bytes:
        return json.dumps([float(v) for v in x]) if self._legacy else _float_bytes(x)

    @property
    def _vector_columns(self) -> str:
        """The columns of a row's vector: its exact value, and (version 3) its float32 copy where that is not kept."""
        return "x, x32" if self.version >= 3 else "x, NULL"

    def _vector_in(self, exact, copy=None) -> list[float] | None:
        """A row's vector (:attr:`_vector_columns`): exact, else its float32 copy (as floats), else None."""
        if self._legacy:
            return json.loads(exact)
        if exact is not None:
            return _floats(exact).tolist()
        return None if copy is None else np.frombuffer(copy, dtype=np.float32).tolist()

    @property
    def _wall_column(self) -> str:
        return "wall_ms / 1000.0" if self.version >= 3 else "wall_s"

    def _names(self) -> list[str]:
        """Version 3: the task names of the first score stored (read again while not known: a writer may store it)."""
        if self._task_names is None:
            self._task_names = self.get("score_tasks")
        return self._task_names or []

    def _score_in(self, row) -> Score:
        """The score of a row (fitness, wrist_error, object_error, score)."""
        if self._legacy:
            return Score.from_dict(json.loads(row[3]))
        tasks = _decode_tasks_v3(row[3], self._names()) if self.version >= 3 else json.loads(row[3])
        return _decode_score(row[0], row[1], row[2], tasks)

    def _keeps_exact(self, generation: int, fitness: float) -> bool:
        """Version 3: whether an evaluation keeps its exact vector: one of generation 0, or of the first generation
        stored, or one at least as good as every stable evaluation of the generations before its own.

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

    @contextmanager
    def _writing(self):
        """A committed transaction; a failed write (disk full, folder removed) is one clear error."""
        if self.read_only:
            raise SimtuneError(f"{self.path} is open read-only: not written")
        try:
            with self.db:
                yield
        except sqlite3.Error as exc:
            raise SimtuneError(
                f"cannot write run store {self.path}: {exc} (disk full or not writable?); "
                f"finished evaluations are kept: `simtune resume {self.run_dir}`"
            ) from None

    def verify(self) -> None:
        """SQLite's quick check of every page; a damaged store is one line naming it and the first problem."""
        try:
            problems = [row[0] for row in self.db.execute("PRAGMA quick_check(3)")]
        except sqlite3.DatabaseError as exc:
            problems = [str(exc)]
        if problems != ["ok"]:
            lines = [line.strip() for p in problems for line in p.splitlines() if line.strip()]
            first = next((line for line in lines if not line.startswith("***")), lines[0] if lines else "?")
            raise SimtuneError(
                f"{self.path} is damaged ({first}): start a new run in another folder "
                "(`sqlite3 run.sqlite .recover` may salvage its rows)"
            )

    # --- meta ------------------------------------------------------------------------------
    def set(self, **values) -> None:
        with self._writing():
            self.db.executemany(
                "INSERT OR REPLACE INTO meta VALUES (?, ?)", [(k, json.dumps(v)) for k, v in values.items()]
            )

    def get(self, key: str, default=None):
        row = self.db.execute("SELECT value FROM meta WHERE key = ?", (key,)).fetchone()
        return json.loads(row[0]) if row else default

    # --- evaluations --------------------------------------------------------------------------
    def lookup(self, x) -> Score | None:
        row = self.db.execute(
            "SELECT fitness, wrist_error, object_error, score FROM evaluations WHERE key = ?", (self._key(x),)
        ).fetchone()
        return None if row is None else self._score_in(row)

    def record_evaluation(self, x, score: Score, generation: int, wall_s: float, residuals=None) -> None:
        """Store an evaluation (with ``residuals``: its residual vector too, in the same transaction); one stored
        earlier for the same vector is replaced (in its place: same id; in version 3 with its exact vector)."""
        if self.version >= 3:
            self._record_evaluation_v3(x, score, generation, wall_s, residuals)
            return
        stored_score = json.dumps(score.to_dict()) if self._legacy else _encode_tasks(score)
        with self._writing():
            self.db.execute(
                "INSERT INTO evaluations (key, x, fitness, wrist_error, object_error, stable, pruned, score,"
                " generation, wall_s, finished_at) VALUES (?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?)"
                " ON CONFLICT(key) DO UPDATE SET fitness = excluded.fitness, wrist_error = excluded.wrist_error,"
                " object_error = excluded.object_error, stable = excluded.stable, pruned = excluded.pruned,"
                " score = excluded.score, generation = excluded.generation, wall_s = excluded.wall_s,"
                " finished_at = excluded.finished_at",
                (
                    self._key(x),
                    self._vector_out(x),
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
            self._record_residuals(x, residuals)

    def _record_evaluation_v3(self, x, score: Score, generation: int, wall_s: float, residuals) -> None:
        key = self._key(x)
        # a row stored again (a test, a caller outside the Evaluator) keeps its exact vector, and the best fitness
        # of each generation is read anew afterwards
        replaced = self.db.execute("SELECT 1 FROM evaluations WHERE key = ?", (key,)).fetchone() is not None
        exact = replaced or self._keeps_exact(generation, score.fitness)
        names = self._names()
        first = self._task_names is None  # the first score stored: its task names are the store's
        if first:
            names = [t.task for t in score.tasks]
        with self._writing():
            if first:
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
                    _float_bytes(x) if exact else None,
                    None if exact else np.ascontiguousarray(x, dtype=np.float32).tobytes(),
                    score.fitness,
                    score.wrist_error,
                    score.object_error,
                    int(score.stable),
                    int(score.pruned),
                    _encode_tasks_v3(score, names),
                    generation,
                    round(wall_s * 1000),
                    int(time.time()),
                ),
            )
            self._record_residuals(x, residuals)
        self._task_names = names
        if replaced:
            self._generation_best = None
        elif score.stable:
            self._note_stable(generation, score.fitness)

    def _record_residuals(self, x, residuals) -> None:
        if residuals is not None:
            self.db.execute("INSERT OR IGNORE INTO residuals VALUES (?, ?)", (self._key(x), _float_bytes(residuals)))

    def release_failures(self, retry: Callable[[Score], bool]) -> int:
        """Forget the failed evaluations ``retry`` picks that were never retried, so that a replay runs them again.

        Each is remembered in ``retried``: a failure is given one retry, never more.  Returns how many.
        """
        rows = self.db.execute(
            "SELECT key, fitness, wrist_error, object_error, score FROM evaluations"
            " WHERE stable = 0 AND key NOT IN (SELECT key FROM retried)"
        ).fetchall()
        keys = [(row[0],) for row in rows if retry(self._score_in(row[1:]))]
        with self._writing():
            self.db.executemany("INSERT OR IGNORE INTO retried VALUES (?)", keys)
            self.db.executemany("DELETE FROM evaluations WHERE key = ?", keys)
            self.db.executemany("DELETE FROM residuals WHERE key = ?", keys)
        return len(keys)

    def failed_scores(self) -> list[Score]:
        """The scores of the failed evaluations (blown up, crashed or timed out), in store order, each with why."""
        rows = self.db.execute(
            "SELECT fitness, wrist_error, object_error, score FROM evaluations WHERE stable = 0 ORDER BY id"
        ).fetchall()
        return [self._score_in(row) for row in rows]

    def lookup_residuals(self, x) -> np.ndarray | None:
        row = self.db.execute("SELECT r FROM residuals WHERE key = ?", (self._key(x),)).fetchone()
        return _floats(row[0]) if row else None

    def record_residuals(self, x, residuals) -> None:
        with self._writing():
            self._record_residuals(x, residuals)

    def count_evaluations(self) -> int:
        return self.db.execute("SELECT COUNT(*) FROM evaluations").fetchone()[0]

    def count_outcomes(self) -> dict[str, int]:
        """How many evaluations blew up or failed (penalised) and how many were pruned."""
        unstable, pruned = self.db.execute(
            "SELECT COALESCE(SUM(1 - stable), 0), COALESCE(SUM(pruned), 0) FROM evaluations"
        ).fetchone()
        return {"unstable": int(unstable), "pruned": int(pruned)}

    def evaluations(self) -> list[dict]:
        """Every evaluation in store order: its vector ``x`` (a list of floats), fitness, errors, outcome,
        generation and wall time.

        ``x`` is the exact vector where the store keeps it: always in versions 1 and 2; in version 3 for
        generation 0, the first generation stored and each evaluation that was the best so far (the best one
        among them), and for the others the float32 copy it keeps (about 7 significant digits; not a key).
        None where a store has neither.
        """
        rows = self.db.execute(
            f"SELECT {self._vector_columns}, fitness, wrist_error, object_error, stable, pruned, generation,"
            f" {self._wall_column} FROM evaluations ORDER BY id"
        ).fetchall()
        return [
            dict(
                x=self._vector_in(r[0], r[1]),
                fitness=r[2],
                wrist_error=r[3],
                object_error=r[4],
                stable=bool(r[5]),
                pruned=bool(r[6]),
                generation=r[7],
                wall_s=r[8],
            )
            for r in rows
        ]

    def initial_fitness(self) -> list[float]:
        """Fitness of every evaluation of the initial population (generation 0), in store order."""
        rows = self.db.execute("SELECT fitness FROM evaluations WHERE generation = 0 ORDER BY id").fetchall()
        return [float(r[0]) for r in rows]

    def initial_population(self) -> list[list[float]]:
        """The exact parameter vector of every evaluation of the initial population (generation 0), in store order."""
        rows = self.db.execute(
            f"SELECT {self._vector_columns} FROM evaluations WHERE generation = 0 ORDER BY id"
        ).fetchall()
        return [self._vector_in(*r) for r in rows]  # type: ignore[misc]  # exact in every version: never None

    def best_evaluation(self) -> dict | None:
        """The evaluation of the lowest fitness (the first stored of equals): its exact vector and its score."""
        row = self.db.execute(
            f"SELECT {self._vector_columns}, fitness, wrist_error, object_error, score FROM evaluations"
            " ORDER BY fitness, id LIMIT 1"
        ).fetchone()
        if row is None:
            return None
        return {"x": self._vector_in(row[0], row[1]), "score": self._score_in(row[2:]).to_dict()}

    # --- generation checkpoints ---------------------------------------------------------------
    def record_generation(
        self,
        generation: int,
        population,
        energies,
        best_x,
        best_fitness: float,
        evaluations: int,
        elapsed_s: float,
        keep_population: bool = True,
    ) -> None:
        """Checkpoint a generation.  A resumed run replays its earlier generations: one found stored with the same
        population and energies keeps the evaluation count and time of when it was first reached; one that
        differs (the replay took another path, e.g. after a retried evaluation) replaces it and every later one.

        With ``keep_population`` (a search's population, which ``resume --rescore`` starts from) the population
        is stored and those of earlier generations are dropped: only the latest is ever read.  Without (a
        refinement's batch of points), only its digest is.  Version 1 stores keep every population, as before.
        ``best_x`` is stored by versions 1 and 2 only (nothing reads it; in version 3 the best evaluation up to
        this generation holds it, exact).
        """
        population = np.atleast_2d(np.asarray(population, dtype=np.float64))
        energies = np.asarray(energies, dtype=np.float64).ravel()
        with self._writing():
            if self._legacy:
                self._record_generation_v1(
                    generation, population, energies, best_x, best_fitness, evaluations, elapsed_s
                )
                return
            digest = _population_digest(population, energies)
            stored = self.db.execute("SELECT digest FROM generations WHERE generation = ?", (generation,)).fetchone()
            if stored is not None and stored[0] == digest:
                if keep_population:  # a replay reached the latest population again: keep it (it may be dropped)
                    self.db.execute(
                        "UPDATE generations SET population = ?, energies = ? WHERE generation = ?",
                        (_float_bytes(population), _float_bytes(energies), generation),
                    )
                    self.db.execute(
                        "UPDATE generations SET population = NULL, energies = NULL WHERE generation < ?", (generation,)
                    )
                return
            if stored is not None:
                self.db.execute("DELETE FROM generations WHERE generation >= ?", (generation,))
            if keep_population:
                self.db.execute(
                    "UPDATE generations SET population = NULL, energies = NULL WHERE generation < ?", (generation,)
                )
            row = {
                "generation": generation,
                "best_fitness": float(best_fitness),
                "population": _float_bytes(population) if keep_population else None,
                "energies": _float_bytes(energies) if keep_population else None,
                "evaluations": evaluations,
                "elapsed_s": elapsed_s,
                "finished_at": time.time(),
                "digest": digest,
            }
            if self.version == 2:  # version 3 leaves the best point out: it is the best evaluation up to here
                row["best_x"] = _float_bytes(best_x)
            self.db.execute(
                f"INSERT INTO generations ({', '.join(row)}) VALUES ({', '.join('?' * len(row))})", tuple(row.values())
            )

    def _record_generation_v1(self, generation, population, energies, best_x, best_fitness, evaluations, elapsed_s):
        population_json = json.dumps(population.tolist())
        energies_json = json.dumps([float(e) for e in energies])
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
                float(best_fitness),
                json.dumps([float(v) for v in best_x]),
                population_json,
                energies_json,
                evaluations,
                elapsed_s,
                time.time(),
            ),
        )

    def generations(self) -> list[dict]:
        rows = self.db.execute(
            "SELECT generation, best_fitness, evaluations, elapsed_s FROM generations ORDER BY generation"
        ).fetchall()
        return [dict(generation=r[0], best_fitness=r[1], evaluations=r[2], elapsed_s=r[3]) for r in rows]

    def last_checkpoint(self, up_to: int | None = None) -> dict | None:
        """The latest generation checkpoint that holds a population (with ``up_to``: at or before that generation)."""
        row = self.db.execute(
            "SELECT generation, population, energies, elapsed_s FROM generations"
            " WHERE generation <= ? AND population IS NOT NULL ORDER BY generation DESC LIMIT 1",
            (up_to if up_to is not None else 2**62,),
        ).fetchone()
        if row is None:
            return None
        if self._legacy:
            return dict(
                generation=row[0],
                population=np.array(json.loads(row[1])),
                energies=np.array(json.loads(row[2])),
                elapsed_s=row[3],
            )
        energies = _floats(row[2])
        return dict(
            generation=row[0],
            population=_floats(row[1]).reshape(len(energies), -1),
            energies=energies,
            elapsed_s=row[3],
        )

    def close(self) -> None:
        self.db.close()
