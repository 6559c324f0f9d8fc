"""The grid's index: one row per unit (status, attempts, summary), written by the coordinator alone.

:class:`GridIndex` is the interface and holds the queries, written once in the SQL that
SQLite (>= 3.24) and PostgreSQL share; :class:`SQLiteGridIndex` (``GRID/grid.sqlite``, the
default) and :class:`PostgresGridIndex` (a database given by URL, shared by many grids)
supply the connection, the driver's parameter style and transactions.
"""

from __future__ import annotations

import re
import sqlite3
import time
from abc import ABC, abstractmethod
from collections.abc import Iterator
from contextlib import AbstractContextManager, contextmanager
from pathlib import Path
from typing import TYPE_CHECKING, Any

from simtune.errors import ConfigError, SimtuneError
from simtune.grid.spec import Unit

if TYPE_CHECKING:
    import psycopg

INDEX_FILE = "grid.sqlite"

# Rows are keyed by grid, so one PostgreSQL database can index many grids.  DOUBLE PRECISION,
# not REAL: PostgreSQL's REAL is single precision.
_SCHEMA = [
    """CREATE TABLE IF NOT EXISTS grid_units (
        grid TEXT NOT NULL, id TEXT NOT NULL,
        engine TEXT NOT NULL, tasks TEXT NOT NULL, space TEXT NOT NULL, seed INTEGER NOT NULL,
        run_dir TEXT NOT NULL,
        status TEXT NOT NULL DEFAULT 'pending',   -- pending, running, done, failed
        attempts INTEGER NOT NULL DEFAULT 0,
        fitness DOUBLE PRECISION, generic_fitness DOUBLE PRECISION, evaluations INTEGER, generations INTEGER,
        wall_s DOUBLE PRECISION, error TEXT, updated_at DOUBLE PRECISION,
        PRIMARY KEY (grid, id))""",
    """CREATE TABLE IF NOT EXISTS grid_meta (
        grid TEXT NOT NULL, key TEXT NOT NULL, value TEXT NOT NULL, PRIMARY KEY (grid, key))""",
]
_UNIT_COLUMNS = (
    "id, engine, tasks, space, seed, run_dir, status, attempts, fitness, generic_fitness, "
    "evaluations, generations, wall_s, error, updated_at"
)


class GridIndex(ABC):
    """The grid's table of units.  Only the coordinating process opens it (see :func:`open_index`).

    Subclasses connect, run one statement (:meth:`_execute`, SQL with ``?`` placeholders) and
    group statements into a transaction (:meth:`_transaction`); every query is written here.
    """

    #: where the index is, for messages (a PostgreSQL URL without its password)
    location: str
    #: the grid's rows in the tables: "" for a file of its own, the grid folder in a shared database
    key: str

    def __init__(self, grid_dir: Path):
        self.grid_dir = Path(grid_dir)
        try:
            self.grid_dir.mkdir(parents=True, exist_ok=True)
        except OSError as exc:
            raise SimtuneError(f"cannot create grid folder {self.grid_dir}: {exc.strerror}") from None

    def _create_schema(self) -> None:
        with self._transaction():
            for statement in _SCHEMA:
                self._execute(statement)

    # --- what a back end supplies ----------------------------------------------------------
    @abstractmethod
    def _execute(self, sql: str, params: tuple = ()) -> Any:
        """Run one statement written with ``?`` placeholders; return its cursor."""

    @abstractmethod
    def _transaction(self) -> AbstractContextManager[None]:
        """A transaction around the statements run inside it: committed at the end, rolled back on an error."""

    @abstractmethod
    def close(self) -> None:
        """Close the connection."""

    # --- the index ---------------------------------------------------------------------------
    def run_dir(self, unit: Unit) -> Path:
        return self.grid_dir / "runs" / unit.id

    def add(self, units: list[Unit]) -> None:
        """Add the units not in the index yet (as pending); rows of known units are kept."""
        with self._transaction():
            for u in units:
                self._execute(
                    "INSERT INTO grid_units (grid, id, engine, tasks, space, seed, run_dir, updated_at)"
                    " VALUES (?, ?, ?, ?, ?, ?, ?, ?) ON CONFLICT (grid, id) DO NOTHING",
                    (self.key, u.id, u.engine, u.tasks, u.space, u.seed, str(self.run_dir(u)), time.time()),
                )

    def set_meta(self, key: str, value: str) -> None:
        self._execute(
            "INSERT INTO grid_meta (grid, key, value) VALUES (?, ?, ?)"
            " ON CONFLICT (grid, key) DO UPDATE SET value = excluded.value",
            (self.key, key, value),
        )

    def status(self, unit: Unit) -> str:
        return self._execute("SELECT status FROM grid_units WHERE grid = ? AND id = ?", (self.key, unit.id)).fetchone()[
            0
        ]

    def mark(self, unit: Unit, status: str, summary: dict | None = None, error: str | None = None) -> None:
        """Set a unit's status (a new attempt when it becomes ``running``), its summary and last error."""
        summary = summary or {}
        self._execute(
            "UPDATE grid_units SET status = ?, attempts = attempts + ?, fitness = COALESCE(?, fitness),"
            " generic_fitness = COALESCE(?, generic_fitness), evaluations = COALESCE(?, evaluations),"
            " generations = COALESCE(?, generations), wall_s = COALESCE(?, wall_s), error = ?, updated_at = ?"
            " WHERE grid = ? AND id = ?",
            (
                status,
                1 if status == "running" else 0,
                summary.get("fitness"),
                summary.get("generic_fitness"),
                summary.get("evaluations"),
                summary.get("generations"),
                summary.get("wall_s"),
                error,
                time.time(),
                self.key,
                unit.id,
            ),
        )

    def attempts(self, unit: Unit) -> int:
        return self._execute(
            "SELECT attempts FROM grid_units WHERE grid = ? AND id = ?", (self.key, unit.id)
        ).fetchone()[0]

    def rows(self) -> list[dict]:
        cur = self._execute(f"SELECT {_UNIT_COLUMNS} FROM grid_units WHERE grid = ? ORDER BY id", (self.key,))
        names = [d[0] for d in cur.description]
        return [dict(zip(names, r)) for r in cur.fetchall()]

    def counts(self) -> dict[str, int]:
        return dict(
            self._execute(
                "SELECT status, COUNT(*) FROM grid_units WHERE grid = ? GROUP BY status", (self.key,)
            ).fetchall()
        )

    def best(self) -> Iterator[tuple[str, str, float]]:
        """(engine, tasks, best fitness so far) over finished units."""
        yield from self._execute(
            "SELECT engine, tasks, MIN(fitness) FROM grid_units WHERE grid = ? AND status = 'done'"
            " GROUP BY engine, tasks ORDER BY engine, tasks",
            (self.key,),
        ).fetchall()


