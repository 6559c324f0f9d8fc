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

import math
import os
import time
from collections.abc import Callable, Collection, Mapping, Sequence
from dataclasses import dataclass, field, replace
from datetime import date
from pathlib import Path
from typing import Any

from simtune.alignment import DelayEstimate, aligned, estimate_delay
from simtune.check.project import Finding
from simtune.check.project import check_project as _check_project
from simtune.check.task import check as run_check
from simtune.check.task import moved_joints
from simtune.common import checks
from simtune.common.limits import MAX_BOOTSTRAP, MAX_SEED, MAX_SYNTH_REPEATS, MAX_WORKERS
from simtune.data.clock import DEFAULT_REFERENCE, check_reference, default_reference
from simtune.data.task import DEFAULT_REPEATS, check_repeats
from simtune.engines import engine_class
from simtune.errors import ConfigError, SimtuneError
from simtune.export import ExportResult, export_run, export_runs
from simtune.fitness import FitnessWeights, Score, TaskScore
from simtune.grid import GridIndex, GridSpec, run_grid
from simtune.grid import plan_grid as _plan_grid
from simtune.objective import Objective, load_references
from simtune.optimize import TuneResult
from simtune.params import get_space, read_params_file, validate_params
from simtune.project import Project, get_project
from simtune.project import load_project as _load_project
from simtune.reference import REFERENCE_DIR, run_demo
from simtune.run_config import COMPARE_DEFAULTS, COMPARE_SETS, DEFAULT_SPACE, TRANSFER_DEFAULTS
from simtune.run_config import DEFAULTS as RUN_DEFAULTS
from simtune.run_plan import RunConfig, new_run_config
from simtune.runs import read_run_record, resume_run, run_uncertainty, start_run
from simtune.studies.compare import run_compare
from simtune.studies.generalise import run_generalisation
from simtune.studies.sensitivity import METHODS, evaluation_count, run_sensitivity
from simtune.studies.synth import API_NAMES, DEFAULT_JOINT_NOISE_DEG, SynthResult, run_synth
from simtune.studies.transfer import run_transfer
from simtune.tasks import check_loading, check_targets, with_loading, with_targets
from simtune.tasks.init_project import init_project as _init_project
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
    #: what the fitness compared the simulation with: ``aligned`` (the repeats on one clock) or ``mean``
    reference: str = DEFAULT_REFERENCE
    #: which of each task's repeats built that reference: ``all``, ``even`` or ``odd``
    repeats: str = "all"
    #: task -> the file names of the repeats that built its reference (evaluate; empty for a run read back)
    repeat_files: dict[str, list[str]] = field(default_factory=dict)
    #: why a tuning run's search stopped (``converged``, ``max-seconds`` ...: simtune.optimize.base.STOP_REASONS);
    #: None for an evaluation and for runs stored before it was kept
    stop_reason: str | None = None
    #: what a run's prior (``prior``: simtune.objective.Prior) added to the fitness it minimised; ``fitness`` is the
    #: data's fit without it.  0 without a prior, and for an evaluation
    prior_penalty: float = 0.0
    #: a run's held-out tasks (``validate``) scored with its best parameters: ``tasks``, ``parts``, ``fitness`` (per
    #: held-out task), ``fitted`` (per tuned task), ``ratio``, ``clock_aligned``; None without them
    validation: dict | None = None

    @classmethod
    def from_score(cls, engine: str, x: Mapping[str, float], score: Score, generic: Score | dict, **more) -> Result:
        generic_fitness = generic["fitness"] if isinstance(generic, dict) else generic.fitness
        return cls(
            engine=engine,
            tasks=tuple(t.task for t in score.tasks),
            x=dict(x),
            fitness=score.data_fitness,
            prior_penalty=score.prior_penalty,
            wrist_error=score.wrist_error,
            object_error=score.object_error,
            joint_error=score.joint_error,
            parts={t.task: t for t in score.tasks},
            generic_fitness=float(generic_fitness),
            stable=score.stable,
            **more,
        )


def load_project(path: Path | str | None = None) -> Project:
    """The project in a folder (docs/task-files.md).

    Args:
        path: the project folder (or its simtune.toml); None: the bundled Kinova MICO project.

    Returns:
        The Project: its robot, ``tasks`` by name, ``groups`` and data root.
    """
    return get_project(None) if path is None else _load_project(_path("path", path))


# --- the arguments, each checked where it enters: a ConfigError naming it, never a TypeError deep inside ------------


def _workers(value: object) -> int:
    """A worker count: 1 to :data:`~simtune.common.limits.MAX_WORKERS`."""
    return checks.count("workers", value, 1, MAX_WORKERS)


def _path(name: str, value: object) -> Path:
    """A file or folder given as a str or a Path."""
    if isinstance(value, str | os.PathLike) and not isinstance(value, bytes):
        return Path(value)
    raise ConfigError(f"{name}: expected a file or folder (a str or a Path), got {checks.shown(value)}")


def _paths(name: str, value: object, what: str = "a file or folder") -> list[Path]:
    """Files or folders given as one str or Path, or a list of them."""
    if isinstance(value, str | os.PathLike) and not isinstance(value, bytes):
        return [Path(value)]
    if (
        not isinstance(value, Collection)
        or isinstance(value, Mapping | bytes)
        or not all(isinstance(v, str | os.PathLike) and not isinstance(v, bytes) for v in value)
    ):
        raise ConfigError(f"{name}: expected {what} (a str or a Path, or a list of them), got {checks.shown(value)}")
    return [Path(v) for v in value]


def _names(name: str, value: object, example: str) -> list[str]:
    """Names given as one string (comma-separated, blank ones dropped) or as a list of strings; at least one."""
    if isinstance(value, str):
        names = [part.strip() for part in value.split(",") if part.strip()]
    elif isinstance(value, Collection) and not isinstance(value, Mapping) and all(isinstance(v, str) for v in value):
        names = [v.strip() for v in value]
        for index, given in enumerate(names):
            if not given:  # a list is what the caller built: a blank item in it is a slip, not a separator
                raise ConfigError(f"{name}: the name at index {index} of {checks.shown(value)} is empty")
    else:
        raise ConfigError(
            f"{name}: expected names (a string such as {example!r}, or a list of them), got {checks.shown(value)}"
        )
    if not names:
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


