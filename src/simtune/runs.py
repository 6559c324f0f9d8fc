"""Tuning runs: a run folder with its store, configuration and best parameters.

``start_run`` creates the folder and records everything needed to repeat the
run (configuration, versions, command line, a fingerprint of the data, task
definitions and engine version); ``resume_run`` reads it back and
continues: the optimiser (``RunConfig.optimizer``, see
:data:`simtune.optimize.OPTIMIZERS`) replays its search with the same seed,
taking every finished evaluation from the store, then the optional
least-squares refinement (``refine``) does the same.  ``best_params.json`` is rewritten atomically after every run
session, in the format ``--params-file`` reads.

Safety of a run folder:

- one process writes it at a time (:mod:`simtune.store.lock`); a second is refused at once;
- ``start_run`` refuses a folder that holds a run (resume it) or anything else that is
  not simtune's (the user's files are never overwritten);
- ``resume_run`` reads a ``run.sqlite`` read-only until it knows it is a run store of
  this simtune, checks every page of it, refuses an unknown key in its configuration,
  and refuses when the data, a task definition or the engine version changed since the
  run started, naming what changed;
- ``resume_run(..., rescore=True)`` (``simtune resume RUN --rescore``) starts a new run on
  the data as it is now, in the same folder and with the same configuration: the old
  store and best parameters move to ``RUN/superseded/`` (``run-<time>.sqlite``,
  ``best_params-<time>.json``), the generic fitness is scored anew, and the search starts
  from the old run's last population of its search (every member scored anew): DE takes
  it as its first population, the other optimisers score it as their first batch;
- a failed evaluation that ran past the time-out is retried once on resume.
"""

from __future__ import annotations

import hashlib
import json
import os
import platform
import sqlite3
import sys
import tempfile
import time
import warnings
from dataclasses import asdict, fields, replace
from pathlib import Path

import numpy as np

import simtune
from simtune.activity import announce, robot_content
from simtune.common.spawn_guard import check_main_guarded, start_worker_server
from simtune.data.fingerprint import fingerprint_changes, folders_fingerprint
from simtune.errors import EngineVersionWarning, RunInterrupted, SimtuneError
from simtune.objective import Objective, generic_score, recordings_folder
from simtune.optimize import TuneResult, TuneSettings, get_optimizer, least_squares_refine
from simtune.optimize.evaluator import THREADS_FIRST_S, timed_out
from simtune.optimize.progress import TuneProgress
from simtune.params.space import is_supported
from simtune.run_plan import RunConfig, RunPlan, plan_run
from simtune.store import STORE_FILE, RunRecord, RunStore, check_store_file, read_record
from simtune.store.lock import LOCK_FILE, check_free, run_lock
from simtune.tasks import TaskSpec
from simtune.tasks.spec import FINGERPRINT
from simtune.uncertainty import uncertainty, verdict

BEST_PARAMS_FILE = "best_params.json"
#: the share of a --max-seconds cap the inactive-parameter probe may take before the search (then it stops
#: measuring tasks it does not hold: :attr:`simtune.run_plan.RunPlan.probe_deadline`)
PROBE_SHARE = 0.5
#: where ``resume --rescore`` keeps the run it replaces
SUPERSEDED_DIR = "superseded"
STORE_FILES = (STORE_FILE, STORE_FILE + "-wal", STORE_FILE + "-shm")
#: what simtune leaves in a run folder besides the run itself
_OWN_ENTRIES = frozenset({LOCK_FILE, SUPERSEDED_DIR, *STORE_FILES})


def versions(plan: RunPlan) -> dict[str, str]:
    import scipy

    return {
        "simtune": simtune.__version__,
        plan.config.engine: plan.engine.version(),
        "numpy": np.__version__,
        "scipy": scipy.__version__,
        "python": platform.python_version(),
    }


def task_fingerprint(task: TaskSpec) -> str:
    """SHA-256 of what a task makes the engine do.

    Catalogue entries (description, recordings folder ...) are left out, and so are fields added after runs
    were stored while they hold their default (``tasks.spec.FINGERPRINT``): those runs' fingerprints stay.
    """
    spec = asdict(task)
    for f in fields(task):
        omit = f.metadata.get(FINGERPRINT)
        # a run setting the task carries (its loading) is the run's fingerprint's, beside the tasks
        if omit in ("never", "run") or (omit in ("default", "added") and getattr(task, f.name) == f.default):
            spec.pop(f.name)
    return _digest(spec)


def _digest(value) -> str:
    """SHA-256 of ``value`` as canonical JSON (keys sorted; what JSON lacks as its ``str``): a fingerprint's hash."""
    return hashlib.sha256(json.dumps(value, sort_keys=True, default=str).encode()).hexdigest()


