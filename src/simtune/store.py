"""The run store: one SQLite file per run folder, holding every evaluation.

Tables
- ``meta``: key -> JSON value (the run's configuration, versions, command line, status);
- ``evaluations``: one row per finished evaluation: the parameter vector, its
  fitness and parts, generation, wall time, whether the simulation was stable,
  and whether it was pruned (stopped once it could not beat its parent: its
  fitness is then a lower bound);
- ``generations``: one row per generation: the best member, the evaluation count and
  the run's elapsed time, a digest of the population and its energies (a replayed
  generation is recognised by it), and the population itself only where ``resume
  --rescore`` may need it: the latest checkpoint that holds a population;
- ``residuals``: for the evaluations of a least-squares refinement, the residual
  vector (float64 bytes), so a resumed refinement replays without simulating;
- ``retried``: the keys of failed evaluations already given their one retry
  (:meth:`RunStore.release_failures`).

Store version 2 (this one) writes vectors, populations and keys as float64 and
SHA-1 bytes and each score's per-task parts as compact JSON: about 0.6 kB per
evaluation of the 61-parameter space instead of 1.9 kB, and one population
instead of one per generation.  Version 1 stores (JSON text everywhere, every
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
from simtune.fitness import Score, TaskScore

STORE_FILE = "run.sqlite"
SCHEMA_VERSION = 2
#: store versions this simtune reads and writes (1: vectors and populations as JSON text)
READABLE_VERSIONS = (1, 2)
MIN_FREE_BYTES = 50_000_000

_SCHEMA = """
CREATE TABLE IF NOT EXISTS meta (key TEXT PRIMARY KEY, value TEXT NOT NULL);
CREATE TABLE IF NOT EXISTS evaluations (
    id INTEGER PRIMARY KEY,
    key BLOB UNIQUE NOT NULL,
    x BLOB NOT NULL,
    fitness REAL NOT NULL,
    wrist_error REAL,
    object_error REAL,
    stable INTEGER NOT NULL,
    pruned INTEGER NOT NULL DEFAULT 0,
    score TEXT NOT NULL,
    generation INTEGER NOT NULL,
    wall_s REAL NOT NULL,
    finished_at REAL NOT NULL
);
CREATE TABLE IF NOT EXISTS generations (
    generation INTEGER PRIMARY KEY,
    best_fitness REAL NOT NULL,
    best_x BLOB NOT NULL,
    population BLOB,
    energies BLOB,
    evaluations INTEGER NOT NULL,
    elapsed_s REAL NOT NULL,
    finished_at REAL NOT NULL,
    digest BLOB NOT NULL
);
CREATE TABLE IF NOT EXISTS residuals (key BLOB PRIMARY KEY, r BLOB NOT NULL);
CREATE TABLE IF NOT EXISTS retried (key BLOB PRIMARY KEY);
"""
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


def _encode_tasks(score: Score) -> str:
    """A score's per-task parts as compact JSON: parts at their default value left out, and with one task, its
    totals (they are the score's, stored in their columns)."""
    tasks = []
    for task in score.tasks:
        parts = {k: v for k, v in asdict(task).items() if k not in _TASK_DEFAULTS or v != _TASK_DEFAULTS[k]}
        if len(score.tasks) == 1 and all(parts[k] == getattr(score, k) for k in _TOTALS):
            parts = {k: v for k, v in parts.items() if k not in _TOTALS}
        tasks.append(parts)
    return json.dumps(tasks, separators=(",", ":"))


def _decode_score(fitness: float, wrist_error: float, object_error: float | None, tasks: str) -> Score:
    totals = {"fitness": fitness, "wrist_error": wrist_error, "object_error": object_error}
    parts = [TaskScore(**{**totals, **t}) for t in json.loads(tasks)]
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

    ``RunStore(run_dir)`` opens it for writing; :meth:`open_read_only` for reading alone.
    A version 1 store is read and written in its own format (``self.version``).
    """

    read_only = False
    version = SCHEMA_VERSION

    def __init__(self, run_dir: Path, create: bool = False, filename: str = STORE_FILE):
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
        try:
            self.db = sqlite3.connect(self.path, timeout=30)
            self.db.execute("PRAGMA journal_mode=WAL")
            self.db.execute("PRAGMA synchronous=NORMAL")
            self.db.executescript(_SCHEMA)  # a version 1 store has its tables already: left as they are
        except sqlite3.Error as exc:
            raise SimtuneError(f"{self.path}: cannot open run store ({exc})") from None
        if create and self.get("schema_version") is None:
            self.set(schema_version=SCHEMA_VERSION)
        self.version = self.get("schema_version")
        _check_version(self.path, self.version)

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

    # --- the two formats: version 1 (JSON text, hex keys) and this one (float64 and digest bytes) -------------
    @property
    def _legacy(self) -> bool:
        return self.version == 1

    def _key(self, x) -> str | bytes:
        digest = hashlib.sha1(_float_bytes(x))
        return digest.hexdigest() if self._legacy else digest.digest()

    def _vector_out(self, x) -> str | bytes:
        return json.dumps([float(v) for v in x]) if self._legacy else _float_bytes(x)

    def _vector_in(self, stored) -> list[float]:
        return json.loads(stored) if self._legacy else _floats(stored).tolist()

    def _score_in(self, row) -> Score:
        """The score of a row (fitness, wrist_error, object_error, score)."""
        if self._legacy:
            return Score.from_dict(json.loads(row[3]))
        return _decode_score(*row)

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
        earlier for the same vector is replaced (in its place: same id)."""
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
            if residuals is not None:
                self.db.execute(
                    "INSERT OR IGNORE INTO residuals VALUES (?, ?)", (self._key(x), _float_bytes(residuals))
                )

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

    def lookup_residuals(self, x) -> np.ndarray | None:
        row = self.db.execute("SELECT r FROM residuals WHERE key = ?", (self._key(x),)).fetchone()
        return _floats(row[0]) if row else None

    def record_residuals(self, x, residuals) -> None:
        with self._writing():
            self.db.execute("INSERT OR IGNORE INTO residuals VALUES (?, ?)", (self._key(x), _float_bytes(residuals)))

    def count_evaluations(self) -> int:
        return self.db.execute("SELECT COUNT(*) FROM evaluations").fetchone()[0]

    def count_outcomes(self) -> dict[str, int]:
        """How many evaluations blew up or failed (penalised) and how many were pruned."""
        unstable, pruned = self.db.execute(
            "SELECT COALESCE(SUM(1 - stable), 0), COALESCE(SUM(pruned), 0) FROM evaluations"
        ).fetchone()
        return {"unstable": int(unstable), "pruned": int(pruned)}

    def evaluations(self) -> list[dict]:
        rows = self.db.execute(
            "SELECT x, fitness, wrist_error, object_error, stable, pruned, generation, wall_s FROM evaluations"
            " ORDER BY id"
        ).fetchall()
        return [
            dict(
                x=self._vector_in(r[0]),
                fitness=r[1],
                wrist_error=r[2],
                object_error=r[3],
                stable=bool(r[4]),
                pruned=bool(r[5]),
                generation=r[6],
                wall_s=r[7],
            )
            for r in rows
        ]

    def initial_fitness(self) -> list[float]:
        """Fitness of every evaluation of the initial population (generation 0), in store order."""
        rows = self.db.execute("SELECT fitness FROM evaluations WHERE generation = 0 ORDER BY id").fetchall()
        return [float(r[0]) for r in rows]

    def initial_population(self) -> list[list[float]]:
        """The parameter vector of every evaluation of the initial population (generation 0), in store order."""
        rows = self.db.execute("SELECT x FROM evaluations WHERE generation = 0 ORDER BY id").fetchall()
        return [self._vector_in(r[0]) for r in rows]

    def best_evaluation(self) -> dict | None:
        row = self.db.execute(
            "SELECT x, fitness, wrist_error, object_error, score FROM evaluations ORDER BY fitness, id LIMIT 1"
        ).fetchone()
        return None if row is None else {"x": self._vector_in(row[0]), "score": self._score_in(row[1:]).to_dict()}

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
            self.db.execute(
                "INSERT INTO generations (generation, best_fitness, best_x, population, energies, evaluations,"
                " elapsed_s, finished_at, digest) VALUES (?, ?, ?, ?, ?, ?, ?, ?, ?)",
                (
                    generation,
                    float(best_fitness),
                    _float_bytes(best_x),
                    _float_bytes(population) if keep_population else None,
                    _float_bytes(energies) if keep_population else None,
                    evaluations,
                    elapsed_s,
                    time.time(),
                    digest,
                ),
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