def _study_root(data: object) -> Path:
    """The data root of a study (compare, transfer, sensitivity, a grid): ``data`` made absolute, else the
    recordings shipped with simtune."""
    return Path(os.path.abspath(_path("data", data))) if data is not None else REFERENCE_DIR


def _reference(reference: object, paper_exact: bool = False) -> str:
    """The reference kind asked for: ``aligned`` or ``mean``; None: aligned, or mean with ``paper_exact``."""
    return default_reference(paper_exact) if reference is None else check_reference(reference)


def _targets(targets: object, where: str) -> str:
    """The targets asked for (:data:`simtune.tasks.TARGETS`); None: the task files' (``task``)."""
    return "task" if targets is None else check_targets(targets, where)


def _repeats(repeats: object) -> str:
    """The repeats asked for: ``all``, ``even`` or ``odd``; None: all."""
    return DEFAULT_REPEATS if repeats is None else check_repeats(repeats)


def _flag(name: str, value: object) -> bool:
    """A switch: True or False (not 1, "yes" or None)."""
    if not isinstance(value, bool):
        raise ConfigError(f"{name} must be True or False, got {checks.shown(value)}")
    return value


def _sampling(method: object, samples: object) -> tuple[str, int]:
    """A sensitivity method (:data:`~simtune.studies.sensitivity.METHODS`) and its sample count: at least 2, a power
    of two for Sobol's (Saltelli) sampling."""
    if not isinstance(method, str) or method not in METHODS:
        raise ConfigError(f"method: unknown sensitivity method {checks.shown(method)} (known: {', '.join(METHODS)})")
    count = checks.count("samples", samples, 2)
    if method == "sobol" and count & (count - 1):
        raise ConfigError(f"samples: Sobol sampling needs a power of two (e.g. 64, 128, 256), got {count}")
    return method, count


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
            raise ConfigError(f"align_clock: unknown task {name!r} (the tasks evaluated: {', '.join(RUN_DEFAULTS)})")
    return set(names)


def init_project(
    urdf: Path | str,
    out: Path | str,
    *,
    tracked_link: str | None = None,
    driven_joints: str | Collection[str] | None = None,
    package_path: Path | str | Sequence[str | Path] = (),
    loaded: list | None = None,
    density: float | None = None,
    total_mass: float | None = None,
    dataset: Path | str | None = None,
    made: list | None = None,
) -> Path:
    """A new project for a robot given as a URDF or an MJCF file (``simtune init``; docs/own-robot.md).

    Args:
        urdf: the robot file, named in place by the project (never copied); an MJCF is told by its root element.
        out: the new project folder (absent, or empty).
        tracked_link: the link whose pose the recordings track; None: the loader's choice.
        driven_joints: the joints that drive the arm, joined by commas (as ``--driven-joints``) or a list; None:
            the loader's choice.
        package_path: a folder for a URDF's ``package://`` names, or ``NAME=DIR`` (package NAME is folder DIR), or
            a list of them (written into the project).
        loaded: a list that receives the robot as loaded (its ``choices`` say what was chosen and why).
        density: [kg/m^3] of the links without an ``<inertial>`` (default aluminium's).
        total_mass: [kg] spread over those links by volume instead (not with ``density``).
        dataset: a LeRobot dataset folder: the project's task is every episode of it, each its own task
            (``schedule_episode = "each"``; joints mapped by name, the angle unit checked against the limits, a
            duration every episode covers) instead of the example ``reach`` (``simtune init --dataset``).
        made: a list that receives what was read from ``dataset`` (its task's name, episodes, unit, joints).

    Returns:
        The project file (``OUT/simtune.toml``).

    Raises:
        ConfigError: an argument of the wrong type or value, named; ProjectError or RobotError: an ``out`` that
            holds anything, or a robot file that cannot be used (then nothing is written).
    """
    if tracked_link is not None and not isinstance(tracked_link, str):
        raise ConfigError(f"tracked_link: expected a link name (a string) or None, got {checks.shown(tracked_link)}")
    if loaded is not None and not isinstance(loaded, list):
        raise ConfigError(f"loaded: expected a list to receive the robot, or None, got {checks.shown(loaded)}")
    if made is not None and not isinstance(made, list):
        raise ConfigError(f"made: expected a list to receive the dataset's task, or None, got {checks.shown(made)}")
    return _init_project(
        _path("urdf", urdf),
        _path("out", out),
        tracked_link=tracked_link,
        driven_joints=None if driven_joints is None else _names("driven_joints", driven_joints, "joint_1,joint_2"),
        package_path=_paths("package_path", package_path, "folders or NAME=DIR"),
        loaded=loaded,
        # their range is init's own check (naming the command line's --density, which calls this)
        density=None if density is None else checks.number("density", density),
        total_mass=None if total_mass is None else checks.number("total_mass", total_mass),
        dataset=None if dataset is None else _path("dataset", dataset),
        made=made,
    )