def run_fingerprint(plan: RunPlan, screened: bool = True) -> dict:
    """What the fitness of a run depends on besides its parameters: data files, the reference made of them (aligned
    or mean) and which repeats build it (left out when all: the fingerprints of runs stored before the choice
    stay), task definitions, the robot, engine version; with ``screened``, the repeats the repeat check left out
    (:func:`left_out_repeats`, left out when none: every run stored before the check); how the robot was loaded
    (left out when as the paper did, every run stored before the choice, and in an engine whose loading is one)."""
    fingerprint = {
        "data": folders_fingerprint({t.name: recordings_folder(plan.config.data, t) for t in plan.tasks}),
        "reference": plan.config.reference,
        "tasks": {t.name: task_fingerprint(t) for t in plan.tasks},
        "engine": f"{plan.config.engine} {plan.engine.version()}",
    }
    if plan.config.repeats != "all":
        fingerprint["repeats"] = plan.config.repeats
    # left out as the paper's (the fingerprints of runs stored before the choice), and for an engine it changes nothing
    if plan.config.loading != "paper" and plan.engine.reads_loading:
        fingerprint["loading"] = plan.config.loading
    # the robot on its own (its content, not its path), so that a changed URDF is named as such on resume rather than
    # as a changed task (the robot is part of each task's definition)
    fingerprint["robot"] = _digest(robot_content(plan.robot))
    if screened and (left_out := left_out_repeats(plan)):
        fingerprint["left_out"] = left_out
    return fingerprint


def left_out_repeats(plan: RunPlan) -> dict[str, list[str]]:
    """Per task, the files of the repeats the repeat check left out of the run's reference (reads the data)."""
    return {name: [Path(p).name for p in ref.left_out] for name, ref in plan.references.items() if ref.left_out}


def left_out_changes(stored: dict, now: dict) -> list[str]:
    """What the repeat check leaves out now and did not when the run started (``stored``), and the reverse."""
    changes = []
    for task in sorted(set(stored) | set(now)):
        was, is_now = set(stored.get(task, [])), set(now.get(task, []))
        changes += [f"the repeat check now leaves out {task}/{name}" for name in sorted(is_now - was)]
        changes += [
            f"the repeat check now keeps {task}/{name} (left out when the run started)" for name in sorted(was - is_now)
        ]
    return changes


#: A task's fingerprint now -> the one runs stored before tasks were files, for the same definition: the
#: Python tasks single, double and cube wrote their whole-degree targets as integers (JSON ``-100``, where a
#: task file's numbers are floats, ``-100.0``).  Their runs still resume.
FORMER_TASK_FINGERPRINTS = {
    "3c93b153181985fc08c84f984aeb0d1b8a084297ac281603136d1d3607937bb8": (
        "c1f7ab884c68a1bdbe2ed2db3d95f37e374293cfdb90ce869c160519038c0482"  # single
    ),
    "6cb61d93c7e4144af91deda4d43299b514f095b5dbc442ee47263dc9f08f203c": (
        "5d5bf0964f0279e146e088df7e3b4d9241d8cc4959c4cf438d69ac230925d047"  # double
    ),
    "db61f136e7966e566d7f89a6ebae2647b60ff7096e6bb4a7b052b805f44b65e3": (
        "3692f3b6c26dd9ee6186571b8617bc8980d98f05918f2fac987ba7abedb1094d"  # cube
    ),
}


def fingerprint_differences(stored: dict, now: dict) -> list[str]:
    """What changed between two run fingerprints, one phrase each (``cube/cube0002.tsv changed``)."""
    changes = fingerprint_changes(stored.get("data", {}), now["data"])
    # a run stored before the choice of reference scored against the plain mean
    was, now_kind = stored.get("reference", "mean"), now.get("reference", "mean")
    if was != now_kind:
        changes.append(f"the reference changed from {was} to {now_kind}")
    # a fingerprint without repeats: all of them (every run stored before the choice, and every run of all)
    was, now_kind = stored.get("repeats", "all"), now.get("repeats", "all")
    if was != now_kind:
        changes.append(f"the repeats changed from {was} to {now_kind}")
    # a fingerprint without the loading: the paper's (every run stored before the choice)
    was, now_kind = stored.get("loading", "paper"), now.get("loading", "paper")
    if was != now_kind:
        changes.append(f"the robot's loading changed from {was} to {now_kind}")
    # a fingerprint without the robot's: a run stored before it was kept (its tasks' fingerprints cover the robot)
    robot_changed = "robot" in stored and "robot" in now and stored["robot"] != now["robot"]
    if robot_changed:
        changes.append("the robot changed (its description or a mesh file)")
    for name in sorted(set(stored.get("tasks", {})) | set(now["tasks"])):
        before, after = stored.get("tasks", {}).get(name), now["tasks"].get(name)
        if before != after and before != FORMER_TASK_FINGERPRINTS.get(after or "") and not robot_changed:
            changes.append(f"the definition of task {name!r} changed")
    if stored.get("engine", now["engine"]) != now["engine"]:
        changes.append(engine_change(stored["engine"], now["engine"]))
    return changes


