"""A run's configuration and its plan: what the user asked for, and what it resolves to, once.

:class:`RunConfig` is what a run stores (``run.sqlite``'s ``config``, its JSON form kept as it was so that old
runs resume) and :func:`new_run_config` the one place a new one is made, by the API, the grid, the studies and
the demo alike.  :func:`plan_run` resolves a configuration once into a :class:`RunPlan`: its project, the tasks,
their robot, the engine class, the parameter space, the inactive parameters, the references and the objective; a run
(:mod:`simtune.runs`) passes the plan down instead of resolving its configuration again in every step.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass
from functools import cached_property
from pathlib import Path

from simtune.activity import active_space, declared_inactive, inactive_parameters
from simtune.data import TaskData
from simtune.engines import Engine, engine_class
from simtune.errors import ConfigError, RecordingWarning
from simtune.fitness import FitnessWeights
from simtune.objective import Objective, check_weights, load_references
from simtune.params import ParameterSpace, get_space
from simtune.project import Project, get_project
from simtune.robot.description import RobotDescription
from simtune.run_config import (  # noqa: F401 (run_plan is its public home too: simtune.runs, the studies)
    DEFAULT_SPACE,
    RESIDUALS,
    RunConfig,
    default_space,
)
from simtune.tasks import TaskSpec, held_out, select_tasks


def new_run_config(
    engine: str,
    tasks: str,
    space: str,
    *,
    data: Path | str | None,
    project: Project | None = None,
    weights: FitnessWeights | None = None,
    **settings,
) -> RunConfig:
    """The configuration of a new run, as its store keeps it: ``data`` as given (made absolute by the caller
    where the run must find it from any folder), ``project`` by its project file (the bundled MICO project: not
    at all), ``weights`` as a mapping; ``settings`` are RunConfig's other fields, their defaults where left out."""
    bundled = project is None or project is get_project(None)
    return RunConfig(
        engine=engine,
        tasks=tasks,
        space=space,
        data=None if data is None else str(data),
        project=None if project is None or bundled else str(project.file.resolve()),
        weights=None if weights is None else weights.as_dict(),
        **settings,
    )