def check_project(
    path: Path | str, engines: str | Collection[str] | None = None, data: Path | str | None = None
) -> list[Finding]:
    """Everything ``simtune check PROJECT`` reports on a project: problems, warnings and notes.

    Args:
        path: the project folder or its simtune.toml.
        engines: the engines to load the robot in, comma-separated or a list; None: every engine simtune knows.
        data: a data root (``DATA/<task>/``) whose recordings are checked instead of the project's own.

    Returns:
        The findings, each a problem, a warning or a note.
    """
    return _check_project(
        _path("path", path),
        None if engines is None else tuple(_names("engines", engines, "mujoco,pybullet")),
        None if data is None else _path("data", data),
    )


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
    reference: str | None = None,
    repeats: str | None = None,
    targets: str | None = None,
    keep_repeats: bool = False,
    loading: str | None = None,
) -> Result:
    """The fitness of parameter values for an engine on tasks (``simtune evaluate``).

    Args:
        engine: the physics engine (``simtune engines``).
        tasks: task names or groups, comma-separated or a list, of ``project``.
        project: a Project or its folder; None: the bundled MICO project.
        data: the data root (``DATA/<task>/``); None: the project's recordings.
        params: a mapping of parameter values, or a params file such as best_params.json; None: the engine's
            generic values.
        weights: of the fitness's parts: ``simtune.fitness.FitnessWeights``, a mapping or ``"joint=0.1,wrist=1"``;
            None: the defaults.
        joint_topic: the JointState topic of ROS 2 joint logs (docs/recordings.md); None: each log's only one.
        align_clock: True, or the names of the tasks whose recording clock is aligned first (their command delay
            estimated from the recordings with the physics of ``params`` held fixed, :mod:`simtune.alignment`).
        reference: ``aligned`` (None, the default: the repeats shifted onto one clock, then averaged) or ``mean``
            (the paper's plain mean of the repeats).
        repeats: which of each task's repeats build that reference: ``all`` (None, the default), ``even`` (the
            1st, 3rd ... in sorted order) or ``odd`` (the 2nd, 4th ...): score on the repeats a run was not tuned on.
        targets: the joint targets the tasks carry: ``task`` (None, the default: the task files') or ``published``
            (where a task file corrects the published ones: :data:`simtune.tasks.TARGETS`).
        keep_repeats: keep a repeat far from the others, which the repeat check (:mod:`simtune.data.screen`)
            otherwise leaves out with a warning naming its file.
        loading: how the engine loads the robot: ``description`` (None, the default: as its file says) or
            ``paper`` (as the seed paper loaded it: :data:`simtune.tasks.LOADINGS`; only PyBullet differs).

    Returns:
        A Result: the fitness and its parts per task; ``fitness_unaligned`` the fitness without the clock
        alignment; ``repeat_files`` the repeats scored against.

    Raises:
        ConfigError: an argument of the wrong type or value, named.
    """
    kind = _reference(reference)
    keep = _flag("keep_repeats", keep_repeats)
    selection = _repeats(repeats)
    fitness_weights = _weights(weights)
    proj = _project(project)
    specs = with_loading(
        with_targets(proj.parse_tasks(",".join(_names("tasks", tasks, "single,cube"))), _targets(targets, "targets")),
        "description" if loading is None else check_loading(loading),
    )
    names = _aligned(align_clock, specs)
    given = _params(params)
    if joint_topic is not None and not isinstance(joint_topic, str):
        raise ConfigError(f"joint_topic: expected a topic name (a string), got {joint_topic!r}")
    cls = engine_class(engine)
    robot = common_robot(specs)
    supported = cls.supported(robot)
    if isinstance(given, Path):
        file_values = read_params_file(given, engine, robot)
        values = validate_params(file_values, supported, engine, where=str(given), robot=robot)
    else:
        values = validate_params(dict(given), supported, engine, where="params", robot=robot)
    references = load_references(_root(data, proj), specs, joint_topic, kind, selection, keep)
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
    files = {name: [Path(source).name for source in ref.sources] for name, ref in references.items()}
    return Result.from_score(
        engine,
        values,
        score,
        generic,
        evaluations=evaluations,
        wall_s=wall,
        reference=kind,
        repeats=selection,
        repeat_files=files,
        **more,
    )


def _task_spec(tasks: object) -> str:
    """Tasks as a run stores them: a string as given (the project reads names, groups and commas in it), a list
    of names joined by commas."""
    if isinstance(tasks, str):
        return tasks
    return ",".join(_names("tasks", tasks, "single,cube"))


def run_config(
    engine: str = "mujoco",
    tasks: str | Collection[str] = "cube",
    *,
    project: Project | Path | str | None = None,
    data: Path | str | None = None,
    weights: FitnessWeights | Mapping[str, float] | str | None = None,
    only: str | Collection[str] | None = None,
    **settings: Any,
) -> RunConfig:
    """The configuration ``tune`` runs and stores (``simtune tune``'s options, by RunConfig's names).

    Args:
        engine: the physics engine (``simtune engines``).
        tasks: a task name, several joined by commas, or a list of names.
        project: a Project or its folder; None: the bundled MICO project.  Stored by its project file.
        data: the folder with one sub-folder of recordings per task (stored absolute); None: the project's.
        weights: FitnessWeights, a mapping or ``"joint=0.1,wrist=1"``; None: the defaults.
        only: the parameters to tune (a comma-separated string or a list); None: the whole space.
        settings: any other field of :class:`~simtune.run_plan.RunConfig` by name (space, optimizer, seed,
            workers, max_seconds, max_evaluations, paper_exact, reference, repeats, targets, residuals ...), its
            default where left out or None (calibrated and auto, or shared and de with ``paper_exact``);
            ``validate`` also as a count (``4``) or a list of task names or episode numbers.

    Returns:
        The checked configuration.

    Raises:
        ConfigError: an unknown setting, or a value of the wrong type or range (one line naming it).
    """
    for key in settings:
        if key not in RUN_DEFAULTS or key in ("engine", "tasks", "project", "data", "weights"):
            raise ConfigError(f"unknown run setting {key!r}; the settings are RunConfig's: {', '.join(RUN_DEFAULTS)}")
    given = _given(settings)
    held = given.get("validate")
    if isinstance(held, int) and not isinstance(held, bool):
        given["validate"] = str(held)  # validate=4: the last 4 tasks, as --validate 4
    elif isinstance(held, list | tuple) and all(isinstance(v, str | int) and not isinstance(v, bool) for v in held):
        given["validate"] = ",".join(map(str, held))  # task names or episode numbers
    proj = _project(project)
    config = new_run_config(
        engine,
        _task_spec(tasks),
        given.pop("space", ""),
        data=_root(data, proj),
        project=proj,
        weights=_weights(weights),
        only=None if only is None else _names("only", only, "command_delay"),
        **given,
    )
    config.check()  # a value of the wrong type or range: one line naming it, before anything runs
    return config


def tune(
    engine: str = "mujoco",
    tasks: str | Collection[str] = "cube",
    *,
    out: Path | str,
    show_progress: bool = False,
    **settings,
) -> Result:
    """Tune ``engine`` on ``tasks`` into a new run folder (``simtune tune``).

    The run is an ordinary one: ``simtune resume OUT`` continues it, ``read_run(OUT)`` reads it.

    Args:
        engine: the physics engine.
        tasks: a task name, several joined by commas, or a list.
        out: the new run folder.
        show_progress: draw the progress bar at a terminal.
        settings: :func:`run_config`'s (project, data, weights, only and RunConfig's fields: space, optimizer,
            max_evaluations ...).

    Returns:
        The finished run, read back (:func:`read_run`).
    """
    out_dir = _path("out", out)
    progress = _flag("show_progress", show_progress)
    start_run(run_config(engine, tasks, **settings), out_dir, show_progress=progress)
    return read_run(out_dir)