def engine_change(stored: str, now: str) -> str:
    """The phrase of :func:`fingerprint_differences` for a run stored under another engine or engine version."""
    return f"engine {stored} is now {now}"


def replays_under_this_engine(run_dir: Path, plan: RunPlan, store: RunStore, changes: list[str]) -> list[str]:
    """``changes`` less an engine version that changed alone, where this engine replays the run's stored evaluations:
    its best one and the first of its initial population, re-scored now, to the stored fitness exactly.  A run that
    replays resumes, with one warning line saying so; one that does not keeps the change (refused, with why).

    Args:
        run_dir: the run's folder (named in the line).
        plan: the run as it would go on now.
        store: its store, open.
        changes: :func:`fingerprint_differences` of its fingerprint and today's.

    Returns:
        The changes that remain.
    """
    stored_engine = store.get("fingerprint", {}).get("engine", "")
    now_engine = f"{plan.config.engine} {plan.engine.version()}"
    phrase = engine_change(stored_engine, now_engine)
    if phrase not in changes or stored_engine.split(" ")[0] != plan.config.engine:
        return changes  # no version change, or another engine altogether
    others = [c for c in changes if c != phrase]
    objective = plan.objective(store.get("inactive_parameters"), store.get("parameters"))
    try:
        best = store.best_evaluation()
        witnesses = [] if best is None else [(best["x"], best["score"]["fitness"])]
        first = store.initial_population()[:1]
        score = store.lookup(first[0]) if first else None
        if score is not None and not score.pruned:  # a pruned score is a bound, not the fitness
            witnesses.append((first[0], score.fitness))
        if objective.vector_space().names != store.get("parameters") or not witnesses:
            return changes
        differences = [abs(objective.score_vector(np.asarray(x, dtype=float)).fitness - f) for x, f in witnesses]
    finally:
        objective.close()
    largest = max(differences)
    if largest != 0.0:
        return [*others, f"{phrase} and scores its stored evaluations differently (by up to {largest:.3g})"]
    warnings.warn(
        f"{run_dir} was tuned with {stored_engine}; {now_engine} replays its stored evaluations to the same fitness "
        f"({len(witnesses)} re-scored), so it goes on with {now_engine}",
        EngineVersionWarning,
        stacklevel=2,
    )
    return others


def _summary(changes: list[str], shown: int = 3) -> str:
    more = f" and {len(changes) - shown} more" if len(changes) > shown else ""
    return "; ".join(changes[:shown]) + more


def write_json_atomic(path: Path, data: dict) -> None:
    """Write ``path`` whole or not at all (a temporary file of a unique name, then renamed over it)."""
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".tmp")
    umask = os.umask(0)
    os.umask(umask)
    try:
        if hasattr(os, "fchmod"):
            os.fchmod(fd, 0o666 & ~umask)  # as an ordinary new file (mkstemp makes it private)
        with os.fdopen(fd, "w") as fh:
            fh.write(json.dumps(data, indent=2) + "\n")
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise


def has_run(run_dir: Path) -> bool:
    """Whether ``run_dir`` holds a simtune run that was set up (its store has a configuration).

    A ``run.sqlite`` that is not a simtune store is a one-line error (and is left unchanged).
    """
    path = Path(run_dir) / STORE_FILE
    if not path.exists():
        return False
    if not check_store_file(path):
        return False
    store = RunStore(run_dir)
    try:
        return store.get("config") is not None
    finally:
        store.close()


def read_run_record(run_dir: Path | str) -> RunRecord[RunConfig]:
    """The run in ``run_dir`` read once (:func:`simtune.store.read_record`), its configuration checked by
    :meth:`RunConfig.from_stored`: the record the API, export and the report are views of.

    A folder that is missing, holds no store, or holds one SQLite cannot read is one line naming it.
    """
    run_dir = Path(run_dir)
    if not run_dir.is_dir():
        raise SimtuneError(f"{run_dir}: no such run folder")
    if not (run_dir / STORE_FILE).is_file():
        raise SimtuneError(f"{run_dir} is not a run folder: its store {STORE_FILE} is missing")
    try:
        return read_record(run_dir, RunConfig.from_stored)
    except sqlite3.Error as exc:
        raise SimtuneError(f"{run_dir / STORE_FILE}: corrupt run store, cannot read it ({exc})") from None


