"""simtune from Python: load a project, evaluate parameters, tune, read a run; one result type.

::

    import simtune.api as st

    project = st.load_project("myproject")           # or None: the bundled Kinova MICO project
    generic = st.evaluate("mujoco", "cube", project=project)
    tuned = st.tune("mujoco", "cube", project=project, out="runs/cube", max_evaluations=500)
    print(tuned.fitness, tuned.x["timestep"], tuned.parts["cube"].object_error)
    again = st.read_run("runs/cube")                  # the same Result, from the run folder

Every function is the command of the same name (``simtune evaluate``, ``simtune tune``) without the
printing: the same objective (:mod:`simtune.objective`) and runs (:mod:`simtune.runs`), the same
one-line :class:`~simtune.errors.SimtuneError` for bad input.  docs/api.md has the details.
"""

from __future__ import annotations

import os
import sqlite3
import time
from collections.abc import Collection, Mapping
from dataclasses import dataclass, field
from pathlib import Path

from simtune.alignment import DelayEstimate, aligned, estimate_delay
from simtune.engines import engine_class
from simtune.errors import ConfigError, SimtuneError
from simtune.fitness import FitnessWeights, Score, TaskScore
from simtune.objective import Objective, load_references
from simtune.params import read_params_file, validate_params
from simtune.project import Project, get_project
from simtune.project import load_project as _load_project
from simtune.runs import RunConfig, start_run
from simtune.store import STORE_FILE, RunStore
from simtune.tasks.spec import common_robot


@dataclass(frozen=True)
class Result:
    """Parameters and their fitness, in the spirit of SciPy's ``OptimizeResult``.

    ``x``: the parameter values (name -> value; those not named keep the engine's generic values);
    ``fitness`` = ``wrist_error`` + ``object_error`` (+ the weighted ``joint_error`` of joint logs;
    parts the recordings lack are None) summed over the tasks, whose own scores are
    ``parts`` (task name -> TaskScore); ``generic_fitness``: the engine's generic parameters on the
    same tasks; ``evaluations``: simulations of all tasks the result took (a run's stored ones);
    ``run_dir``: the run folder of a tuning run (None for an evaluation).
    """

    engine: str
    tasks: tuple[str, ...]
    x: dict[str, float]
    fitness: float
    wrist_error: float | None
    object_error: float | None
    parts: dict[str, TaskScore]
    generic_fitness: float
    stable: bool
    evaluations: int
    run_dir: Path | None = None
    message: str = ""
    #: seconds spent simulating (evaluate) or tuning (all sessions of a run)
    wall_s: float = 0.0
    #: mean joint-angle error [rad] of joint-log recordings; None without them
    joint_error: float | None = None
    #: tasks whose recording clock was aligned (evaluate's ``align_clock``): how, and the fitness without it
    alignments: tuple[DelayEstimate, ...] = ()
    fitness_unaligned: float | None = None
    #: task -> the command delay [s] its clock was aligned with
    clock_aligned: dict[str, float] = field(default_factory=dict)

    @classmethod
    def from_score(cls, engine: str, x: Mapping[str, float], score: Score, generic: Score | dict, **more) -> Result:
        generic_fitness = generic["fitness"] if isinstance(generic, dict) else generic.fitness
        return cls(
            engine=engine,
            tasks=tuple(t.task for t in score.tasks),
            x=dict(x),
            fitness=score.fitness,
            wrist_error=score.wrist_error,
            object_error=score.object_error,
            joint_error=score.joint_error,
            parts={t.task: t for t in score.tasks},
            generic_fitness=float(generic_fitness),
            stable=score.stable,
            **more,
        )


def load_project(path: Path | str | None = None) -> Project:
    """The project in folder ``path`` (docs/task-files.md); None: the bundled Kinova MICO project."""
    return get_project(None) if path is None else _load_project(_path("path", path))


# --- the arguments, each checked where it enters: a ConfigError naming it, never a TypeError deep inside ------------


def _path(name: str, value: object) -> Path:
    """A file or folder given as a str or a Path."""
    if isinstance(value, str | os.PathLike) and not isinstance(value, bytes):
        return Path(value)
    raise ConfigError(f"{name}: expected a file or folder (a str or a Path), got {value!r}")