@dataclass(eq=False)
class RunPlan:
    """What a run's configuration resolves to, resolved once: made by :func:`plan_run`.

    The inactive parameters and the references are read on first use: a resume that finds its data changed
    stops before either is needed, and a resumed run takes its inactive parameters from its store.
    """

    config: RunConfig
    #: the project the tasks were looked up in (``config.project``, resolved once)
    project: Project
    tasks: list[TaskSpec]
    robot: RobotDescription
    engine: type[Engine]
    #: the run's space before inactive parameters are left out: the engine's (or the paper's whole list)
    full_space: ParameterSpace
    #: the tasks held out of the search (``config.validate``), scored with its best parameters afterwards
    validation: tuple[TaskSpec, ...] = ()
    #: when the inactive-parameter probe stops measuring tasks it does not hold (``time.monotonic()``; a run under
    #: ``--max-seconds`` sets it: :func:`simtune.activity.inactive_parameters`); None: it measures every one
    probe_deadline: float | None = None

    @property
    def keeps_inactive(self) -> bool:
        """Whether the search keeps parameters that change no rollout (``keep_inactive``, ``paper_exact``)."""
        return self.config.keep_inactive or self.config.paper_exact

    @cached_property
    def inactive(self) -> dict[str, str]:
        """Parameters of the full space that change no rollout of the tasks: name -> why (measured, cached).

        A run that keeps them all records what the engine and the schedules declare instead: it searches every
        parameter either way, and the probe would only cost it rollouts."""
        if self.keeps_inactive:
            return declared_inactive(self.config.engine, self.tasks, self.full_space)
        return inactive_parameters(
            self.config.engine, self.tasks, self.full_space, workers=self.config.workers, deadline=self.probe_deadline
        )

    @cached_property
    def references(self) -> dict[str, TaskData]:
        """The recordings of every task (from the run's data root, else each task's own folder), as the run's
        reference (aligned or mean), of the run's repeats (all, even or odd)."""
        data = None if self.config.data is None else Path(self.config.data)
        config = self.config
        return load_references(
            data, self.tasks, config.joint_topic, config.reference, config.repeats, config.keep_repeats
        )

    def search_space(self, inactive: dict[str, str] | None = None) -> ParameterSpace:
        """The space searched: the full space less ``inactive`` (default: the measured ones) unless the run keeps
        them.  Parameters named by ``--only`` stay whether active or not: the user asked for them."""
        if self.keeps_inactive:
            return self.full_space
        inactive = self.inactive if inactive is None else inactive
        named = self.config.only or []
        idle = [name for name in named if name in inactive]
        if named and len(idle) == len(named):  # nothing the search could move: say so before any budget is spent
            why = "; ".join(f"{name}: {inactive[name]}" for name in idle[:3])
            raise ConfigError(
                f"--only: {'it changes' if len(idle) == 1 else 'they change'} no rollout of {self.config.tasks} "
                f"({why}): nothing to tune; `simtune params --task {self.config.tasks}` lists the active parameters"
            )
        if idle:
            warnings.warn(
                f"--only: {', '.join(idle)} change(s) no rollout of {self.config.tasks} and stay in the search "
                "without effect (`simtune params --task " + self.config.tasks + "` says why)",
                RecordingWarning,
                stacklevel=2,
            )
        return active_space(self.full_space, inactive, named)

    def objective(self, inactive: dict[str, str] | None = None, stored: list[str] | None = None) -> Objective:
        """The run's objective over :meth:`search_space` (``inactive``: a stored run's, else measured).  Weights
        that weigh nothing the recordings hold are refused before the inactive parameters are measured: a
        one-line refusal, not one after a probe of many rollouts.

        Args:
            inactive: the parameters left out as changing no rollout (a stored run's); None: measured.
            stored: a stored run's parameter list: the run keeps the parameters it was made with
                (:meth:`stored_space`).

        Returns:
            The objective (close it when done).
        """
        weights = self.config.weights
        fitness_weights = FitnessWeights() if weights is None else FitnessWeights.from_mapping(weights, "weights")
        check_weights(self.tasks, self.references, fitness_weights)
        space = self.search_space(inactive)
        if stored is not None:
            space = self.stored_space(space, stored)
        return Objective(
            self.config.engine,
            self.tasks,
            self.references,
            space,
            fitness_weights,
            noise_weighted=self.config.residuals == "noise",
            prior_strength=self.config.prior,
        )

    def validation_score(self, params: dict[str, float], fitted: float) -> dict | None:
        """The held-out tasks (:attr:`validation`) scored with ``params``, the run's best: what a tuned simulator
        does on motions it was not tuned on.

        A held-out task whose commands share its recordings' clock takes the run's shared ``command_delay``; one
        whose capture started on its own has no tuned delay, and its clock is aligned first (its delay estimated
        with the physics of ``params`` held fixed, :func:`simtune.alignment.estimate_delay`), as ``evaluate
        --align-clock`` does.

        Args:
            params: the parameter values to score (the run's best).
            fitted: the run's best fitness over its own tasks (the data's fit, summed over them).

        Returns:
            None without held-out tasks; else ``tasks`` (their names), ``parts`` (task -> fitness), ``fitness``
            (the mean per held-out task: ``validation_fitness``), ``fitted`` (the run's best fitness per tuned
            task, the same measure), ``ratio`` (the first over the second) and ``clock_aligned`` (task -> the delay
            [s] its clock was aligned with).
        """
        if not self.validation:
            return None
        from simtune.alignment import aligned, estimate_delay
        from simtune.params.kinds import DELAY, task_delay_name

        held = list(self.validation)
        data = None if self.config.data is None else Path(self.config.data)
        config = self.config
        references = load_references(
            data, held, config.joint_topic, config.reference, config.repeats, config.keep_repeats
        )
        weights = None if config.weights is None else FitnessWeights.from_mapping(config.weights, "weights")
        objective = Objective(config.engine, held, references, weights=weights)
        try:
            values = {k: v for k, v in params.items() if k != DELAY or any(t.shared_clock for t in held)}
            own = [
                t for t in held if not (t.shared_clock and DELAY in params) and task_delay_name(t.name) not in values
            ]
            estimates = [estimate_delay(objective, t, values) for t in own]
            score = objective.score(aligned(values, estimates) if estimates else values)
        finally:
            objective.close()
        per_task = score.data_fitness / len(held)
        per_tuned = fitted / max(len(self.tasks), 1)
        return {
            "tasks": [t.name for t in held],
            "parts": {t.task: t.fitness for t in score.tasks},
            "fitness": per_task,
            "fitted": per_tuned,
            "ratio": per_task / per_tuned if per_tuned > 0 else None,
            "clock_aligned": {e.task: e.delay_s for e in estimates},
        }

    def stored_space(self, space: ParameterSpace, stored: list[str]) -> ParameterSpace:
        """The parameters a stored run was made with, as this simtune defines them.

        A space grows when a kind is added to it (``extended`` gained the drive-train kinds): a run made before
        goes on over its own list, the added parameters at the generic values it simulated them with.

        Args:
            space: the space this simtune would search for the run's configuration.
            stored: the run's stored parameter list.

        Returns:
            ``space`` where the lists agree; else, where every stored name is still a parameter of the run's full
            space, those parameters in the stored order; else ``space`` as it is (the caller names the difference).
        """
        if space.names == stored:
            return space
        by_name = {p.name: p for p in self.full_space.parameters}
        if not all(name in by_name for name in stored):
            return space
        return ParameterSpace(space.name, tuple(by_name[name] for name in stored))


def plan_run(config: RunConfig) -> RunPlan:
    """Resolve ``config`` once: its project, its tasks (of that project), their robot, the engine class and the full
    space."""
    selected = select_tasks(config.tasks, config.project, config.targets, config.loading)
    tasks, held = held_out(selected.tasks, config.validate)
    robot = selected.robot
    engine = engine_class(config.engine)
    # the paper's runs varied every parameter of its list in every engine, whether the engine used it or not
    supported = None if config.paper_exact else engine.supported(robot)
    names = [t.name for t in tasks] if config.task_delays else None
    shared = [t.name for t in tasks if t.shared_clock]
    space = get_space(config.space, supported, config.only, robot=robot, tasks=names, shared_clock=shared)
    return RunPlan(config, selected.project, tasks, robot, engine, space, tuple(held))