def discard_run(run_dir: Path) -> None:
    """Delete the run in ``run_dir`` (store, best parameters, superseded runs); the caller holds its lock."""
    import shutil

    for name in (*STORE_FILES, BEST_PARAMS_FILE):
        (Path(run_dir) / name).unlink(missing_ok=True)
    shutil.rmtree(Path(run_dir) / SUPERSEDED_DIR, ignore_errors=True)


def _check_vacant(run_dir: Path, locked: bool) -> None:
    """Refuse a folder that holds a run or anything that is not simtune's; under the lock, clear a store that was
    never set up (its process died while creating it)."""
    if not run_dir.exists():
        return
    if not run_dir.is_dir():
        raise SimtuneError(f"{run_dir} is a file, not a run folder")
    if has_run(run_dir):
        raise SimtuneError(f"{run_dir} already holds a run: `simtune resume {run_dir}` continues it")
    others = sorted(p.name for p in run_dir.iterdir() if p.name not in _OWN_ENTRIES)
    if others:
        listed = ", ".join(others[:3]) + (f" and {len(others) - 3} more" if len(others) > 3 else "")
        raise SimtuneError(
            f"{run_dir} is not empty ({listed}) and holds no simtune run: choose a new or empty folder for --out"
        )
    if locked:
        for name in STORE_FILES:
            (run_dir / name).unlink(missing_ok=True)


def _make_folder(run_dir: Path) -> None:
    try:
        run_dir.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise SimtuneError(f"cannot create run folder {run_dir}: {exc.strerror}") from None


def _create_store(run_dir: Path, plan: RunPlan, objective: Objective, generic, started: float, **meta) -> RunStore:
    """The new run's store, set up; ``started``: when the command began (``time.perf_counter``), so that the
    start-up (reading the recordings, the inactive-parameter probe, the generic score) counts against
    ``--max-seconds`` as the search does: a budget is the command's wall time."""
    store = RunStore(run_dir, create=True)
    supported = plan.engine.supported(plan.robot)
    store.set(
        versions=versions(plan),
        command=sys.argv,
        parameters=objective.vector_space().names,
        bounds=objective.vector_space().bounds,
        # in the search vector without effect in this engine (only --paper-exact keeps such parameters)
        unmapped_parameters=[n for n in objective.vector_space().names if not is_supported(n, supported)],
        generic=generic.to_dict(),
        # every parameter of the full space that changes no rollout of the tasks, and why (left out of the
        # search unless keep_inactive; the report and export never pool them)
        inactive_parameters=plan.inactive,
        fingerprint=run_fingerprint(plan),
        status="running",
        elapsed_s=(setup := time.perf_counter() - started),
        setup_s=setup,
        **meta,
    )
    store.set(config=plan.config.record())  # last: a store with a configuration is a run that was fully set up
    return store


def start_run(config: RunConfig, run_dir: Path, show_progress: bool = True) -> TuneResult:
    """Create ``run_dir`` and tune.  A folder that holds a run (use resume) or other files is refused."""
    started = time.perf_counter()
    run_dir = Path(run_dir)
    config.check()
    check_free(run_dir)  # a run in progress there: say who runs it, at once
    _check_vacant(run_dir, locked=False)
    if config.worker_processes:
        # first: a script to fix leaves no run behind, and the inactive-parameter probe (its own worker
        # processes, where its cache is empty) would otherwise meet the unguarded script first
        check_main_guarded(f"{config.workers} workers")
        start_worker_server()  # its imports run while this process reads the recordings
    plan = plan_run(config)
    if config.max_seconds is not None:
        # the probe may take half the cap: past it, a task it does not hold yet keeps its parameters in the search
        plan.probe_deadline = time.monotonic() - (time.perf_counter() - started) + PROBE_SHARE * config.max_seconds
    announce(f"reading and aligning the recordings of {config.tasks} ({config.reference} reference) ...")
    objective = plan.objective()  # checks engine, tasks, space and data before any folder is made
    announce(f"scoring {config.engine}'s generic parameters, then tuning {len(objective.vector_space())} parameter(s)")
    generic = generic_score(objective)
    _make_folder(run_dir)
    with run_lock(run_dir):
        _check_vacant(run_dir, locked=True)  # again: another process may have started a run meanwhile
        store = _create_store(run_dir, plan, objective, generic, started)
        return _run_interruptible(objective, plan, store, show_progress)


