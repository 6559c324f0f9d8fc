"""Experiment grids: engines x tasks x spaces x repeats, one optimisation per unit of work.

Each unit is an ordinary run folder (``GRID/runs/<engine>-<task>-<space>-s<seed>``)
with its own run store, written only by the worker running it.  The grid's index
(``GRID/grid.sqlite``, or tables in a PostgreSQL database that many grids
share) is written only by the coordinating process, so no store ever needs
locking across machines.

Running the same grid again skips finished units and resumes unfinished ones
from their stores; a unit whose worker dies is retried (on another worker,
under Dask) and resumes from what the dead worker committed, so nothing is
lost or counted twice.  Executors: ``local`` (a process pool here) or ``dask``
(any ``distributed`` scheduler; a ``LocalCluster`` when no address is given;
``dask-jobqueue`` clusters for SLURM/PBS work the same way).
"""

from __future__ import annotations

import json
import re
import sqlite3
import time
from collections.abc import Callable, Iterator
from concurrent.futures import ProcessPoolExecutor, as_completed
from concurrent.futures.process import BrokenProcessPool
from contextlib import contextmanager
from dataclasses import asdict, dataclass
from pathlib import Path

from simtune.errors import ConfigError, SimtuneError

INDEX_FILE = "grid.sqlite"
MAX_ATTEMPTS = 3

# One schema for both back ends (SQLite >= 3.24 and PostgreSQL share this SQL; PostgreSQL's REAL
# would be single precision): rows are
# keyed by grid, so one PostgreSQL database can index many grids.
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


@dataclass(frozen=True)
class Unit:
    """One optimisation of the grid."""

    engine: str
    tasks: str  # "cube", or "single,cube" for tasks tuned together
    space: str
    seed: int

    @property
    def id(self) -> str:
        return f"{self.engine}-{self.tasks.replace(',', '+')}-{self.space}-s{self.seed}"


@dataclass
class GridSpec:
    engines: list[str]
    tasks: list[str]  # each entry one experiment; "single+cube" tunes both at once
    spaces: list[str]
    repeats: int
    data: str
    max_seconds_per_run: float | None = None
    max_generations: int = 1000
    only: list[str] | None = None  # tune just these parameters of each space

    def units(self) -> list[Unit]:
        return [
            Unit(e, t.replace("+", ","), s, r)
            for e in self.engines
            for t in self.tasks
            for s in self.spaces
            for r in range(self.repeats)
        ]

    def validate(self) -> None:
        """Fail before any compute on an unknown engine, task or space, or missing data."""
        from simtune.engines import engine_class
        from simtune.objective import load_references
        from simtune.params import get_space
        from simtune.tasks import parse_tasks

        if self.repeats < 1:
            raise ConfigError("--repeats must be at least 1")
        for name in self.engines:
            for space in self.spaces:
                get_space(space, engine_class(name).supported(), self.only)
        tasks = {t.name: t for entry in self.tasks for t in parse_tasks(entry.replace("+", ","))}
        load_references(Path(self.data), list(tasks.values()))


# --- the unit of work (runs in a worker process) --------------------------------------
def run_unit(unit: Unit, run_dir: str, spec: GridSpec) -> dict:
    """Run or resume one optimisation; returns its summary.  Safe to run again after a crash."""
    from simtune.runlock import run_lock
    from simtune.runs import RunConfig, has_run, resume_run, start_run
    from simtune.store import RunStore

    path = Path(run_dir)
    config = RunConfig(
        engine=unit.engine,
        tasks=unit.tasks,
        space=unit.space,
        data=spec.data,
        seed=unit.seed,
        workers=1,
        max_seconds=spec.max_seconds_per_run,
        max_generations=spec.max_generations,
        only=spec.only,
    )
    try:
        path.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise SimtuneError(f"cannot create run folder {path}: {exc.strerror}") from None
    with run_lock(path):  # one writer: a unit still running elsewhere (a worker thought lost) refuses this one
        if has_run(path):
            result = resume_run(path, show_progress=False)
        else:  # new, or died before the run was set up: start_run clears such a store
            result = start_run(config, path, show_progress=False)
    store = RunStore(path)
    summary = dict(
        fitness=result.score.fitness,
        generic_fitness=store.get("generic")["fitness"],
        evaluations=result.evaluations,
        generations=result.generations,
        wall_s=result.wall_s,
    )
    store.close()
    return summary