def start(config: RunConfig, out: Path | str, *, show_progress: bool = False) -> TuneResult:
    """Run a configuration in a new run folder.

    Args:
        config: a RunConfig (see :func:`run_config`).
        out: the new run folder.
        show_progress: draw the progress bar at a terminal.

    Returns:
        The optimiser's TuneResult (what ``simtune tune`` prints).
    """
    if not isinstance(config, RunConfig):
        raise ConfigError(
            f"config: expected a RunConfig (simtune.api.run_config makes one), got {checks.shown(config)}"
        )
    return start_run(config, _path("out", out), show_progress=_flag("show_progress", show_progress))


def resume(run_dir: Path | str, *, rescore: bool = False, show_progress: bool = False) -> TuneResult:
    """Continue a stopped or killed run (``simtune resume``), keeping every finished evaluation.

    Args:
        run_dir: the run folder.
        rescore: start anew on the data as it is now, from the old run's last population.
        show_progress: draw the progress bar at a terminal.

    Returns:
        The optimiser's TuneResult.
    """
    return resume_run(
        _path("run_dir", run_dir),
        show_progress=_flag("show_progress", show_progress),
        rescore=_flag("rescore", rescore),
    )


def uncertainty(run_dir: Path | str, workers: int = 1, bootstrap: int = 0) -> dict:
    """How well the recordings pin each parameter at a finished run's best point (``simtune uncertainty``).

    Args:
        run_dir: a finished run folder.
        workers: processes for the Jacobian's rollouts (threads for the bootstrap's).
        bootstrap: draws of the recordings' repeats to refit the best point against (0: Gauss-Newton alone): intervals
            where the simulation is not smooth, and never narrower than the draws' scatter elsewhere.

    Returns:
        The summary stored in the run: rank, condition number, a 95 % interval per parameter, correlated pairs.
    """
    draws = checks.count("bootstrap", bootstrap, 0, MAX_BOOTSTRAP)
    return run_uncertainty(_path("run_dir", run_dir), _workers(workers), draws)


def _given(settings: Mapping[str, Any]) -> dict[str, Any]:
    """The run settings given: None stands for the default of a setting chosen by name (space, optimizer,
    reference, repeats, targets, residuals: the command line's "not given"); for a count or a switch it is a
    value, refused by the check."""
    return {
        key: value for key, value in settings.items() if value is not None or not isinstance(RUN_DEFAULTS.get(key), str)
    }


def _study_settings(defaults: Mapping[str, Any], settings: Mapping[str, Any]) -> dict[str, Any]:
    """A study's run settings: those given, else the study's declared defaults."""
    return {**defaults, **_given(settings)}


def compare(
    engine: str = "mujoco",
    tasks: str | Collection[str] = "cube",
    *,
    out: Path | str,
    optimizers: str | Collection[str] = "de,cmaes,bo,random",
    seeds: int = 3,
    budget: int = 300,
    target: float | None = None,
    on_run: Callable[[str, int, str], None] | None = None,
    **settings: Any,
) -> dict:
    """Optimisers head to head on ``budget`` evaluations, ``seeds`` runs each (``simtune compare``).

    Args:
        engine: the physics engine.
        tasks: a task name, several joined by commas, or a list.
        out: the folder for the runs (``OUT/<optimizer>/seed-<s>``) and compare.json; finished runs are reused.
        optimizers: the optimisers, comma-separated or a list.
        seeds: runs per optimiser (seeds 0..N-1).
        budget: evaluations each run may use.
        target: a fitness to reach: the evaluations each optimiser needed.
        on_run: called as ``on_run(optimizer, seed, "running" or "resuming")`` before each run not reused.
        settings: :func:`run_config`'s settings (data, space, workers, only, reference ...), the comparison's
            defaults (:data:`~simtune.run_config.COMPARE_DEFAULTS`) where left out; not those each run sets
            itself (optimizer, seed, the budgets).

    Returns:
        The comparison, as OUT/compare.json holds it.
    """
    for key in COMPARE_SETS:
        if key in settings:
            raise ConfigError(f"compare sets {key} for each run itself: leave it out")
    base = run_config(engine, tasks, **_study_settings(COMPARE_DEFAULTS, settings))
    # none named: run_compare says to name at least one
    seeds, budget = checks.count("seeds", seeds), checks.count("budget", budget)
    return run_compare(base, _listed(optimizers), seeds, budget, _path("out", out), target, on_run=on_run)


def transfer(
    engine: str = "mujoco",
    train: str | Collection[str] = "single,cube",
    test: str | Collection[str] = "double",
    *,
    out: Path | str,
    test_data: Path | str | None = None,
    align_clock: bool = True,
    show_progress: bool = False,
    **settings: Any,
) -> dict:
    """Tune on ``train``, then score the tuned and the generic parameters on ``train`` and the unseen ``test``
    tasks (``simtune transfer``).

    Args:
        engine: the physics engine.
        train: the tasks tuned on together (comma-separated or a list).
        test: the unseen tasks the tuned parameters are scored on.
        out: the folder for the tuning run (OUT/run) and transfer.json; run again, it resumes or reuses the run.
        test_data: the data root of the test tasks; None: the tuning run's.
        align_clock: also score each test task with its own recording clock aligned.
        show_progress: draw the tuning run's progress bar.
        settings: :func:`run_config`'s settings for the tuning run, the study's defaults
            (:data:`~simtune.run_config.TRANSFER_DEFAULTS`) where left out.

    Returns:
        The result, as OUT/transfer.json holds it.
    """
    config = run_config(engine, train, **_study_settings(TRANSFER_DEFAULTS, settings))
    test_root = None if test_data is None else _path("test_data", test_data)
    return run_transfer(
        config, _task_spec(test), _path("out", out), test_root, show_progress=show_progress, align_clock=align_clock
    )


