"""Experiment grids: engines x tasks x spaces x repeats, one optimisation per unit of work.

Each unit is an ordinary run folder (``GRID/runs/<engine>-<task>-<space>-s<seed>``)
with its own run store, written only by the worker running it.  The grid's index
(``GRID/grid.sqlite``) is written only by the coordinating process, so no
store ever needs locking across machines.

Running the same grid again skips finished units and resumes unfinished ones
from their stores; a unit whose worker dies is retried (on another worker,
under Dask) and resumes from what the dead worker committed, so nothing is
lost or counted twice.  Executors: ``local`` (a process pool here) or ``dask``
(any ``distributed`` scheduler; a ``LocalCluster`` when no address is given;
``dask-jobqueue`` clusters for SLURM/PBS work the same way).
"""

from __future__ import annotations

import json
import shutil
import sqlite3
import time
from collections.abc import Callable, Iterator
from concurrent.futures import ProcessPoolExecutor, as_completed
from concurrent.futures.process import BrokenProcessPool
from dataclasses import asdict, dataclass
from pathlib import Path

from simtune.errors import ConfigError, SimtuneError

INDEX_FILE = "grid.sqlite"
MAX_ATTEMPTS = 3

_SCHEMA = """
CREATE TABLE IF NOT EXISTS units (
    id TEXT PRIMARY KEY,
    engine TEXT NOT NULL, tasks TEXT NOT NULL, space TEXT NOT NULL, seed INTEGER NOT NULL,
    run_dir TEXT NOT NULL,
    status TEXT NOT NULL DEFAULT 'pending',   -- pending, running, done, failed
    attempts INTEGER NOT NULL DEFAULT 0,
    fitness REAL, generic_fitness REAL, evaluations INTEGER, generations INTEGER, wall_s REAL,
    error TEXT, updated_at REAL
);
CREATE TABLE IF NOT EXISTS grid_meta (key TEXT PRIMARY KEY, value TEXT NOT NULL);
"""


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
        return [Unit(e, t.replace("+", ","), s, r)
                for e in self.engines for t in self.tasks for s in self.spaces for r in range(self.repeats)]

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
    from simtune.runs import RunConfig, resume_run, start_run
    from simtune.store import RunStore

    path = Path(run_dir)
    config = RunConfig(engine=unit.engine, tasks=unit.tasks, space=unit.space, data=spec.data, seed=unit.seed,
                       workers=1, max_seconds=spec.max_seconds_per_run, max_generations=spec.max_generations,
                       only=spec.only)
    if (path / "run.sqlite").exists():
        try:
            has_config = RunStore(path).get("config") is not None
        except SimtuneError:
            has_config = False
        if not has_config:  # died before the run was set up: nothing in it is worth keeping
            shutil.rmtree(path)
    if (path / "run.sqlite").exists():
        result = resume_run(path, show_progress=False)
    else:
        result = start_run(config, path, show_progress=False)
    store = RunStore(path)
    summary = dict(fitness=result.score.fitness, generic_fitness=store.get("generic")["fitness"],
                   evaluations=result.evaluations, generations=result.generations, wall_s=result.wall_s)
    store.close()
    return summary