def resume_run(run_dir: Path, show_progress: bool = True, rescore: bool = False) -> TuneResult:
    """Continue the run in ``run_dir`` where it stopped, reusing every stored evaluation.

    With ``rescore``: start a new run from its last population on the data as it is now (see the module's notes).
    """
    run_dir = Path(run_dir)
    path = _run_to_write(run_dir, "resume")
    with run_lock(run_dir):
        store = RunStore(run_dir)
        try:
            store.verify()
            stored = store.get("config")
            if stored is None:
                raise never_set_up(run_dir)
            config = RunConfig.from_stored(stored, f"{path}")
            # a finished run is checked as any other (its data, tasks and engine as they were), then given back as
            # it was: the warnings of reading its recordings again were printed when it was tuned
            done = None if rescore else finished_result(store)
            with warnings.catch_warnings(record=done is not None) as held:
                if done is not None:
                    warnings.simplefilter("always")  # held, each of them: the filters apply when said below
                elif config.worker_processes:
                    start_worker_server()  # its imports run while this process reads the recordings
                plan = plan_run(config)
                check_data_found(run_dir, plan)
                changes = _changes_since_start(run_dir, plan, store, rescore)
            if done is not None and not changes:
                return done  # nothing to resume: the store, its wall time and best_params.json stay as they are
            for caught in held or []:  # what the checks said, said now that the run goes on or is refused
                warnings.warn_explicit(caught.message, caught.category, caught.filename, caught.lineno)
            if rescore:
                return _rescore(run_dir, store, plan, changes, show_progress)
            if changes:
                raise SimtuneError(
                    f"{run_dir}: {_summary(changes)} since the run started, so its stored fitness values are stale: "
                    f"`simtune resume {run_dir} --rescore` starts a new run from its last population on the data "
                    "as it is now"
                )
            objective = plan.objective(store.get("inactive_parameters"), store.get("parameters"))
            _check_parameters(run_dir, objective, store, config)
            store.release_failures(timed_out)  # each evaluation that timed out gets one more try
            return _run_interruptible(objective, plan, store, show_progress)
        except sqlite3.DatabaseError as exc:
            raise SimtuneError(f"{path} is damaged ({exc})") from None
        finally:
            store.close()


def _changes_since_start(run_dir: Path, plan: RunPlan, store: RunStore, rescore: bool) -> list[str]:
    """What changed since the run started (its data, the repeats left out, tasks, robot, engine), one phrase each;
    without ``rescore``, less an engine version that replays the stored evaluations (saying so)."""
    stored_fingerprint = store.get("fingerprint")
    if stored_fingerprint is None:  # a run from before fingerprints has nothing to compare with
        return []
    changes = fingerprint_differences(stored_fingerprint, run_fingerprint(plan, screened=False))
    if not changes:  # the data as it was: the repeats left out of it must be the same
        changes = left_out_changes(stored_fingerprint.get("left_out", {}), left_out_repeats(plan))
    if not rescore:  # another engine version that replays the stored evaluations goes on, saying so
        changes = replays_under_this_engine(run_dir, plan, store, changes)
    return changes


def check_data_found(run_dir: Path, plan: RunPlan) -> None:
    """A run reads its recordings from where it was tuned on them: a data folder that has gone is one line saying
    so (rather than every recording in it "removed")."""
    data = plan.config.data
    folders = [Path(data)] if data is not None else [recordings_folder(None, t) for t in plan.tasks]
    for folder in folders:
        if not folder.is_dir():
            relative = "" if folder.is_absolute() else " (stored relative to the folder the run started in)"
            raise SimtuneError(
                f"{run_dir}: its data folder {folder} was not found{relative}: the run reads its recordings from "
                "there; put them back there to go on with it"
            )


def _run_to_write(run_dir: Path, command: str) -> Path:
    """The store of the run in ``run_dir``, checked before ``command`` writes to it: a run folder, not in use by
    another process, writable, its store simtune's and set up; one line for each that is not."""
    path = run_dir / STORE_FILE
    if not path.exists():
        raise SimtuneError(f"{run_dir} is not a run folder (no {STORE_FILE})")
    # a run in progress there: say who runs it, at once, before reading its store (a read-only look at a store
    # whose writer is stopped mid-transaction can fail with SQLite's "locking protocol" instead)
    check_free(run_dir)
    written = [run_dir, *(run_dir / name for name in (*STORE_FILES, BEST_PARAMS_FILE, LOCK_FILE))]
    if any(p.exists() and not os.access(p, os.W_OK) for p in written):
        raise SimtuneError(
            f"{run_dir} is read-only ({command} writes its store, its lock and best_params.json): copy the run "
            f"folder where you can write (cp -r {run_dir} NEW) and {command} the copy"
        )
    if not check_store_file(path):  # read-only: a foreign file gets no lock file beside it and no tables in it
        raise never_set_up(run_dir)
    return path