def generalise(
    engine: str = "mujoco",
    tasks: str | Collection[str] = "single,cube",
    *,
    out: Path | str,
    show_progress: bool = False,
    on_run: Callable[[int, int, str, Path], None] | None = None,
    **settings: Any,
) -> dict:
    """Tune each of ``tasks`` alone, all together and (three or more) leaving each out, and score every task each
    way against its floor (``simtune generalise``; :mod:`simtune.studies.generalise`).

    Args:
        engine: the physics engine.
        tasks: two tasks or more (comma-separated or a list).
        out: the study's folder: its runs (``alone/<task>``, ``joint``, ``without/<task>``) and generalise.json;
            run again, finished runs are reused and unfinished ones resumed.
        show_progress: draw each run's progress bar.
        on_run: called before each run with its number, the number of runs, its label and its folder.
        settings: :func:`run_config`'s settings for every run (``tune``'s defaults where left out).

    Returns:
        The study, as OUT/generalise.json holds it: per task (``rows``) its floor, its fit alone, joint and held
        out (each ``{"fitness", "wrist", "delay_s"}``), the joint-fit penalty and the held-out ratio.
    """
    if on_run is not None and not callable(on_run):
        raise ConfigError(f"on_run: expected a function or None, got {on_run!r}")
    config = run_config(engine, tasks, **settings)
    return run_generalisation(config, _path("out", out), show_progress=show_progress, on_run=on_run)


def sensitivity(
    engine: str = "mujoco",
    tasks: str | Collection[str] = "cube",
    *,
    out: Path | str,
    data: Path | str | None = None,
    space: str = "extended",
    samples: int = 10,
    method: str = "morris",
    only: str | Collection[str] | None = None,
    seed: int = 0,
    workers: int = 1,
    eval_timeout: float | None = 600.0,
    on_evaluation: Callable[[Score, bool], None] | None = None,
) -> dict:
    """Global sensitivity of the fitness to each parameter (``simtune sensitivity``).

    Args:
        engine: the physics engine.
        tasks: a task name, several joined by commas, or a list.
        out: the folder for sensitivity.sqlite (the evaluations, cached) and the result.
        data: the data root; None: the recordings shipped with simtune.
        space: the parameter space.
        samples: Morris trajectories or Sobol base samples.
        method: ``morris`` or ``sobol`` (SALib).
        only: these parameters of the space alone (comma-separated or a list).
        seed: the sampling seed.
        workers: processes evaluating in parallel.
        eval_timeout: seconds before a worker's evaluation is abandoned; None: never.
        on_evaluation: called as ``on_evaluation(score, reused)`` after each evaluation.

    Returns:
        The result (each parameter's indices), as written into ``out``.
    """
    method, samples = _sampling(method, samples)
    return run_sensitivity(
        engine,
        _task_spec(tasks),
        _study_root(data),
        space,
        _path("out", out),
        samples=samples,
        method=method,
        only=None if only is None else _names("only", only, "command_delay"),
        seed=checks.count("seed", seed, 0, MAX_SEED),
        workers=_workers(workers),
        eval_timeout=None if eval_timeout is None else checks.seconds("eval_timeout", eval_timeout),
        on_evaluation=on_evaluation,
    )


def sensitivity_evaluations(
    engine: str, space: str, method: str, samples: int, only: str | Collection[str] | None = None
) -> int:
    """The evaluations :func:`sensitivity` runs with these arguments (its progress bar's total).

    Args:
        engine: the physics engine.
        space: the parameter space.
        method: ``morris`` or ``sobol``.
        samples: as :func:`sensitivity`'s.
        only: as :func:`sensitivity`'s.

    Returns:
        The number of evaluations.
    """
    names = None if only is None else _names("only", only, "command_delay")
    method, samples = _sampling(method, samples)
    return evaluation_count(method, samples, len(get_space(space, engine_class(engine).supported(), names)))


def demo(out: Path | str = "runs/demo", workers: int = 2, max_seconds: float = 120.0, console=None) -> dict:
    """``simtune demo``: tune MuJoCo to the shipped reference recording and print generic vs tuned.

    Args:
        out: the run folder (started afresh).
        workers: processes evaluating in parallel.
        max_seconds: the wall-time cap [s].
        console: a rich Console to print on; None: standard output.

    Returns:
        The generic and the tuned fitness (``generic``, ``tuned``).
    """
    return run_demo(
        _path("out", out),
        workers=_workers(workers),
        max_seconds=checks.seconds("max_seconds", max_seconds),
        console=console,
    )


def grid_spec(
    engines: str | Collection[str] = "mujoco,pybullet",
    tasks: str | Collection[str] = "single,cube",
    spaces: str | Collection[str] = "shared,individual",
    *,
    repeats: int = 10,
    data: Path | str | None = None,
    max_seconds_per_run: float | None = None,
    max_generations: int = 1000,
    only: str | Collection[str] | None = None,
    keep_inactive: bool = False,
    reference: str | None = None,
    repeat_set: str | None = None,
) -> GridSpec:
    """An experiment grid (``simtune grid``'s options): engines x experiments x spaces x seeds.

    Args:
        engines: engine names, comma-separated or a list.
        tasks: experiments, comma-separated or a list; an experiment joins tasks tuned together with '+'
            (``single+cube``).
        spaces: parameter spaces, comma-separated or a list.
        repeats: seeds per cell (the number of runs).
        data: the data root; None: the recordings shipped with simtune.
        max_seconds_per_run: each run's wall-time cap [s]; None: none.
        max_generations: each run's generation limit.
        only: these parameters of each space alone.
        keep_inactive: keep parameters that change no rollout in the search.
        reference: ``aligned`` or ``mean``; None: aligned.
        repeat_set: which of each task's recorded repeats every run is tuned on (all, even or odd; None: all);
            ``--repeat-set`` on the command line.

    Returns:
        The GridSpec, checked.
    """
    return GridSpec(
        engines=_listed(engines, "engines"),
        tasks=_listed(tasks, "tasks"),
        spaces=_listed(spaces, "spaces"),
        repeats=checks.count("repeats", repeats),
        data=str(_study_root(data)),
        max_seconds_per_run=None
        if max_seconds_per_run is None
        else checks.seconds("max_seconds_per_run", max_seconds_per_run),
        max_generations=checks.count("max_generations", max_generations),
        only=None if only is None else _names("only", only, "command_delay"),
        keep_inactive=_flag("keep_inactive", keep_inactive),
        reference=_reference(reference),
        repeat_set=_repeats(repeat_set),
    )


def grid(spec: GridSpec, out: Path | str, **execution) -> GridIndex:
    """Run every unfinished optimisation of a grid in its folder (``simtune grid``).

    Args:
        spec: the grid (:func:`grid_spec`).
        out: the grid folder.
        execution: :func:`simtune.grid.run_grid`'s executor, workers, scheduler, index_url and on_event.

    Returns:
        The grid's index.
    """
    return run_grid(_grid_spec(spec), _path("out", out), **execution)