class SQLiteGridIndex(GridIndex):
    """The index as ``GRID/grid.sqlite``, a file of the grid's own."""

    def __init__(self, grid_dir: Path):
        super().__init__(grid_dir)
        self.location = str(self.grid_dir / INDEX_FILE)
        self.key = ""
        check_index_file(Path(self.location))  # read-only: a user's file of that name is never written
        try:
            # autocommit: a statement outside _transaction() is committed at once
            self.db = sqlite3.connect(self.location, timeout=30, isolation_level=None)
            self.db.execute("PRAGMA journal_mode=WAL")
            self._create_schema()
        except sqlite3.DatabaseError as exc:
            raise SimtuneError(f"cannot open grid index {self.location}: {exc}") from None

    def _execute(self, sql: str, params: tuple = ()) -> sqlite3.Cursor:
        return self.db.execute(sql, params)

    @contextmanager
    def _transaction(self) -> Iterator[None]:
        self.db.execute("BEGIN IMMEDIATE")
        try:
            yield
        except BaseException:
            self.db.execute("ROLLBACK")
            raise
        self.db.execute("COMMIT")

    def close(self) -> None:
        self.db.close()


def check_index_file(path: Path) -> None:
    """Refuse a ``grid.sqlite`` that is not a grid index (one line naming it), reading it only.

    A missing or empty file, or a SQLite database holding no tables or the index's own, is an index (to be set up);
    anything else (a file that is not a database, a database of other tables) is someone's own and is left exactly as
    it was.

    Args:
        path: the index file.
    """
    if not path.exists() or (path.is_file() and path.stat().st_size == 0):
        return
    if not path.is_file():
        raise SimtuneError(f"{path} is not a grid index (not a file): move it away or choose another grid folder")
    try:
        db = sqlite3.connect(path.resolve().as_uri() + "?mode=ro", uri=True)
        try:
            tables = {row[0] for row in db.execute("SELECT name FROM sqlite_master WHERE type = 'table'")}
        finally:
            db.close()
    except sqlite3.DatabaseError as exc:
        raise SimtuneError(
            f"{path} is not a grid index ({exc}); it was left unchanged: move it away or choose another grid folder"
        ) from None
    if tables and "grid_units" not in tables:
        raise SimtuneError(
            f"{path} is not a grid index (a SQLite database without its table grid_units); it was left unchanged: "
            "move it away or choose another grid folder"
        )


class PostgresGridIndex(GridIndex):
    """The index in a PostgreSQL database given by URL: a long-lived, shared record of many grids.

    Rows are keyed by the grid folder's absolute path.  Needs ``pip install 'simtune[postgres]'``.
    """

    def __init__(self, grid_dir: Path, url: str):
        if not re.match(r"postgres(ql)?://", url):
            raise ConfigError(f"--index {redact(url)!r} is not a postgresql:// URL (leave it out for GRID/grid.sqlite)")
        try:
            import psycopg
        except ImportError:
            raise SimtuneError("a PostgreSQL grid index needs psycopg: pip install 'simtune[postgres]'") from None
        super().__init__(grid_dir)
        self.location = redact(url)
        self.key = str(self.grid_dir.resolve())
        try:
            # autocommit: a statement outside _transaction() is committed at once
            self.db: psycopg.Connection = psycopg.connect(url, autocommit=True, connect_timeout=10)
        except psycopg.Error as exc:
            reason = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
            raise SimtuneError(f"cannot open grid index {self.location}: {reason}") from None
        self._create_schema()

    def _execute(self, sql: str, params: tuple = ()) -> psycopg.Cursor:
        return self.db.execute(sql.replace("?", "%s"), params)  # psycopg's placeholder is %s

    @contextmanager
    def _transaction(self) -> Iterator[None]:
        with self.db.transaction():
            yield

    def close(self) -> None:
        self.db.close()


def open_index(grid_dir: Path, url: str | None = None) -> GridIndex:
    """The index of the grid in ``grid_dir``: ``grid_dir/grid.sqlite``, or the PostgreSQL database at ``url``."""
    return SQLiteGridIndex(grid_dir) if url is None else PostgresGridIndex(grid_dir, url)


def redact(url: str) -> str:
    """``url`` without its password, for messages."""
    return re.sub(r"//([^:/@]+):[^@]*@", r"//\1:***@", url)