def _names(name: str, value: object, example: str) -> list[str]:
    """Names given as one string (comma-separated) or as a list of strings; at least one."""
    if isinstance(value, str):
        names = [part.strip() for part in value.split(",") if part.strip()]
    elif isinstance(value, Collection) and not isinstance(value, Mapping) and all(isinstance(v, str) for v in value):
        names = [v.strip() for v in value]
    else:
        raise ConfigError(f"{name}: expected names (a string such as {example!r}, or a list of them), got {value!r}")
    if not names or not all(names):
        raise ConfigError(f"{name}: names nothing ({value!r}): give one or more, e.g. {example!r}")
    return names


def _project(project: object) -> Project:
    if project is None or isinstance(project, Project):
        return get_project(project)
    return get_project(_path("project", project))


def _weights(weights: object) -> FitnessWeights | None:
    """Fitness weights given as FitnessWeights, a mapping or ``joint=0.1,wrist=1`` (None: the defaults)."""
    if weights is None or isinstance(weights, FitnessWeights):
        return weights
    if isinstance(weights, str):
        return FitnessWeights.parse(weights)
    if not isinstance(weights, Mapping) or not all(isinstance(k, str) for k in weights):
        raise ConfigError(
            "weights: expected FitnessWeights, a mapping such as {'joint': 0.1} or the text 'joint=0.1,wrist=1', "
            f"got {weights!r}"
        )
    return FitnessWeights.from_mapping(weights, "weights")


def _params(params: object) -> Mapping[str, float] | Path:
    """Parameter values given as a mapping of names to numbers, or as a params file (a str or a Path)."""
    if params is None:
        return {}
    if isinstance(params, Mapping):
        if not all(isinstance(k, str) for k in params):
            raise ConfigError(f"params: expected parameter names (strings) as keys, got {list(params)!r}")
        return params
    return _path("params", params)


def _root(data: object, project: Project) -> Path | None:
    """``data`` (absolute: a run stores it), else the project's data root (None: each task's own recordings)."""
    return Path(os.path.abspath(_path("data", data))) if data is not None else project.data_root()


def _aligned(align_clock: object, specs) -> set[str]:
    """The tasks whose clocks ``align_clock`` names: True (all), False (none) or task names of ``specs``."""
    if align_clock is None or isinstance(align_clock, bool):
        return {t.name for t in specs} if align_clock else set()
    if not isinstance(align_clock, str | Collection) or isinstance(align_clock, Mapping):
        raise ConfigError(f"align_clock: expected True, False or task names, got {align_clock!r}")
    names = _names("align_clock", align_clock, "cube") if align_clock else []
    known = [t.name for t in specs]
    for name in names:
        if name not in known:
            raise ConfigError(f"align_clock: unknown task {name!r} (the tasks evaluated: {', '.join(known)})")
    return set(names)


def evaluate(
    engine: str = "mujoco",
    tasks: str | Collection[str] = "cube",
    *,
    project: Project | Path | str | None = None,
    data: Path | str | None = None,
    params: Mapping[str, float] | Path | str | None = None,
    weights: FitnessWeights | Mapping[str, float] | str | None = None,
    joint_topic: str | None = None,
    align_clock: bool | Collection[str] = False,
) -> Result:
    """Fitness of ``params`` (a mapping, or a params file such as best_params.json; default: the engine's
    generic values) for ``engine`` on ``tasks`` (names or groups: comma-separated, or a list) of ``project``.

    ``data``: the data root (``DATA/<task>/``); default: the project's recordings.  ``weights``: of the
    fitness's parts (``simtune.fitness.FitnessWeights``, a mapping or ``"joint=0.1,wrist=1"``);
    ``joint_topic``: the JointState topic of ROS 2 joint logs (docs/recordings.md).  ``align_clock``:
    True, or the names of the tasks whose recording clock is aligned first (their command delay estimated
    from the recordings with the physics of ``params`` held fixed, :mod:`simtune.alignment`); the result's
    ``fitness_unaligned`` is the fitness without it.  An argument of the wrong type or value is a
    :class:`~simtune.errors.ConfigError` naming it.
    """
    fitness_weights = _weights(weights)
    proj = _project(project)
    specs = proj.parse_tasks(",".join(_names("tasks", tasks, "single,cube")))
    names = _aligned(align_clock, specs)
    given = _params(params)
    if joint_topic is not None and not isinstance(joint_topic, str):
        raise ConfigError(f"joint_topic: expected a topic name (a string), got {joint_topic!r}")
    cls = engine_class(engine)
    robot = common_robot(specs)
    supported = cls.supported(robot)
    if isinstance(given, Path):
        file_values = read_params_file(given, engine)
        values = validate_params(file_values, supported, engine, where=str(given), robot=robot)
    else:
        values = validate_params(dict(given), supported, engine, where="params", robot=robot)
    references = load_references(_root(data, proj), specs, joint_topic)
    objective = Objective(engine, specs, references, weights=fitness_weights)
    try:
        start = time.perf_counter()
        score = objective.score(values)
        wall = time.perf_counter() - start
        generic = score if not values else objective.score({})
        evaluations = 1 if not values else 2
        estimates = tuple(estimate_delay(objective, t, values) for t in specs if t.name in names)
        unaligned = score
        if estimates:
            values = aligned(values, list(estimates))
            score = objective.score(values)
            evaluations += 1 + sum(e.rollouts for e in estimates)
    finally:
        objective.close()
    more = (
        {
            "alignments": estimates,
            "fitness_unaligned": unaligned.fitness,
            "clock_aligned": {e.task: e.delay_s for e in estimates},
        }
        if estimates
        else {}
    )
    return Result.from_score(engine, values, score, generic, evaluations=evaluations, wall_s=wall, **more)