def never_set_up(run_dir: Path) -> SimtuneError:
    """The error for a run folder whose store holds no run (its process died while creating it, or the file was
    emptied): where to start it afresh, a folder `simtune tune --out` takes."""
    others = sorted(p.name for p in run_dir.iterdir() if p.name not in _OWN_ENTRIES)
    if not others:
        return SimtuneError(
            f"{run_dir}: the run was never set up (its process died while creating it): "
            f"`simtune tune --out {run_dir}` starts it afresh"
        )
    return SimtuneError(
        f"{run_dir}: the run was never set up (its store holds no run), and the folder holds {', '.join(others[:3])}: "
        "start the run afresh in a new folder (`simtune tune ... --out NEW`)"
    )


def _check_parameters(run_dir: Path, objective: Objective, store: RunStore, config: RunConfig) -> None:
    if objective.vector_space().names != store.get("parameters"):
        raise SimtuneError(f"{run_dir}: the stored parameter list differs from this simtune's {config.space!r} space")


def _rescore(run_dir: Path, store: RunStore, plan: RunPlan, changes: list[str], show_progress: bool) -> TuneResult:
    """A new run in ``run_dir`` from the old run's last search population, on the data as it is now."""
    started = time.perf_counter()
    checkpoint = store.last_checkpoint(up_to=store.get("search_generations"))
    # the new data must load before the old run is moved aside
    objective = plan.objective(store.get("inactive_parameters"), store.get("parameters"))
    _check_parameters(run_dir, objective, store, plan.config)
    generic = generic_score(objective)
    store.close()
    kept = _supersede(run_dir)
    population = None if checkpoint is None else np.atleast_2d(checkpoint["population"])
    new = _create_store(
        run_dir,
        plan,
        objective,
        generic,
        started,
        initial_population=None if population is None else population.tolist(),
        rescored_from={
            "store": str(kept.relative_to(run_dir)),
            "generation": None if checkpoint is None else checkpoint["generation"],
            "members": 0 if population is None else len(population),
            "changes": changes,
        },
    )
    return _run_interruptible(objective, plan, new, show_progress)


def _supersede(run_dir: Path) -> Path:
    """Move the run's store and best parameters to ``RUN/superseded/`` (names stamped with the time); the new path."""
    folder = run_dir / SUPERSEDED_DIR
    folder.mkdir(exist_ok=True)
    stamp = time.strftime("%Y%m%d-%H%M%S")
    n = 1
    while (folder / f"run-{stamp}.sqlite").exists():
        n += 1
        stamp = f"{time.strftime('%Y%m%d-%H%M%S')}-{n}"
    target = folder / f"run-{stamp}.sqlite"
    for suffix in ("-wal", "-shm", ""):  # the database last: its journal moves with it under the matching name
        source = run_dir / (STORE_FILE + suffix)
        if source.exists():
            os.replace(source, folder / (target.name + suffix))
    best = run_dir / BEST_PARAMS_FILE
    if best.exists():
        os.replace(best, folder / f"best_params-{stamp}.json")
    return target


def _run_interruptible(objective: Objective, plan: RunPlan, store: RunStore, show_progress: bool) -> TuneResult:
    """:func:`_run`; Ctrl-C becomes :class:`RunInterrupted`, naming the folder to resume."""
    try:
        return _run(objective, plan, store, show_progress)
    except KeyboardInterrupt:
        raise RunInterrupted(store.run_dir) from None