def plan_grid(spec: GridSpec) -> list[dict]:
    """Size and estimated cost of a grid (``simtune grid --plan``).

    Args:
        spec: the grid (:func:`grid_spec`).

    Returns:
        One row per engine x experiment x space.
    """
    return _plan_grid(_grid_spec(spec))


def _grid_spec(spec: object) -> GridSpec:
    if not isinstance(spec, GridSpec):
        raise ConfigError(f"spec: expected a GridSpec (simtune.api.grid_spec makes one), got {checks.shown(spec)}")
    return spec


def check(
    engine: str = "mujoco",
    tasks: str | Collection[str] = "cube",
    *,
    project: Project | Path | str | None = None,
    data: Path | str | None = None,
    space: str = "extended",
    workers: int = 1,
    reference: str | None = None,
    repeats: str | None = None,
    write_task: Path | str | None = None,
    keep_repeats: bool = False,
    targets: str | None = None,
    only: str | Collection[str] | None = None,
    params: Mapping[str, float] | Path | str | None = None,
) -> dict:
    """Before tuning (``simtune check --task``): the recordings' quality and what they can inform.

    Per task: the recordings' quality (the repeats' clock shifts and the floor: their spread with and without
    alignment), the rest pose after each phase against where its targets put the arm (with proposed targets for a
    rest that lies far off), and which active parameters the recordings can inform (the Jacobian at the generic
    point).

    Args:
        engine: the physics engine.
        tasks: a task name, several joined by commas, or a list.
        project: a Project or its folder; None: the bundled MICO project.
        data: the data root; None: the project's.
        space: the parameter space whose identifiability is checked.
        workers: processes for the Jacobian's rollouts.
        reference: ``aligned`` (None, the default) or ``mean``.
        repeats: ``all`` (None, the default), ``even`` or ``odd``; the result names the files used.
        write_task: a new file to write the one checked task's file to, each phase whose rest lies far off given
            its proposed targets (the former kept as ``published_targets_deg``, the evidence in a comment).
        keep_repeats: keep a repeat far from the others (else left out with a warning, named in each task's
            ``repeat_check_left_out``).
        targets: the tasks' targets checked (:data:`simtune.tasks.TARGETS`; None: the task files' own).
        only: the parameters of ``space`` whose identifiability is checked (comma-separated or a list); None: all.
        params: the point the Jacobian is taken at: values (a mapping, or a params file such as a run's
            best_params.json or a synth's truth.json) in place of the generic ones; None: the generic point.

    Returns:
        The check's findings as ``simtune check --json`` prints them (``identifiability``: the combinations of
        parameters the recordings cannot tell apart and the motion that would, docs/tuning.md); ``written_task``
        names the file written (None where no rest lies far off, or none that targets place: nothing is written)
        and ``written_task_notes`` says where a comment of a corrected phase names a value it replaced.
    """
    kind = _reference(reference)
    selection = _repeats(repeats)
    proj = _project(project)
    root = _root(data, proj)  # None: each task's own recordings folder (its task file's, else the project's)
    specs = with_targets(proj.parse_tasks(_task_spec(tasks)), _targets(targets, "targets"))
    if write_task is not None and len(specs) != 1:
        raise ConfigError(f"--write-task writes one task's file: check one task, not {len(specs)}")
    out = None if write_task is None else _path("write_task", write_task)
    if out is not None:  # refused before the check (seconds to minutes), never after it
        from simtune.tasks.correct import check_task_out

        source = proj.task_files.get(specs[0].name)
        if source is None:
            raise SimtuneError(f"--write-task: task {specs[0].name!r} has no task file to correct")
        check_task_out(source, out)
    keep = _flag("keep_repeats", keep_repeats)
    names = None if only is None else _names("only", only, "armature_joint_6,servo_gain_joint_6")
    given = _params(params)
    robot = common_robot(specs)
    if isinstance(given, Path):
        at_name = str(given)
        file_values = read_params_file(given, engine, robot)
        values = validate_params(
            file_values, engine_class(engine).supported(robot), engine, where=str(given), robot=robot
        )
    else:
        at_name = "generic" if not given else "params"
        values = validate_params(
            dict(given), engine_class(engine).supported(robot), engine, where="params", robot=robot
        )
    result = run_check(
        engine,
        specs,
        root,
        space,
        _workers(workers),
        reference=kind,
        repeats=selection,
        keep_repeats=keep,
        only=names,
        at=values,
        at_name=at_name,
    )
    result["targets"] = _targets(targets, "targets")
    if out is not None:
        result["written_task_notes"] = []
        result["written_task"] = _write_corrected_task(
            proj, specs[0], result["data_quality"][0], out, result["written_task_notes"]
        )
    return result


def _evidence(row: dict, proposal: dict) -> str:
    """The comment above a corrected phase's targets: how far its recorded rest lay and what the proposal leaves,
    in mm and (where the check fitted the orientation) deg."""
    turned, offset = proposal.get("orientation_before_deg"), proposal.get("marker_offset_m")
    before = f"{1000 * row['distance_m']:.1f} mm" + ("" if turned is None else f" and {turned:.1f} deg")
    after = f"{1000 * proposal['residual_after_m']:.1f} mm" + (
        "" if turned is None else f" and {proposal['orientation_after_deg']:.1f} deg"
    )
    point = "" if offset is None else f", the marker at {'/'.join(f'{1000 * v:.0f}' for v in offset)} mm in the link"
    return (
        f"simtune check ({date.today().isoformat()}): the recorded rest after {row['stretch']} lies {before} from "
        f"where the former targets put the wrist;\n{moved_joints(proposal)} leaves {after} (inverse kinematics of "
        f"the wrist's {proposal.get('fit', 'position only')}{point})"
    )