def tune(
    engine: str = "mujoco",
    tasks: str | Collection[str] = "cube",
    *,
    out: Path | str,
    project: Project | Path | str | None = None,
    data: Path | str | None = None,
    space: str = "extended",
    optimizer: str = "auto",
    refine: bool = False,
    seed: int = 0,
    workers: int = 1,
    max_evaluations: int | None = None,
    max_seconds: float | None = None,
    max_generations: int = 1000,
    target_fitness: float | None = None,
    only: str | Collection[str] | None = None,
    eval_timeout: float = 600.0,
    weights: FitnessWeights | Mapping[str, float] | str | None = None,
    joint_topic: str | None = None,
    show_progress: bool = False,
) -> Result:
    """Tune ``engine`` on ``tasks`` of ``project`` into the new run folder ``out`` (``simtune tune``).

    The run is an ordinary one: ``simtune resume OUT`` continues it, ``read_run(OUT)`` reads it.
    The run stores the project by its project file (the bundled MICO project: not at all).  ``only``: the
    parameters to tune (a comma-separated string or a list; None: the whole space).
    """
    out_dir = _path("out", out)
    proj = _project(project)
    fitness_weights = _weights(weights)
    config = RunConfig(
        engine=engine,
        tasks=",".join(_names("tasks", tasks, "single,cube")),
        space=space,
        data=None if (root := _root(data, proj)) is None else str(root),
        seed=seed,
        workers=workers,
        max_seconds=max_seconds,
        max_generations=max_generations,
        only=None if only is None else _names("only", only, "command_delay"),
        eval_timeout=eval_timeout,
        target_fitness=target_fitness,
        optimizer=optimizer,
        refine=refine,
        max_evaluations=max_evaluations,
        project=None if proj is get_project(None) else str(proj.file.resolve()),
        weights=None if fitness_weights is None else fitness_weights.as_dict(),
        joint_topic=joint_topic,
    )
    start_run(config, out_dir, show_progress=show_progress)
    return read_run(out_dir)


def read_run(run_dir: Path | str) -> Result:
    """The best parameters of the run in ``run_dir`` (finished or not) as a :class:`Result`."""
    run_dir = _path("run_dir", run_dir)
    if not (run_dir / STORE_FILE).is_file():
        raise SimtuneError(f"{run_dir} is not a run folder (no {STORE_FILE})")
    try:
        return _read_run(run_dir)
    except sqlite3.DatabaseError as exc:
        raise SimtuneError(f"{run_dir / STORE_FILE}: cannot read the run store ({exc}): is it damaged?") from None


def _read_run(run_dir: Path) -> Result:
    store = RunStore.open_read_only(run_dir)
    try:
        config = store.get("config")
        best = store.best_evaluation()
        if config is None or best is None:
            raise SimtuneError(f"{run_dir}: the run has no evaluation yet")
        names = store.get("parameters")
        return Result.from_score(
            str(config["engine"]),
            dict(zip(names, (float(v) for v in best["x"]), strict=True)),
            Score.from_dict(best["score"]),
            store.get("generic"),
            evaluations=store.count_evaluations(),
            run_dir=run_dir,
            message=str(store.get("message", store.get("status", ""))),
            wall_s=float(store.get("elapsed_s", 0.0) or 0.0),
        )
    finally:
        store.close()


__all__ = ["Project", "Result", "evaluate", "load_project", "read_run", "tune"]