def _run(objective: Objective, plan: RunPlan, store: RunStore, show_progress: bool) -> TuneResult:
    config = plan.config
    tune = get_optimizer(config.optimizer)
    max_seconds, target, max_evaluations = config.max_seconds, config.target_fitness, config.max_evaluations
    searched = store.get("search_evaluations")
    elapsed_at_start = store.get("elapsed_s", 0.0)
    # a finished run resumed: its search and refinement are replayed from the store, nothing new is simulated, and
    # its wall time and uncertainty stay what they were (a replay is not tuning time)
    finished = store.get("status") == "finished"
    stored_uncertainty = store.get("uncertainty") if finished else None
    initial = store.get("initial_population")
    if searched is not None:
        # the search finished in an earlier session (a refinement followed): replay it to the same point,
        # whatever the clock says now
        max_seconds, target, max_evaluations = None, None, searched
    stored = store.count_evaluations()
    with TuneProgress(enabled=show_progress, max_seconds=config.max_seconds, stored=stored) as progress:
        settings = TuneSettings(
            seed=config.seed,
            workers=config.workers,
            max_seconds=max_seconds,
            max_generations=config.max_generations,
            max_evaluations=max_evaluations,
            elapsed_before=store.get("search_elapsed_s", store.get("elapsed_s", 0.0)),
            eval_timeout=config.eval_timeout,
            prune=config.prune and not config.paper_exact,
            paper_exact=config.paper_exact,
            target_fitness=target,
            on_evaluation=progress.evaluation,
            on_generation=progress.generation,
            initial_population=None if initial is None else np.array(initial, dtype=float),
            threads=config.threads,
            threads_first_s=None if config.threads else THREADS_FIRST_S,
        )
        result = tune(objective, store, settings)
        if searched is None:
            store.set(
                search_evaluations=result.used_evaluations,
                search_generations=result.generations,
                search_elapsed_s=result.wall_s,
                search_message=result.message,
                search_converged=result.converged,
                search_stop_reason=result.stop_reason,
            )
        else:  # the replay stopped on the evaluation count: say why the search stopped first
            result.message = store.get("search_message", result.message)
            result.converged = bool(store.get("search_converged", result.converged))
            result.stop_reason = store.get("search_stop_reason", result.stop_reason)
        if config.refine:
            refined = least_squares_refine(
                objective,
                store,
                result.x,
                replace(settings, elapsed_before=max(result.wall_s, elapsed_at_start)),
                first_generation=result.generations + 1,
            )
            result = _combine(result, refined)
    generic = store.get("generic")
    write_json_atomic(
        store.run_dir / BEST_PARAMS_FILE,
        {
            "engine": config.engine,
            "tasks": config.tasks,
            "space": config.space,
            # the data's fit, comparable with a plain run's; a prior's part beside it (--prior)
            "fitness": result.score.data_fitness,
            **({"prior": config.prior, "prior_penalty": result.score.prior_penalty} if config.prior else {}),
            "wrist_error": result.score.wrist_error,
            "object_error": result.score.object_error,
            "joint_error": result.score.joint_error,
            "generic_fitness": generic["fitness"],
            "parameters": list(result.params),
            "params": result.params,
        },
    )
    if finished:
        result.wall_s = elapsed_at_start
    # the wall time the command prints is the one stored, to the last digit (the last checkpoint's was a little less)
    store.set(elapsed_s=result.wall_s)
    store.set(
        status="finished",
        message=result.message,
        best_fitness=result.score.data_fitness,
        result=_result_record(result),
    )
    # after the run is finished: a kill meanwhile loses only this summary (`simtune uncertainty RUN` redoes it)
    if stored_uncertainty is None:
        store.set(uncertainty=_uncertainty_or_reason(objective, plan, store, result))
    if store.get("verdict") is None:  # cheap: the floor of the loaded references and the generic values
        try:
            summary = store.get("uncertainty")
            store.set(verdict=verdict(objective, plan.references, result.params, result.score.data_fitness, summary))
        except SimtuneError as exc:  # the run stands without it
            store.set(verdict={"error": str(exc), "floor": None, "over_floor": None, "moved": []})
    if plan.validation and store.get("validation") is None:  # the held-out tasks (--validate), with the best
        try:
            store.set(validation=plan.validation_score(dict(result.params), result.score.data_fitness))
        except SimtuneError as exc:  # the run stands without it, saying why
            store.set(validation={"error": str(exc), "tasks": [t.name for t in plan.validation]})
    store.close()
    return result


def _result_record(result: TuneResult) -> dict:
    """What a finished run's :class:`TuneResult` holds beyond its store's evaluations (store meta ``result``), so
    that resuming the run gives it back as it was (:func:`finished_result`) rather than replaying the run."""
    return {
        "x": [float(v) for v in result.x],
        "generations": result.generations,
        "used_evaluations": result.used_evaluations,
        "message": result.message,
        "converged": bool(result.converged),
        "stop_reason": result.stop_reason,
        "history": [float(v) for v in result.history],
    }


def finished_result(store: RunStore) -> TuneResult | None:
    """The result of a finished run as its last session stored it, without a replay; None where the run is not
    finished, holds an evaluation that timed out and was never retried, or its store lacks what the result needs
    (a store from before the result was kept, or one killed before its uncertainty or verdict was stored: a replay
    finishes those).

    Args:
        store: the run's store, open.

    Returns:
        Its result (no new evaluations, its stored wall time), or None.
    """
    record = store.get("result")
    if store.get("status") != "finished" or not isinstance(record, dict):
        return None
    if store.get("uncertainty") is None or store.get("verdict") is None:
        return None
    if store.has_failures_to_retry(timed_out):  # an evaluation that timed out gets its one retry: a replay
        return None
    names = store.get("parameters") or []
    x = np.asarray(record.get("x", []), dtype=float)
    score = store.lookup(x) if len(x) == len(names) else None
    if score is None:
        return None
    return TuneResult(
        x,
        dict(zip(names, (float(v) for v in x), strict=True)),
        score,
        int(record["generations"]),
        store.count_evaluations(),
        0,
        float(store.get("elapsed_s", 0.0)),
        str(record["message"]),
        bool(record["converged"]),
        [float(v) for v in record.get("history", [])],
        used_evaluations=int(record["used_evaluations"]),
        stop_reason=str(record["stop_reason"]),
    )