# --- the grid's index (coordinator only) -------------------------------------------------
class GridIndex:
    def __init__(self, grid_dir: Path):
        self.grid_dir = Path(grid_dir)
        try:
            self.grid_dir.mkdir(parents=True, exist_ok=True)
        except OSError as exc:
            raise SimtuneError(f"cannot create grid folder {self.grid_dir}: {exc.strerror}") from None
        self.db = sqlite3.connect(self.grid_dir / INDEX_FILE, timeout=30)
        self.db.execute("PRAGMA journal_mode=WAL")
        self.db.executescript(_SCHEMA)

    def add(self, units: list[Unit]) -> None:
        with self.db:
            self.db.executemany(
                "INSERT OR IGNORE INTO units (id, engine, tasks, space, seed, run_dir, updated_at)"
                " VALUES (?, ?, ?, ?, ?, ?, ?)",
                [(u.id, u.engine, u.tasks, u.space, u.seed, str(self.run_dir(u)), time.time()) for u in units])

    def run_dir(self, unit: Unit) -> Path:
        return self.grid_dir / "runs" / unit.id

    def status(self, unit: Unit) -> str:
        return self.db.execute("SELECT status FROM units WHERE id = ?", (unit.id,)).fetchone()[0]

    def mark(self, unit: Unit, status: str, summary: dict | None = None, error: str | None = None) -> None:
        summary = summary or {}
        with self.db:
            self.db.execute(
                "UPDATE units SET status = ?, attempts = attempts + ?, fitness = COALESCE(?, fitness),"
                " generic_fitness = COALESCE(?, generic_fitness), evaluations = COALESCE(?, evaluations),"
                " generations = COALESCE(?, generations), wall_s = COALESCE(?, wall_s), error = ?, updated_at = ?"
                " WHERE id = ?",
                (status, 1 if status == "running" else 0, summary.get("fitness"), summary.get("generic_fitness"),
                 summary.get("evaluations"), summary.get("generations"), summary.get("wall_s"), error,
                 time.time(), unit.id))

    def attempts(self, unit: Unit) -> int:
        return self.db.execute("SELECT attempts FROM units WHERE id = ?", (unit.id,)).fetchone()[0]

    def rows(self) -> list[dict]:
        cur = self.db.execute("SELECT * FROM units ORDER BY id")
        names = [d[0] for d in cur.description]
        return [dict(zip(names, r)) for r in cur.fetchall()]

    def counts(self) -> dict[str, int]:
        return dict(self.db.execute("SELECT status, COUNT(*) FROM units GROUP BY status").fetchall())

    def close(self) -> None:
        self.db.close()


# --- executors ----------------------------------------------------------------------------
Submit = Callable[[Unit], None]


def _run_local(spec: GridSpec, index: GridIndex, units: list[Unit], workers: int,
               on_event: Callable[[], None]) -> None:
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
                for future, unit in futures.items():
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


def _run_dask(spec: GridSpec, index: GridIndex, units: list[Unit], workers: int, scheduler: str | None,
              on_event: Callable[[], None]) -> None:
    """Submit every unit to a Dask scheduler; Dask reschedules the units of a lost worker."""
    try:
        from distributed import Client, LocalCluster, as_completed as dask_completed
    except ImportError:
        raise SimtuneError("the dask executor needs Dask: pip install 'simtune[grid]'") from None
    cluster = None
    if scheduler:
        client = Client(scheduler)
    else:
        cluster = LocalCluster(n_workers=workers, threads_per_worker=1, processes=True,
                               dashboard_address=None)
        client = Client(cluster)
    try:
        pending = list(units)
        while pending:
            futures = {}
            for unit in pending:
                index.mark(unit, "running")
                # a lost worker's units are rescheduled by Dask itself and resume from their stores
                fut = client.submit(run_unit, unit, str(index.run_dir(unit)), spec,
                                    key=f"{unit.id}-{time.time_ns()}", pure=False)
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


def run_grid(spec: GridSpec, grid_dir: Path, *, executor: str = "local", workers: int = 2,
             scheduler: str | None = None, on_event: Callable[[GridIndex], None] | None = None) -> GridIndex:
    """Run every unfinished unit of ``spec`` under ``grid_dir``; returns the index."""
    if executor not in ("local", "dask"):
        raise ConfigError(f"unknown executor {executor!r} (known: local, dask)")
    spec.validate()
    index = GridIndex(grid_dir)
    with index.db:
        index.db.execute("INSERT OR REPLACE INTO grid_meta VALUES ('spec', ?)", (json.dumps(asdict(spec)),))
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


def iter_best(index: GridIndex) -> Iterator[tuple[str, str, float]]:
    """(engine, tasks, best fitness so far) over finished units."""
    yield from index.db.execute(
        "SELECT engine, tasks, MIN(fitness) FROM units WHERE status = 'done' GROUP BY engine, tasks ORDER BY 1, 2")


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
                rows.append(dict(engine=engine, tasks=entry, space=space_name, parameters=len(space),
                                 eval_s=cost, evaluations_per_run=evaluations, run_hours=run_s / 3600,
                                 repeats=spec.repeats, core_hours=spec.repeats * run_s / 3600))
    return rows
