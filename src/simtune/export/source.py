"""A finished tuning run, read and checked before anything is exported from it.

Export refuses (one line, :class:`~simtune.errors.SimtuneError`) a folder that
is not a run (no ``run.sqlite``), a run store of another store version, a run
made by another simtune version (its engine mapping may differ from this
one's, so the files would not reproduce it), and an unfinished run: one whose
store status is not ``finished`` or that has no ``best_params.json``.  Both are
needed: ``best_params.json`` holds the tuned values and fitness that the
exported files reproduce, and the status says the optimiser wrote it at the
end of its last session rather than a killed session leaving an older file.
"""

from __future__ import annotations

import json
import warnings
from dataclasses import dataclass
from pathlib import Path

import simtune
from simtune.data.fingerprint import fingerprint_changes, folders_fingerprint
from simtune.engines import engine_class
from simtune.errors import SimtuneError
from simtune.objective import recordings_folder
from simtune.params import validate_params
from simtune.run_plan import RunConfig
from simtune.runs import BEST_PARAMS_FILE, read_run_record
from simtune.store import RunView
from simtune.store.lock import LOCK_FILE, RunBusy, check_free, describe_holder
from simtune.tasks import TaskSpec
from simtune.tasks.spec import common_robot


class ExportWarning(UserWarning):
    """Something about a run that does not stop its export but that its user should know."""


@dataclass(eq=False)
class TunedRun(RunView[RunConfig]):
    """What export needs from one finished run folder: a view of its record (:func:`simtune.runs.read_run_record`)
    with the tuned values of its ``best_params.json`` and the recordings it was tuned on."""

    params: dict[str, float]  # the tuned values (best_params.json); the rest keep the engine's generic ones
    best: dict  # best_params.json as written by the run
    data_files: dict[str, list[dict]]  # task -> [{file, bytes, sha256}] of the recordings it was tuned on
    data_note: str  # where the fingerprint comes from, or why it is missing

    @property
    def path(self) -> Path:
        return self.record.path.resolve()

    @property
    def tasks(self) -> list[TaskSpec]:
        """The run's tasks as it ran them (its project's, with its targets)."""
        return self.record.task_specs

    @property
    def task_names(self) -> list[str]:
        return [t.name for t in self.tasks]

    @property
    def versions(self) -> dict[str, str]:
        """The versions of simtune, the engine and the libraries that made the run, as it stored them."""
        return {str(k): str(v) for k, v in self.record.versions.items()}

    @property
    def command(self) -> list[str]:
        return [str(c) for c in self.record.command]

    @property
    def finished_at(self) -> float | None:
        """When the run's last stored evaluation finished (seconds since the epoch)."""
        return self.record.finished_at

    @property
    def evaluations(self) -> int:
        return int(self.record.evaluations)


def read_run(run_dir: Path | str) -> TunedRun:
    """The finished run in ``run_dir``, checked; a one-line SimtuneError if it cannot be exported."""
    run_dir = Path(run_dir)
    record = read_run_record(run_dir)
    engine = record.engine  # a store never set up has no configuration: refused here
    unfinished = record.unfinished()
    if unfinished is not None:
        _refuse_unfinished(run_dir, unfinished)
    best_file = run_dir / BEST_PARAMS_FILE
    best = _read_best(best_file, run_dir)
    versions = record.versions
    made_by = versions.get("simtune")
    if made_by != simtune.__version__:
        raise SimtuneError(
            f"{run_dir} was tuned by simtune {made_by}, this is simtune {simtune.__version__}: "
            f"its engine mapping may differ, export it with simtune {made_by}"
        )
    if best.get("engine", engine) != engine:
        raise SimtuneError(f"{best_file}: engine {best.get('engine')!r} differs from the run's {engine!r}")
    cls = engine_class(engine)
    tasks = record.task_specs
    robot = common_robot(tasks)
    params = validate_params(best["params"], cls.supported(robot), engine, where=str(best_file), robot=robot)
    installed = cls.version()
    if versions.get(engine) not in (None, installed):
        warnings.warn(
            f"{run_dir} was tuned with {engine} {versions.get(engine)}, exported with {installed}: "
            "the exported files may not reproduce its fitness exactly",
            ExportWarning,
            stacklevel=2,
        )
    data_files, note = _data_files(record.settings.data, tasks, record.data_fingerprint, run_dir)
    return TunedRun(record, params, best, data_files, note)


def _refuse_unfinished(run_dir: Path, unfinished: str) -> None:
    """Why a run that has not finished cannot be exported: it is being tuned now, or it stopped before its end."""
    try:
        check_free(run_dir)
    except RunBusy:
        raise SimtuneError(
            f"{run_dir} is being tuned right now by {describe_holder(run_dir / LOCK_FILE)}: "
            "export it when it has finished"
        ) from None
    raise SimtuneError(f"{unfinished}, then export")


def _read_best(best_file: Path, run_dir: Path) -> dict:
    """The run's ``best_params.json``: the tuned values and fitness the exported files reproduce."""
    if not best_file.is_file():
        raise SimtuneError(f"{run_dir} is an unfinished run: no {BEST_PARAMS_FILE}")
    try:
        best = json.loads(best_file.read_text())
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise SimtuneError(f"{best_file}: cannot read ({exc})") from None
    if not isinstance(best, dict) or not isinstance(best.get("params"), dict) or "fitness" not in best:
        raise SimtuneError(f"{best_file}: not a run's best parameters (no 'params' and 'fitness')")
    return best


def _data_files(
    data: str | None, tasks: list[TaskSpec], stored: dict | None, run_dir: Path
) -> tuple[dict[str, list[dict]], str]:
    """The recordings' fingerprint: the one the run stored if it has one, else the data folder's now."""
    task_names = [t.name for t in tasks]
    folders = {t.name: recordings_folder(data, t) for t in tasks}
    root = Path(data) if data is not None else ", ".join(str(f) for f in folders.values())
    present = Path(data).is_dir() if data is not None else all(f.is_dir() for f in folders.values())
    now = folders_fingerprint(folders) if present else None
    if isinstance(stored, dict):
        if now is not None and (changes := fingerprint_changes(stored, now)):
            warnings.warn(
                f"{run_dir}: the recordings in {root} changed since the run ({', '.join(changes[:3])}"
                f"{' ...' if len(changes) > 3 else ''}); provenance gives the ones it was tuned on",
                ExportWarning,
                stacklevel=3,
            )
        return stored, "fingerprint stored by the run"
    if now is None:
        warnings.warn(
            f"{run_dir}: its data folder {root} is gone: provenance cannot name the recordings' SHA-256",
            ExportWarning,
            stacklevel=3,
        )
        return {name: [] for name in task_names}, f"data folder {root} missing at export"
    return now, "fingerprint of the data folder at export (the run stored none)"
