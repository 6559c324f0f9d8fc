"""The run store of one run folder: :class:`RunStore`, which holds a run through its version's codec."""

from __future__ import annotations

import json
import shutil
import sqlite3
from collections.abc import Callable
from contextlib import contextmanager
from pathlib import Path

import numpy as np

from simtune.errors import SimtuneError
from simtune.fitness import Score
from simtune.store.codec import Checkpoint, Codec, float_bytes, floats
from simtune.store.v1 import JsonCodec
from simtune.store.v2 import Float64Codec
from simtune.store.v3 import CompactCodec

STORE_FILE = "run.sqlite"
SCHEMA_VERSION = 3
#: the codec of each store version this simtune reads and resumes (1: vectors and populations as JSON text;
#: 2: every vector as float64; 3: exact vectors where read)
CODECS: dict[int, Callable[[sqlite3.Connection], Codec]] = {1: JsonCodec, 2: Float64Codec, 3: CompactCodec}
READABLE_VERSIONS = tuple(CODECS)
MIN_FREE_BYTES = 50_000_000

#: the tables of a store of this version
_SCHEMA = CompactCodec.schema
_OWN_TABLES = frozenset({"meta", "evaluations", "generations", "residuals", "retried"})


def check_store_file(path: Path) -> bool:
    """Refuse a file that is not a run store of this simtune's schema, reading it only (one line naming it).

    A foreign SQLite file (or any other file) named ``run.sqlite`` is left exactly as it was.  False for a
    store that was never set up: an empty database, or one holding only simtune's tables, empty, and no schema
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
            # a store whose process died while creating it holds simtune's tables, empty: rows in them without a
            # schema version are someone else's (a user's table named meta), never replaced
            filled = row is None and any(
                db.execute(f'SELECT 1 FROM "{table}" LIMIT 1').fetchone() is not None for table in tables & _OWN_TABLES
            )
        finally:
            db.close()
    except sqlite3.DatabaseError as exc:
        raise SimtuneError(f"{path} cannot be read as a run store ({exc}); it was left unchanged") from None
    if row is None:
        if filled:
            raise SimtuneError(
                f"{path} is not a simtune run store (its tables hold rows but no simtune schema version); "
                "it was left unchanged"
            )
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


class RunStore:
    """SQLite store of one run.  Only the coordinating process writes to it.

    ``RunStore(run_dir)`` opens it for writing; :meth:`open_read_only` for reading alone.  Whatever depends on
    the store's version is its codec's (:attr:`codec`): a store of an older version is read and resumed in its
    own format.  A new store is of the current version; ``version=`` creates an older one, only to compare
    formats (``benchmarks/store_size.py``).
    """

    read_only = False

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
        try:
            self.db = sqlite3.connect(self.path, timeout=30)
            self.db.execute("PRAGMA journal_mode=WAL")
            self.db.execute("PRAGMA synchronous=NORMAL")
            stored = self._stored_version()
            self.version = stored if stored is not None else (version or SCHEMA_VERSION)
            _check_version(self.path, self.version)
            self.codec = CODECS[self.version](self.db)
            # an existing store has its tables already: left as they are (one its version lacks is added)
            self.db.executescript(self.codec.schema)
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
            _check_version(store.path, store.version)
        except (sqlite3.Error, SimtuneError):
            store.db.close()
            raise
        store.codec = CODECS[store.version](store.db)
        return store

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
            "SELECT fitness, wrist_error, object_error, score FROM evaluations WHERE key = ?", (self.codec.key(x),)
        ).fetchone()
        return None if row is None else self.codec.score_in(row)

    def record_evaluation(self, x, score: Score, generation: int, wall_s: float, residuals=None) -> None:
        """Store an evaluation (with ``residuals``: its residual vector too, in the same transaction); one stored
        earlier for the same vector is replaced (in its place: same id; in version 3 with its exact vector)."""
        with self._writing():
            committed = self.codec.write_evaluation(x, score, generation, wall_s)
            self._record_residuals(x, residuals)
        committed()

    def _record_residuals(self, x, residuals) -> None:
        if residuals is not None:
            self.db.execute(
                "INSERT OR IGNORE INTO residuals VALUES (?, ?)", (self.codec.key(x), float_bytes(residuals))
            )

    def _unretried_failures(self, retry: Callable[[Score], bool]) -> list[tuple]:
        """The keys of the failed evaluations ``retry`` picks that were never retried."""
        rows = self.db.execute(
            "SELECT key, fitness, wrist_error, object_error, score FROM evaluations"
            " WHERE stable = 0 AND key NOT IN (SELECT key FROM retried)"
        ).fetchall()
        return [(row[0],) for row in rows if retry(self.codec.score_in(row[1:]))]

    def has_failures_to_retry(self, retry: Callable[[Score], bool]) -> bool:
        """Whether :meth:`release_failures` would release any (a finished run with one is resumed, not given back)."""
        return bool(self._unretried_failures(retry))

    def release_failures(self, retry: Callable[[Score], bool]) -> int:
        """Forget the failed evaluations ``retry`` picks that were never retried, so that a replay runs them again.

        Each is remembered in ``retried``: a failure is given one retry, never more.  Returns how many.
        """
        keys = self._unretried_failures(retry)
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
        return [self.codec.score_in(row) for row in rows]

    def lookup_residuals(self, x) -> np.ndarray | None:
        row = self.db.execute("SELECT r FROM residuals WHERE key = ?", (self.codec.key(x),)).fetchone()
        return floats(row[0]) if row else None

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

    def last_finished_at(self) -> float | None:
        """When the last stored evaluation finished (seconds since the epoch); None without evaluations."""
        row = self.db.execute("SELECT MAX(finished_at) FROM evaluations").fetchone()
        return float(row[0]) if row and row[0] is not None else None

    def evaluations(self) -> list[dict]:
        """Every evaluation in store order: its vector ``x`` (a list of floats), fitness, errors, outcome,
        generation and wall time.

        ``x`` is the exact vector where the store keeps it: always in versions 1 and 2; in version 3 for
        generation 0, the first generation stored and each evaluation that was the best so far (the best one
        among them), and for the others the float32 copy it keeps (about 7 significant digits; not a key).
        None where a store has neither.
        """
        rows = self.db.execute(
            f"SELECT {self.codec.vector_columns}, fitness, wrist_error, object_error, stable, pruned, generation,"
            f" {self.codec.wall_column} FROM evaluations ORDER BY id"
        ).fetchall()
        return [
            dict(
                x=self.codec.vector_in(r[0], r[1]),
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
            f"SELECT {self.codec.vector_columns} FROM evaluations WHERE generation = 0 ORDER BY id"
        ).fetchall()
        return [self.codec.vector_in(*r) for r in rows]  # type: ignore[misc]  # exact in every version: never None

    def best_evaluation(self) -> dict | None:
        """The evaluation of the lowest fitness (the first stored of equals): its exact vector and its score."""
        row = self.db.execute(
            f"SELECT {self.codec.vector_columns}, fitness, wrist_error, object_error, score FROM evaluations"
            " ORDER BY fitness, id LIMIT 1"
        ).fetchone()
        if row is None:
            return None
        return {"x": self.codec.vector_in(row[0], row[1]), "score": self.codec.score_in(row[2:]).to_dict()}

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
            checkpoint = Checkpoint(generation, population, energies, best_x, best_fitness, evaluations, elapsed_s)
            self.codec.write_generation(checkpoint, keep_population)

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
        population, energies = self.codec.checkpoint_in(row[1], row[2])
        return dict(generation=row[0], population=population, energies=energies, elapsed_s=row[3])

    def close(self) -> None:
        self.db.close()