def _write_corrected_task(proj: Project, task, quality: dict, out: Path, notes: list[str]) -> str | None:
    """Write ``task``'s file corrected by the check's proposals (``quality``: its data-quality part) to ``out``;
    ``notes`` gets a line per phase whose comments name a value the correction replaced.  A far rest that no
    targets place (``out_of_reach``) has no proposal and is not written."""
    from simtune.tasks.correct import Correction, write_corrected_task

    corrections, previous = {}, {}
    for row in quality["rest_poses"]:
        proposal = row.get("proposal")
        if proposal is None or row.get("phase") is None:
            continue  # a rest that is not far, or the start pose (not a phase's targets)
        corrections[row["phase"]] = Correction(tuple(proposal["targets_deg"]), _evidence(row, proposal))
        previous[row["phase"]] = tuple(row["targets_deg"])
    if not corrections:
        return None
    return str(write_corrected_task(proj.task_files[task.name], out, corrections, previous, notes))


def synth(
    engine: str = "mujoco",
    tasks: str | Collection[str] = "cube",
    *,
    out: Path | str,
    truth: Path | str | None = None,
    delay_s: float | None = None,
    project: Project | Path | str | None = None,
    noise_m: float = 0.002,
    repeats: int = 10,
    seed: int = 0,
    jitter_s: float = 0.05,
    fmt: str = "tsv",
    joint_noise_rad: float = math.radians(DEFAULT_JOINT_NOISE_DEG),
    force: bool = False,
    episodes: int | None = None,
) -> SynthResult:
    """Recordings with a known ground truth (``simtune synth``).

    Args:
        engine: the engine that simulates them.
        tasks: a task name, several joined by commas, or a list.
        out: the data root to write (``OUT/<task>/``).
        truth: a params file of the true values; None: the engine's generic values.
        delay_s: the true command delay [s]; None: the truth's.
        project: a Project or its folder; None: the bundled MICO project.
        noise_m: the motion-capture noise [m]: Gaussian, per axis, on every sample of the wrist marker (a quarter
            of it on base and object).
        repeats: recordings per task, 1 to :data:`~simtune.common.limits.MAX_SYNTH_REPEATS`.
        seed: of the noise (same seed, same files), 0 to 2^32 - 1.
        jitter_s: each repeat's start moves by a uniform jitter within +- this [s].
        fmt: what each recording holds: a key of :data:`simtune.data.formats.WRITERS` (``tsv``: Qualisys 6D).
        joint_noise_rad: the encoder noise of joint logs [rad] per sample.
        force: replace the truth files of an earlier synth into ``out`` that holds another truth.
        episodes: with a dataset ``fmt``, this many different episodes per task (each its own seeded command
            stream, one clock: no jitter) instead of ``repeats``; None: repeats.

    Returns:
        The SynthResult: the data root, the truth and the recordings written per task.

    Raises:
        ConfigError: an argument of the wrong type or value, named (before anything is simulated).
    """
    from simtune.data.formats import WRITERS

    if not isinstance(fmt, str) or fmt not in WRITERS:
        raise ConfigError(f"fmt: unknown format {checks.shown(fmt)} (known: {', '.join(WRITERS)})")
    recording = {
        "noise_m": checks.number("noise_m", noise_m),
        "repeats": checks.count("repeats", repeats, 1, MAX_SYNTH_REPEATS),
        "seed": checks.count("seed", seed, 0, MAX_SEED),
        "jitter_s": checks.number("jitter_s", jitter_s),
        "fmt": fmt,
        "joint_noise_rad": checks.number("joint_noise_rad", joint_noise_rad),
        "force": _flag("force", force),
        "episodes": None if episodes is None else checks.count("episodes", episodes, 1, MAX_SYNTH_REPEATS),
    }
    return run_synth(
        engine,
        _task_spec(tasks),
        _path("out", out),
        truth_file=None if truth is None else _path("truth", truth),
        delay_s=delay_s,
        project=_project(project),
        names=API_NAMES,
        **recording,
    )


def export(
    run_dirs: Path | str | Collection[Path | str],
    out: Path | str,
    *,
    engine: str | None = None,
    all_engines: bool = False,
    dr: bool = False,
    force: bool = False,
) -> tuple[list[ExportResult], list[tuple[Path, str]]]:
    """Tuned runs as each engine's own model files (``simtune export``).

    Args:
        run_dirs: a finished run folder, or with ``all_engines`` folders holding runs.
        out: the export folder.
        engine: export as this engine's files; None: the run's own engine.
        all_engines: export every finished run under ``run_dirs``, each as its own engine's.
        dr: also write ``dr_ranges.yaml`` (domain-randomisation ranges of the tuned parameters).
        force: replace a previous export in a non-empty ``out``.

    Returns:
        The exports, and the folders skipped with the reason.
    """
    runs = _paths("run_dirs", run_dirs, "a run folder")
    out_dir = _path("out", out)
    if engine is not None and not isinstance(engine, str):
        raise ConfigError(f"engine: expected an engine name (a string) or None, got {checks.shown(engine)}")
    all_engines, dr, force = _flag("all_engines", all_engines), _flag("dr", dr), _flag("force", force)
    if all_engines and engine is not None:
        raise SimtuneError("--all-engines exports each run with its own engine: leave out --engine")
    if all_engines:
        return export_runs(runs, out_dir, dr=dr, force=force)
    if len(runs) != 1:
        raise SimtuneError(f"give one run folder (got {len(runs)}), or --all-engines for several")
    return [export_run(runs[0], out_dir, engine=engine, dr=dr, force=force)], []


def report(
    runs: Path | str | Collection[Path | str],
    out: Path | str,
    published_sims: Path | str | None = None,
    *,
    show_progress: bool = False,
    figure4_parameter: str = "timestep",
    project: Path | str | None = None,
    reference: str | None = None,
    repeats: str | None = None,
) -> Path:
    """Write the HTML report of tuning runs (``simtune report``; docs/report.md).

    Args:
        runs: run folders, or folders holding run folders at any depth (a grid); every run.sqlite below them is read.
        out: the report folder: new, empty, or one an earlier report wrote (only its files are replaced).
        published_sims: a folder of published simulations ``<task>_<Engine>.csv``, scored next to the engines'
            generic fitness; None: none.
        show_progress: draw a progress bar at a terminal.
        figure4_parameter: the parameter whose tuned values the paper's Figure 4 shows.
        project: read the runs' tasks from this project folder; None: the one each run names.
        reference: re-score every run against ``aligned`` or ``mean``; None: each run against its own.
        repeats: re-score against ``all``, ``even`` or ``odd`` repeats; None: each run's own.

    Returns:
        The report's ``index.html``.
    """
    from simtune.report import make_report

    paths = [Path(runs)] if isinstance(runs, str | os.PathLike) else [Path(run) for run in runs]
    return make_report(
        paths,
        Path(out),
        None if published_sims is None else Path(published_sims),
        show_progress=show_progress,
        figure4_parameter=figure4_parameter,
        project=project,
        reference=reference,
        repeats=repeats,
    )


