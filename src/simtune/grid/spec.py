"""A grid's specification, its units, and the work one unit does (in a worker process)."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from simtune.errors import ConfigError, SimtuneError


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
    keep_inactive: bool = False  # keep parameters that change no rollout in the search (the paper's full D)
    reference: str = "aligned"  # what each run is scored against: aligned (repeats on one clock) or mean
    #: which of each task's recorded repeats build that reference: all, even or odd (``--repeat-set``; ``repeats``
    #: is the number of seeds)
    repeat_set: str = "all"

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
        from simtune.data import check_repeats
        from simtune.data.clock import check_reference
        from simtune.engines import engine_class
        from simtune.objective import load_references
        from simtune.params import get_space
        from simtune.tasks import parse_tasks

        if self.repeats < 1:
            raise ConfigError("--repeats must be at least 1")
        check_reference(self.reference, "--reference")
        check_repeats(self.repeat_set, "--repeat-set")
        for name in self.engines:
            for space in self.spaces:
                get_space(space, engine_class(name).supported(), self.only)
        tasks = {t.name: t for entry in self.tasks for t in parse_tasks(entry.replace("+", ","))}
        load_references(Path(self.data), list(tasks.values()), reference=self.reference, repeats=self.repeat_set)


def unit_config(unit: Unit, spec: GridSpec):
    """The run configuration of one unit of ``spec`` (a :class:`~simtune.run_config.RunConfig`)."""
    from simtune.run_plan import new_run_config

    return new_run_config(
        unit.engine,
        unit.tasks,
        unit.space,
        data=spec.data,
        seed=unit.seed,
        workers=1,
        max_seconds=spec.max_seconds_per_run,
        max_generations=spec.max_generations,
        only=spec.only,
        keep_inactive=spec.keep_inactive,
        reference=spec.reference,
        repeats=spec.repeat_set,
        # a grid's unit runs the paper's DE, one worker without a time-out, as grids always have: a grid resumed
        # after an upgrade finds its units' stored settings unchanged
        optimizer="de",
        eval_timeout=None,
    )


def stored_differences(unit: Unit, run_dir: Path, spec: GridSpec) -> list[str]:
    """The settings in which the run stored in ``run_dir`` differs from what ``spec`` asks of ``unit`` (their names:
    ``data``, ``only`` ...); empty where it holds none, or the same."""
    from simtune.store import STORE_FILE, RunStore, check_store_file

    path = Path(run_dir)
    if not (path / STORE_FILE).exists() or not check_store_file(path / STORE_FILE):
        return []
    store = RunStore.open_read_only(path)
    try:
        stored = store.get("config")
    finally:
        store.close()
    if stored is None:
        return []
    wanted = unit_config(unit, spec).record()
    stored = {"reference": "mean", **stored}  # a run stored before the choice of reference scored against the mean
    return sorted(key for key in set(stored) | set(wanted) if stored.get(key) != wanted.get(key))


def other_settings(run_dir: Path, differences: list[str]) -> SimtuneError:
    """The error for a grid cell whose folder holds a run of other settings."""
    return SimtuneError(
        f"{run_dir} holds a run with other settings ({', '.join(differences)} differ from this grid's): a grid "
        "with other settings needs another --out"
    )


def run_unit(unit: Unit, run_dir: str, spec: GridSpec) -> dict:
    """Run or resume one optimisation; returns its summary.  Safe to run again after a crash."""
    from simtune.runs import has_run, read_run_record, resume_run, start_run
    from simtune.store.lock import run_lock

    path = Path(run_dir)
    config = unit_config(unit, spec)
    try:
        path.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise SimtuneError(f"cannot create run folder {path}: {exc.strerror}") from None
    with run_lock(path):  # one writer: a unit still running elsewhere (a worker thought lost) refuses this one
        if has_run(path):
            differences = stored_differences(unit, path, spec)
            if differences:  # never adopted as this cell (nor its store rewritten)
                raise other_settings(path, differences)
            result = resume_run(path, show_progress=False)
        else:  # new, or died before the run was set up: start_run clears such a store
            result = start_run(config, path, show_progress=False)
    generic = read_run_record(path).generic_score  # stored as the run started
    return dict(
        fitness=result.score.fitness,
        generic_fitness=generic["fitness"],
        evaluations=result.evaluations,
        generations=result.generations,
        wall_s=result.wall_s,
    )
