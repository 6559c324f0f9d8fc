"""Running a grid: the coordinator (:func:`run_grid`) and where its units run.

Executors: ``local`` (a process pool here) or ``dask`` (any ``distributed``
scheduler; a ``LocalCluster`` when no address is given; ``dask-jobqueue``
clusters for SLURM/PBS work the same way).  Either way only this process
writes the index; each unit's worker writes its own run store.
"""

from __future__ import annotations

import json
import time
from collections.abc import Callable
from concurrent.futures import ProcessPoolExecutor, as_completed
from concurrent.futures.process import BrokenProcessPool
from dataclasses import asdict
from pathlib import Path

from simtune.common.spawn_guard import check_main_guarded
from simtune.errors import ConfigError, SimtuneError
from simtune.grid.index import GridIndex, open_index
from simtune.grid.spec import GridSpec, Unit, other_settings, run_unit, stored_differences

EXECUTORS = ("local", "dask")
MAX_ATTEMPTS = 3


def run_local(spec: GridSpec, index: GridIndex, units: list[Unit], workers: int, on_event: Callable[[], None]) -> None:
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


def run_dask(
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
        check_main_guarded(f"a local Dask cluster of {workers} workers")
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
    if executor not in EXECUTORS:
        raise ConfigError(f"unknown executor {executor!r} (known: {', '.join(EXECUTORS)})")
    spec.validate()
    index = open_index(grid_dir, index_url)
    units = spec.units()
    # a grid run again into the same folder with other settings: refused before any compute, never its old cells
    # reported as this grid's (nor a run of other settings copied into a cell's folder adopted as that cell)
    for unit in units:
        differences = stored_differences(unit, index.run_dir(unit), spec)
        if differences:
            index.close()
            raise other_settings(index.run_dir(unit), differences)
    index.set_meta("spec", json.dumps(asdict(spec)))
    index.add(units)
    todo = [u for u in units if index.status(u) != "done"]

    def notify() -> None:
        if on_event is not None:
            on_event(index)

    if todo:
        if executor == "local":
            run_local(spec, index, todo, workers, notify)
        else:
            run_dask(spec, index, todo, workers, scheduler, notify)
    notify()
    return index