def is_finished(run_dir: Path) -> bool:
    """Whether ``run_dir`` holds a finished run, read without writing; False for anything that cannot be read as
    one (what reads it next says why)."""
    try:
        store = RunStore.open_read_only(Path(run_dir))
    except (SimtuneError, sqlite3.Error):
        return False
    try:
        return store.get("status") == "finished"
    except (sqlite3.Error, ValueError):
        return False
    finally:
        store.close()


def _uncertainty_or_reason(objective: Objective, plan: RunPlan, store: RunStore, result: TuneResult) -> dict:
    """The Gauss-Newton uncertainty at the best point, or why it could not be computed (the run stands either way).

    Its 2D + 1 rollouts are left out where ``--max-seconds`` cannot hold them (at the search's own pace): the
    budget is the command's wall time, and ``simtune uncertainty RUN`` computes them when wanted."""
    cap, elapsed = plan.config.max_seconds, store.get("elapsed_s", result.wall_s)
    if cap is not None and result.new_evaluations > 0:
        dimension = len(objective.vector_space().names)
        # the search's seconds per evaluation (its batches were as wide as the uncertainty's one batch), its
        # start-up (store meta setup_s) left out
        searching = max(result.wall_s - store.get("setup_s", 0.0), 0.0)
        needed = (2 * dimension + 1) * searching / max(result.used_evaluations, result.new_evaluations, 1)
        if elapsed + needed > cap:
            return {
                "error": f"its {2 * dimension + 1} rollouts (about {needed:.0f} s) would run past "
                f"--max-seconds {cap:g}; `simtune uncertainty {store.run_dir}` computes them",
                "parameters": [],
            }
    try:
        inactive = store.get("inactive_parameters") or {}
        return uncertainty(objective, result.x, plan.full_space, inactive, plan.config.workers, known=store)
    except (SimtuneError, ArithmeticError, ValueError, np.linalg.LinAlgError) as exc:
        return {"error": f"{type(exc).__name__}: {exc}", "parameters": []}


def run_uncertainty(run_dir: Path, workers: int = 1, bootstrap: int = 0) -> dict:
    """Compute (again) the uncertainty at a finished run's best point and store it in the run (store meta), with
    ``bootstrap`` draws of the repeats to refit against (:func:`simtune.uncertainty.bootstrap_refits`)."""
    from simtune.common.limits import MIN_BOOTSTRAP

    run_dir = Path(run_dir)
    if 0 < bootstrap < MIN_BOOTSTRAP:
        raise SimtuneError(
            f"--bootstrap {bootstrap}: a 95 % interval needs {MIN_BOOTSTRAP} draws or more (0: Gauss-Newton alone)"
        )
    path = _run_to_write(run_dir, "uncertainty")
    with run_lock(run_dir):
        store = RunStore(run_dir)
        try:
            # as resume, report and export do: intervals read from a damaged store would be garbage said calmly
            store.verify()
            stored = store.get("config")
            if stored is None:
                raise never_set_up(run_dir)
            config = RunConfig.from_stored(stored, str(path))
            plan = plan_run(config)
            check_data_found(run_dir, plan)
            if store.get("status") != "finished":
                raise SimtuneError(f"{run_dir}: the run is not finished: `simtune resume {run_dir}` finishes it")
            objective = plan.objective(store.get("inactive_parameters"), store.get("parameters"))
            _check_parameters(run_dir, objective, store, config)
            best = store.best_evaluation()
            if best is None:
                raise SimtuneError(f"{run_dir}: no evaluations in the run")
            summary = uncertainty(
                objective,
                np.asarray(best["x"]),
                plan.full_space,
                store.get("inactive_parameters") or {},
                workers,
                known=store,
                bootstrap=bootstrap,
            )
            store.set(uncertainty=summary)
            return summary
        except sqlite3.DatabaseError as exc:
            raise SimtuneError(f"{path} is damaged ({exc})") from None
        finally:
            store.close()


def _combine(search: TuneResult, refined: TuneResult) -> TuneResult:
    """One result for a search followed by its refinement: the better point by fitness, counts added up."""
    best = refined if refined.fitness < search.fitness else search
    gain = search.fitness - best.fitness
    return TuneResult(
        best.x,
        best.params,
        best.score,
        search.generations + refined.generations,
        refined.evaluations,
        search.new_evaluations + refined.new_evaluations,
        refined.wall_s,
        f"{search.message}; refined by {gain:.4g} ({refined.message})",
        search.converged,
        search.history + refined.history,
        search.pruned_evaluations + refined.pruned_evaluations,
        search.steps + refined.steps,
        search.used_evaluations + refined.used_evaluations,
        search.stop_reason,  # why the search stopped: the refinement runs after it either way
    )