#: an example of each list :func:`_listed` reads, for its error
_LIST_EXAMPLES = {"optimizers": "de,cmaes", "engines": "mujoco,pybullet", "tasks": "single,cube", "spaces": "shared"}


def _listed(value: str | Collection[str], name: str = "optimizers") -> list[str]:
    """Names given comma-separated or as a list (blank ones dropped); anything else a ConfigError naming ``name``."""
    return _names(name, value, _LIST_EXAMPLES.get(name, "a,b"))


def read_run(run_dir: Path | str) -> Result:
    """The best parameters of the run in ``run_dir`` (finished or not) as a :class:`Result`.

    Args:
        run_dir: a run folder (``simtune tune --out``).

    Returns:
        The run's best evaluation: its parameters, fitness and parts, the generic fitness, the evaluations and wall
        time of all its sessions, the reference it was scored against and why its search stopped.
    """
    run_dir = _path("run_dir", run_dir)
    record = read_run_record(run_dir)
    config = record.settings
    return Result.from_score(
        record.engine,
        record.best_params,
        Score.from_dict(record.best_evaluation["score"]),
        record.generic_score,
        evaluations=record.evaluations,
        run_dir=run_dir,
        message=str(record.message if record.message is not None else (record.status or "")),
        wall_s=record.elapsed_s,
        reference=config.reference,
        repeats=config.repeats,
        stop_reason=record.stop_reason,
        validation=record.validation,
    )


def design(
    engine: str = "mujoco",
    *,
    out: Path | str,
    project: Path | str | Project | None = None,
    task: str | Collection[str] | None = None,
    space: str = DEFAULT_SPACE,
    only: str | Collection[str] | None = None,
    duration: float = 30.0,
    signals: str | Collection[str] = "marker,joints",
    repeats: int = 10,
    workers: int = 1,
    seed: int = 0,
    name: str | None = None,
    on_progress: Callable[[str, int, int], None] | None = None,
) -> dict:
    """``simtune design``: the motion a lab should record so that its recordings identify the parameters.

    Writes the designed task file at ``out`` (TOML), and beside it the same schedule as a CSV of targets at the
    controller's rate (``<stem>.csv``), as a ROS 2 ``JointTrajectory`` in YAML (``<stem>.trajectory.yaml``) and
    what the design found (``<stem>.design.json``: each parameter's predicted 95 % interval width on the design and
    on the project's current tasks, the combinations still not told apart, the checks in simulation).

    Args:
        engine: the physics engine the parameters are the ones of.
        out: the task file to write (``.toml``).
        project: a project folder or :class:`Project`; None: the bundled MICO project.
        task: the project's task(s) (comma-separated or a list) the design is set beside; the first one's robot,
            start pose, gain and tracked marker the design keeps (default: the project's first task).
        space: the parameter space designed for.
        only: these parameters of the space alone (comma-separated or a list).
        duration: the designed task's length [s].
        signals: what the lab records: ``marker`` (the tracked link's marker), ``joints`` (the joint angles), or
            both joined by a comma.
        repeats: how many repeats the lab records (their mean's noise narrows the intervals).
        workers: threads (MuJoCo) or processes for the Jacobians' rollouts.
        seed: seed of the library's every-joint excursions.
        name: the designed task's name (default: the file's stem).
        on_progress: called with (what, done, total) as the design goes on.

    Returns:
        The design's summary (``<stem>.design.json``'s content), with ``files``: the paths written.
    """
    import json

    from simtune.design import DEFAULT_NOISE, SIGNALS, design_experiment
    from simtune.tasks.files import load_task_file

    engine_class(engine)  # an unknown engine is one line before any work
    target = _path("out", out)
    if target.suffix != ".toml":
        raise ConfigError(f"out: {target}: the designed task is written as a TOML task file (name it *.toml)")
    chosen = _project(project)
    names = chosen.task_names()[:1] if task is None else _names("task", task, "reach")
    if not names:
        raise ConfigError(f"project {chosen.root}: has no task to take the robot's start pose and gain from")
    tasks = [chosen.task(n) for n in names]
    template = tasks[0]
    recorded = tuple(_names("signals", signals, "marker,joints"))
    unknown = [s for s in recorded if s not in SIGNALS]
    if unknown:
        raise ConfigError(f"signals: unknown signal {unknown[0]!r} (known: {', '.join(SIGNALS)})")
    duration = checks.positive("duration", duration, " seconds")
    noise = replace(DEFAULT_NOISE, signals=recorded, repeats=checks.count("repeats", repeats, 1, 1000))
    result = design_experiment(
        engine,
        template,
        tasks,
        duration=duration,
        name=name or target.stem,
        space_name=space,
        only=None if only is None else _names("only", only, "command_delay"),
        noise=noise,
        workers=_workers(workers),
        seed=checks.count("seed", seed, 0, MAX_SEED),
        progress=on_progress,
    )
    stem = target.with_suffix("")
    files = {
        "task": target,
        "csv": stem.with_name(stem.name + ".csv"),
        "trajectory": stem.with_name(stem.name + ".trajectory.yaml"),
        "summary": stem.with_name(stem.name + ".design.json"),
    }
    target.parent.mkdir(parents=True, exist_ok=True)
    files["task"].write_text(result.toml)
    files["csv"].write_text(result.csv)
    files["trajectory"].write_text(result.yaml)
    summary = {**result.summary, "files": {k: str(v) for k, v in files.items()}}
    files["summary"].write_text(json.dumps(summary, indent=1, default=float) + "\n")
    load_task_file(target, chosen.robot, chosen.root)  # the file written reads back as a task of the project
    return summary


__all__ = [
    "Project",
    "Result",
    "check",
    "check_project",
    "compare",
    "demo",
    "design",
    "evaluate",
    "export",
    "generalise",
    "grid",
    "grid_spec",
    "init_project",
    "load_project",
    "plan_grid",
    "read_run",
    "resume",
    "run_config",
    "sensitivity",
    "sensitivity_evaluations",
    "start",
    "synth",
    "transfer",
    "tune",
    "uncertainty",
]
