"""A run as its store holds it: :class:`RunRecord`, read by :func:`read_record` (the one reader of a run).

The API (:func:`simtune.api.read_run`), export (:func:`simtune.export.source.read_run`) and the report
(:func:`simtune.report.collect.load_run`) each check what they need of it, with their own messages; none of them
opens the store.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from simtune.store.runstore import RunStore


@dataclass(frozen=True)
class RunRecord:
    """One run (finished or not) as its store holds it, read once.  Values the store may lack are None: a store
    not written by ``simtune tune`` lacks them, and each reader says so in its own words."""

    path: Path
    #: the store's schema version
    version: int
    status: str | None
    #: the last session's message (None: the store has none)
    message: str | None
    #: the run's configuration as stored (``RunConfig.record()``): engine, tasks, space, data, seed, optimiser, ...
    config: dict | None
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
    def engine(self) -> str:
        return str(self._setting("engine"))

    @property
    def tasks(self) -> str:
        """The tasks as configured: "cube" or "single,cube"."""
        return str(self._setting("tasks"))

    @property
    def space(self) -> str:
        return str(self._setting("space"))

    @property
    def optimizer(self) -> str:
        return str((self.config or {}).get("optimizer", "de"))

    @property
    def data_fingerprint(self) -> dict | None:
        """The recordings' files the run was tuned on (task -> [{file, bytes, sha256}]), as it stored them."""
        return (self.fingerprint or {}).get("data")

    @property
    def active(self) -> list[bool]:
        """For each searched parameter, whether it can change a rollout of the run's tasks."""
        return [name not in self.inactive for name in self.parameters or []]

    def _setting(self, key: str):
        if not isinstance(self.config, dict) or key not in self.config:
            raise KeyError(f"the stored configuration has no {key!r}")
        return self.config[key]


def read_record(run_dir: Path | str) -> RunRecord:
    """The run in ``run_dir`` as its store holds it, read without writing anything.

    Raises :class:`~simtune.errors.SimtuneError` for a folder without a store, a store of an unknown version or
    one whose pages SQLite's quick check finds damaged, :class:`sqlite3.Error` for one it cannot open and
    :class:`ValueError` for unreadable meta values.
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
            config=store.get("config"),
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
