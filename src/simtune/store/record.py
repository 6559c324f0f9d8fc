"""A run as its store holds it: :class:`RunRecord`, read by :func:`read_record` (the one reader of a run).

The API (:func:`simtune.api.read_run`), export (:class:`simtune.export.source.TunedRun`) and the report
(:class:`simtune.report.collect.ReportedRun`) are views of one record, read through
:func:`simtune.runs.read_run_record`; the checks they share (a configuration, a finished search, an evaluation,
parameter names and bounds that agree) are the record's, so each is written once.  None of them opens the store.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from functools import cached_property
from pathlib import Path
from typing import Generic, Protocol, TypeVar

from simtune.errors import SimtuneError
from simtune.store.runstore import STORE_FILE, RunStore
from simtune.tasks import TaskSpec, held_out, parse_tasks


class StoredConfig(Protocol):
    """What the record itself reads of a run's checked configuration (:class:`simtune.run_plan.RunConfig` is one).

    The check of a stored configuration (``RunConfig.from_stored``) needs the optimisers' registry and the fitness
    weights, which sit above the store (docs/architecture.md's layers); so :func:`read_record` is handed the check by
    its caller and the record is generic in what the check returns.  Readers thus get a typed configuration, never
    the stored dict to read by key, and the store imports nothing above it."""

    @property
    def engine(self) -> str: ...
    @property
    def tasks(self) -> str: ...
    @property
    def space(self) -> str: ...
    @property
    def optimizer(self) -> str: ...
    @property
    def project(self) -> str | None: ...
    @property
    def targets(self) -> str: ...
    @property
    def loading(self) -> str: ...


ConfigT = TypeVar("ConfigT", bound=StoredConfig)


@dataclass(frozen=True)
class RunRecord(Generic[ConfigT]):
    """One run (finished or not) as its store holds it, read once.  Values the store may lack are None: a store
    not written by ``simtune tune`` lacks them; the checks below say so in one line each."""

    path: Path
    #: the store's schema version
    version: int
    status: str | None
    #: the last session's message (None: the store has none)
    message: str | None
    #: the run's configuration as stored (``RunConfig.record()``), checked by the ``check`` :func:`read_record` was
    #: handed; None: the store has none (a run never set up); :attr:`settings` says so
    config: ConfigT | None
    #: the command line that made the run
    command: list
    #: the versions of simtune, the engine and the libraries that made it
    versions: dict
    #: the fingerprint the run checks on resume: its recordings' files (``data``), its tasks, its engine
    fingerprint: dict | None
    #: the searched parameters, in the order of a vector, and their bounds
    parameters: list[str] | None
    bounds: list | None
    #: parameters of the run's space that change no rollout of its tasks, and why (left out of the search)
    inactive: dict
    #: Score.to_dict() of the engine's generic parameters
    generic: dict | None
    #: the best evaluation: its exact vector ``x`` and ``score`` (Score.to_dict()); None without evaluations
    best: dict | None
    #: SciPy's settings of a differential-evolution run (None: another optimiser)
    de_settings: dict | None
    #: the search met its convergence criterion
    converged: bool
    #: why the search stopped (simtune.optimize.base.STOP_REASONS); None for runs stored before it was kept
    stop_reason: str | None
    #: the verdict after the tune (simtune.uncertainty.verdict: floor, over_floor, moved); None before it was kept
    verdict: dict | None
    #: the Gauss-Newton uncertainty at the best point (``simtune uncertainty``), if computed
    uncertainty: dict | None
    #: the held-out tasks scored with the best parameters (``--validate``: simtune.run_plan.RunPlan.validation_score);
    #: None without them
    validation: dict | None
    evaluations: int
    #: evaluations that blew up or failed, and those pruned
    outcomes: dict
    #: each generation checkpoint: generation, best fitness, evaluation count, elapsed time
    generations: list[dict]
    #: fitness and exact vectors of the initial population (generation 0), in store order
    initial_fitness: list[float]
    initial_population: list[list[float]]
    #: where a ``resume --rescore`` started this run from: the changes, the members taken, the old store's file
    rescored_from: dict | None
    #: the run's wall time over all its sessions (s)
    elapsed_s: float
    #: when its last stored evaluation finished (seconds since the epoch)
    finished_at: float | None

    @property
    def store_file(self) -> Path:
        return self.path / STORE_FILE

    @property
    def settings(self) -> ConfigT:
        """The run's checked configuration; a one-line error for a store that holds none."""
        if self.config is None:
            raise SimtuneError(f"{self.store_file}: store has no 'config' (the run was never set up by `simtune tune`)")
        return self.config

    @property
    def engine(self) -> str:
        return self.settings.engine

    @property
    def tasks(self) -> str:
        """The tasks as configured: "cube" or "single,cube"."""
        return self.settings.tasks

    @property
    def space(self) -> str:
        return self.settings.space

    @property
    def optimizer(self) -> str:
        return self.settings.optimizer

    @cached_property
    def task_specs(self) -> list[TaskSpec]:
        """The run's tasks as it ran them: from its project, with its targets.  Resolved on first use (a reader of
        the run's numbers alone never reads its project), then kept."""
        return self.resolve_tasks()

    def resolve_tasks(self, project: str | None = None) -> list[TaskSpec]:
        """The run's tasks (those it tuned on: not the ones ``--validate`` held out), with its targets and loading,
        from ``project`` where given (its project moved since), else from the run's own project."""
        config = self.settings
        tasks = parse_tasks(config.tasks, project or config.project, config.targets, config.loading)
        return held_out(tasks, getattr(config, "validate", ""))[0]  # those it tuned on, not those it held out

    @property
    def data_fingerprint(self) -> dict | None:
        """The recordings' files the run was tuned on (task -> [{file, bytes, sha256}]), as it stored them."""
        return (self.fingerprint or {}).get("data")

    @property
    def active(self) -> list[bool]:
        """For each searched parameter, whether it can change a rollout of the run's tasks."""
        return [name not in self.inactive for name in self.parameters or []]

    def unfinished(self) -> str | None:
        """Why the run cannot be read as finished (its status, and how to finish it); None for a finished run."""
        if self.status == "finished":
            return None
        return f"{self.path} is an unfinished run (status {self.status!r}): `simtune resume {self.path}` finishes it"

    @property
    def searched(self) -> list[str]:
        """The searched parameters, checked against their bounds: a one-line error for a store lacking either."""
        parameters, bounds = self.parameters, self.bounds
        if parameters is None or bounds is None:
            raise SimtuneError(f"{self.store_file}: store has no {'parameters' if parameters is None else 'bounds'!r}")
        if len(bounds) != len(parameters):
            raise SimtuneError(f"{self.store_file}: {len(parameters)} parameter names but {len(bounds)} bounds")
        return list(parameters)

    @property
    def best_evaluation(self) -> dict:
        """The best evaluation (its exact vector ``x`` and ``score``): a one-line error for a store without one or
        whose vector does not fit its parameters."""
        names = self.searched
        if self.best is None:
            raise SimtuneError(f"{self.store_file}: the run has no evaluation yet")
        if len(self.best["x"]) != len(names):
            raise SimtuneError(
                f"{self.store_file}: the best vector has {len(self.best['x'])} values for {len(names)} parameters"
            )
        return self.best

    @property
    def generic_score(self) -> dict:
        """Score.to_dict() of the engine's generic parameters (stored as the run starts)."""
        if self.generic is None:
            raise SimtuneError(f"{self.store_file}: store has no 'generic' score (not written by `simtune tune`?)")
        return self.generic

    def check_result(self) -> tuple[dict, dict]:
        """The best evaluation and the generic score, checked: what a reader of the run's result needs."""
        return self.best_evaluation, self.generic_score

    @property
    def best_params(self) -> dict[str, float]:
        """The best evaluation's parameter values, by name (the parameters not searched keep generic values)."""
        return dict(zip(self.searched, (float(v) for v in self.best_evaluation["x"]), strict=True))


@dataclass(eq=False)
class RunView(Generic[ConfigT]):
    """What a reader's view of one record (export's TunedRun, the report's ReportedRun) reads of it alike."""

    record: RunRecord[ConfigT]

    @property
    def config(self) -> ConfigT:
        """The run's checked configuration."""
        return self.record.settings

    @property
    def engine(self) -> str:
        return self.record.engine

    @property
    def space(self) -> str:
        return self.record.space


def read_record(run_dir: Path | str, check: Callable[[object, str], ConfigT]) -> RunRecord[ConfigT]:
    """The run in ``run_dir`` as its store holds it, read without writing anything.

    ``check`` turns the stored configuration into a checked one (``RunConfig.from_stored``: the stored value and
    where it comes from, for its errors); see :class:`StoredConfig` for why the caller hands it over.

    Raises :class:`~simtune.errors.SimtuneError` for a folder without a store, a store of an unknown version or
    one whose pages SQLite's quick check finds damaged, :class:`sqlite3.Error` for one it cannot open and
    :class:`ValueError` for unreadable meta values; ``check``'s error for a configuration it refuses.
    """
    store = RunStore.open_read_only(Path(run_dir))
    try:
        # a store damaged by garbage is refused here as resume refuses it: report and export read through here
        store.verify()
        return RunRecord(
            path=Path(run_dir),
            version=store.version,
            status=store.get("status"),
            message=store.get("message"),
            config=None if (stored := store.get("config")) is None else check(stored, str(store.path)),
            command=store.get("command") or [],
            versions=store.get("versions") or {},
            fingerprint=store.get("fingerprint"),
            parameters=store.get("parameters"),
            bounds=store.get("bounds"),
            inactive=dict(store.get("inactive_parameters") or {}),
            generic=store.get("generic"),
            best=store.best_evaluation(),
            de_settings=store.get("de_settings"),
            converged=bool(store.get("search_converged", False)),
            stop_reason=store.get("search_stop_reason"),
            verdict=store.get("verdict"),
            uncertainty=store.get("uncertainty"),
            validation=store.get("validation"),
            evaluations=store.count_evaluations(),
            outcomes=store.count_outcomes(),
            generations=store.generations(),
            initial_fitness=store.initial_fitness(),
            initial_population=store.initial_population(),
            rescored_from=store.get("rescored_from"),
            elapsed_s=float(store.get("elapsed_s", 0.0) or 0.0),
            finished_at=store.last_finished_at(),
        )
    finally:
        store.close()