# --- the grid's index (coordinator only) -------------------------------------------------
class GridIndex:
    """The grid's table of units: ``GRID/grid.sqlite``, or a PostgreSQL database given by URL.

    A PostgreSQL index suits a long-lived, shared record of many grids (rows are
    keyed by the grid folder's absolute path); it needs ``pip install
    'simtune[postgres]'``.  Either way only the coordinating process writes it.
    """

    def __init__(self, grid_dir: Path, url: str | None = None):
        self.grid_dir = Path(grid_dir)
        try:
            self.grid_dir.mkdir(parents=True, exist_ok=True)
        except OSError as exc:
            raise SimtuneError(f"cannot create grid folder {self.grid_dir}: {exc.strerror}") from None
        if url is None:
            self.location = str(self.grid_dir / INDEX_FILE)
            self.key = ""  # the file belongs to this grid alone
            self.db = sqlite3.connect(self.location, timeout=30, isolation_level=None)
            self.db.execute("PRAGMA journal_mode=WAL")
            self._placeholder = "?"
        else:
            self.location = _redact(url)
            self.key = str(self.grid_dir.resolve())
            self.db = _connect_postgres(url)
            self._placeholder = "%s"
        with self._transaction():
            for statement in _SCHEMA:
                self._execute(statement)

    def _execute(self, sql: str, params: tuple = ()):
        return self.db.execute(sql.replace("?", self._placeholder), params)

    @contextmanager
    def _transaction(self):
        if self._placeholder == "?":
            self.db.execute("BEGIN IMMEDIATE")
            try:
                yield
            except BaseException:
                self.db.execute("ROLLBACK")
                raise
            self.db.execute("COMMIT")
        else:
            with self.db.transaction():
                yield

    def add(self, units: list[Unit]) -> None:
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

    def run_dir(self, unit: Unit) -> Path:
        return self.grid_dir / "runs" / unit.id

    def status(self, unit: Unit) -> str:
        return self._execute("SELECT status FROM grid_units WHERE grid = ? AND id = ?", (self.key, unit.id)).fetchone()[
            0
        ]

    def mark(self, unit: Unit, status: str, summary: dict | None = None, error: str | None = None) -> None:
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

    def close(self) -> None:
        self.db.close()


def _redact(url: str) -> str:
    """``url`` without its password, for messages."""
    return re.sub(r"//([^:/@]+):[^@]*@", r"//\1:***@", url)


def _connect_postgres(url: str):
    if not re.match(r"postgres(ql)?://", url):
        raise ConfigError(f"--index {_redact(url)!r} is not a postgresql:// URL (leave it out for GRID/grid.sqlite)")
    try:
        import psycopg
    except ImportError:
        raise SimtuneError("a PostgreSQL grid index needs psycopg: pip install 'simtune[postgres]'") from None
    try:
        return psycopg.connect(url, autocommit=True, connect_timeout=10)
    except psycopg.Error as exc:
        reason = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
        raise SimtuneError(f"cannot open grid index {_redact(url)}: {reason}") from None


# --- executors ----------------------------------------------------------------------------
Submit = Callable[[Unit], None]


def _run_local(spec: GridSpec, index: GridIndex, units: list[Unit], workers: int, on_event: Callable[[], None]) -> None:
    """A process pool here; a pool broken by a dying worker is replaced and its units retried."""
    pending = list(units)
    while pending:
        with ProcessPoolExecutor(max_workers=workers) as pool:
            futures = {}
            for unit in pending:
                index.mark(unit, "running")
                futures[pool.submit(run_unit, unit, str(index.run_dir(unit)), spec)] = unit
            on_event()
            pending = []
            try:
                for future in as_completed(futures):
                    unit = futures[future]
                    _settle(index, unit, future, pending)
                    on_event()
            except BrokenProcessPool:
                for unit in futures.values():
                    if index.status(unit) == "running":
                        _retry_or_fail(index, unit, "worker process died", pending)
                on_event()


def _settle(index: GridIndex, unit: Unit, future, pending: list[Unit]) -> None:
    try:
        summary = future.result()
    except BrokenProcessPool:
        raise
    except SimtuneError as exc:  # a problem with the unit itself: retrying will not help
        index.mark(unit, "failed", error=str(exc))
    except Exception as exc:  # a worker lost or crashed: try again elsewhere
        _retry_or_fail(index, unit, f"{type(exc).__name__}: {exc}", pending)
    else:
        index.mark(unit, "done", summary)


def _retry_or_fail(index: GridIndex, unit: Unit, error: str, pending: list[Unit]) -> None:
    if index.attempts(unit) < MAX_ATTEMPTS:
        index.mark(unit, "pending", error=error)
        pending.append(unit)
    else:
        index.mark(unit, "failed", error=error)


def _run_dask(
    spec: GridSpec,
    index: GridIndex,
    units: list[Unit],
    workers: int,
    scheduler: str | None,
    on_event: Callable[[], None],
) -> None:
    """Submit every unit to a Dask scheduler; Dask reschedules the units of a lost worker."""
    try:
        from distributed import Client, LocalCluster
        from distributed import as_completed as dask_completed
    except ImportError:
        raise SimtuneError("the dask executor needs Dask: pip install 'simtune[grid]'") from None
    cluster = None
    if scheduler:
        client = Client(scheduler)
    else:
        cluster = LocalCluster(n_workers=workers, threads_per_worker=1, processes=True, dashboard_address=None)
        client = Client(cluster)
    try:
        pending = list(units)
        while pending:
            futures = {}
            for unit in pending:
                index.mark(unit, "running")
                # a lost worker's units are rescheduled by Dask itself and resume from their stores
                fut = client.submit(
                    run_unit, unit, str(index.run_dir(unit)), spec, key=f"{unit.id}-{time.time_ns()}", pure=False
                )
                futures[fut] = unit
            on_event()
            pending = []
            for fut in dask_completed(list(futures)):
                _settle(index, futures[fut], fut, pending)
                on_event()
    finally:
        client.close()
        if cluster is not None:
            cluster.close()


def run_grid(
    spec: GridSpec,
    grid_dir: Path,
    *,
    executor: str = "local",
    workers: int = 2,
    scheduler: str | None = None,
    index_url: str | None = None,
    on_event: Callable[[GridIndex], None] | None = None,
) -> GridIndex:
    """Run every unfinished unit of ``spec`` under ``grid_dir``; returns the index.

    ``index_url``: a PostgreSQL URL for the index instead of ``grid_dir/grid.sqlite``.
    """
    if executor not in ("local", "dask"):
        raise ConfigError(f"unknown executor {executor!r} (known: local, dask)")
    spec.validate()
    index = GridIndex(grid_dir, index_url)
    index.set_meta("spec", json.dumps(asdict(spec)))
    units = spec.units()
    index.add(units)
    todo = [u for u in units if index.status(u) != "done"]
    notify = (lambda: on_event(index)) if on_event else (lambda: None)
    if todo:
        if executor == "local":
            _run_local(spec, index, todo, workers, notify)
        else:
            _run_dask(spec, index, todo, workers, scheduler, notify)
    notify()
    return index


# --- planning ---------------------------------------------------------------------------------
def plan_grid(spec: GridSpec, samples: int = 3, seed: int = 0) -> list[dict]:
    """Size and cost of ``spec``: per engine x experiment x space, measured seconds per evaluation.

    The cost of an evaluation is measured at ``samples`` random points of the
    space (the time step, which dominates it, varies across the search), and a
    run is costed at ``max_generations + 1`` populations of 1 x D members, capped
    by ``max_seconds_per_run``: an upper bound, as most runs converge earlier.
    """
    import numpy as np

    from simtune.engines import engine_class
    from simtune.objective import Objective, load_references
    from simtune.params import get_space
    from simtune.tasks import parse_tasks

    spec.validate()
    rng = np.random.default_rng(seed)
    rows = []
    for engine in spec.engines:
        for entry in spec.tasks:
            tasks = parse_tasks(entry.replace("+", ","))
            refs = load_references(Path(spec.data), tasks)
            for space_name in spec.spaces:
                space = get_space(space_name, engine_class(engine).supported(), spec.only)
                objective = Objective(engine, tasks, refs, space)
                lo, hi = np.array(space.bounds).T
                objective.score_vector(lo + (hi - lo) / 2)  # build the engines outside the timing
                t0 = time.perf_counter()
                for _ in range(samples):
                    objective.score_vector(lo + rng.random(len(space)) * (hi - lo))
                cost = (time.perf_counter() - t0) / samples
                objective.close()
                evaluations = max(5, len(space)) * (spec.max_generations + 1)
                run_s = evaluations * cost
                if spec.max_seconds_per_run is not None:
                    run_s = min(run_s, spec.max_seconds_per_run)
                rows.append(
                    dict(
                        engine=engine,
                        tasks=entry,
                        space=space_name,
                        parameters=len(space),
                        eval_s=cost,
                        evaluations_per_run=evaluations,
                        run_hours=run_s / 3600,
                        repeats=spec.repeats,
                        core_hours=spec.repeats * run_s / 3600,
                    )
                )
    return rows
