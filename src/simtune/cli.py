"""The ``simtune`` command line.

Every command explains itself with ``--help``.  Errors in the user's input
print one line (``error: ...``) and exit with status 2; warnings about data
that was still usable print ``warning: ...`` and the command goes on.
"""

from __future__ import annotations

import functools
import json
import math
import os
import sys
import time
import warnings
from pathlib import Path
from typing import Annotated

import typer
from rich.console import Console
from rich.markup import escape
from rich.table import Table

from simtune.console import text_table
from simtune.errors import SimtuneError
from simtune.report.command import report

app = typer.Typer(
    help="Tune physics-engine parameters until a simulated robot reproduces its motion-capture recordings.\n\n"
    "Start with `simtune demo`; then `simtune evaluate` and `simtune tune` on your own recordings "
    "(--data ROOT, one sub-folder of recordings per task, e.g. ROOT/cube/*.tsv).",
    no_args_is_help=True,
    add_completion=False,
    pretty_exceptions_enable=False,
    # help texts carry units in brackets ([s], [mm]) and extras ('simtune[opt]'): Markdown keeps them
    rich_markup_mode="markdown",
)
err = Console(stderr=True)
out = Console()

# --- values checked where they enter: one line naming the option, exit status 2, nothing written yet ---------
#: seeds fit every random generator simtune seeds (NumPy's legacy seeding takes 32 bits)
MAX_SEED = 2**32 - 1
#: the longest file or folder name common file systems allow [bytes]
NAME_MAX = 255
PATH_MAX = 4095


def _seconds(value: float | None) -> float | None:
    """A duration [s]: finite and above zero."""
    if value is not None and not (math.isfinite(value) and value > 0):
        raise typer.BadParameter(f"{value:g} is not a number of seconds above 0")
    return value


def _not_negative(value: float | None) -> float | None:
    """A finite number, zero or more."""
    if value is not None and not (math.isfinite(value) and value >= 0):
        raise typer.BadParameter(f"{value:g} is not a finite number of 0 or more")
    return value


def _finite(value: float | None) -> float | None:
    if value is not None and not math.isfinite(value):
        raise typer.BadParameter(f"{value:g} is not a finite number")
    return value


def _path(value: Path | None) -> Path | None:
    """A path every file system can hold: no name in it over 255 bytes."""
    if value is None:
        return value
    for part in value.parts:
        size = len(os.fsencode(part))
        if size > NAME_MAX:
            raise typer.BadParameter(
                f"the name {part[:24]}... is {size} bytes long; file systems allow {NAME_MAX} bytes per name"
            )
    if len(os.fsencode(str(value))) > PATH_MAX:
        raise typer.BadParameter(f"the path is longer than {PATH_MAX} bytes")
    return value


SeedOpt = Annotated[int, typer.Option(min=0, max=MAX_SEED, help="Random seed of the optimiser (same seed, same run).")]

EngineOpt = Annotated[str, typer.Option("--engine", "-e", help="Physics engine: see `simtune engines`.")]
TaskOpt = Annotated[
    str,
    typer.Option(
        "--task", "-t", help="Task name, or several joined by commas (their fitness is summed); see `simtune tasks`."
    ),
]
DataOpt = Annotated[
    Path | None,
    typer.Option(
        "--data",
        "-d",
        help="Folder with one sub-folder of recordings per task (`ROOT/<task>/*.tsv`, `*.csv`, `*.c3d`; joint logs "
        "also `*.mcap` or rosbag2 folders). "
        "Default: the reference recordings shipped with simtune.",
        callback=_path,
    ),
]
ProjectOpt = Annotated[
    Path | None,
    typer.Option(
        "--project",
        help="Project folder: simtune.toml, the robot and its task files (docs/task-files.md). "
        "Default: the bundled Kinova MICO project.",
        callback=_path,
    ),
]
JsonOpt = Annotated[bool, typer.Option("--json", help="Print one JSON object instead of a table.")]
WeightsOpt = Annotated[
    str | None,
    typer.Option(
        "--weights",
        help="Weights of the fitness's parts, e.g. joint=0.1,wrist=1,object=1 (keys left out keep their "
        "defaults: wrist 1, object 1, joint 0.5 m/rad); a part the recordings lack counts nothing.",
    ),
]
JointTopicOpt = Annotated[
    str | None,
    typer.Option(
        "--joint-topic",
        help="ROS 2 joint logs: the sensor_msgs/msg/JointState topic to read (default: each log's only one).",
    ),
]
SpaceOpt = Annotated[
    str,
    typer.Option(
        "--space",
        "-s",
        help="Parameter space: shared (31, the paper's), "
        "individual (57, the paper's), extended (individual + command delay "
        "and marker offset) or calibrated (extended + encoder offsets and joint compliance); "
        "an engine's lacks what it cannot map.",
    ),
]
KeepInactiveOpt = Annotated[
    bool,
    typer.Option(
        "--keep-inactive",
        help="Keep parameters that change no rollout of the tasks (measured before the search, see "
        "`simtune params --task T`) in the search: the paper's full D. --paper-exact implies it.",
    ),
]
OnlyOpt = Annotated[
    str | None,
    typer.Option(help="Only these parameters of the space (comma-separated); the rest keep their generic values."),
]
WorkersOpt = Annotated[int, typer.Option("--workers", "-w", min=1, help="Processes evaluating in parallel.")]
#: what each optimiser is, said once for every command's --optimizer
OPTIMIZER_HELP = (
    "auto: a least-squares opening from the generic point with each task's clock aligned to its recordings, then "
    "rounds of a short DE and least squares on the residuals (see the README's Speed); de: differential evolution "
    "as in the paper; cmaes: CMA-ES with restarts; bo: Bayesian optimisation (Optuna TPE, batches of --workers "
    "trials); random: uniform random search. cmaes and bo need `pip install 'simtune[opt]'`."
)
OptimizerOpt = Annotated[str, typer.Option("--optimizer", help=OPTIMIZER_HELP)]
MaxEvalsOpt = Annotated[
    int | None,
    typer.Option(
        "--max-evaluations",
        min=1,
        help="Stop once this many evaluations were used (checked after each batch; DE finishes its generation).",
    ),
]
EvalTimeoutOpt = Annotated[
    float,
    typer.Option(
        help="With --workers 2+: an evaluation still running after this "
        "many seconds (while simtune runs: a paused or sleeping machine does not count) is abandoned, stored as "
        "failed, its worker replaced; `simtune resume` retries it once.",
        callback=_seconds,
    ),
]


def _data_root(data: Path | None) -> Path:
    """--data made absolute (a run stores it: resume, uncertainty and export read it from any folder), else the
    shipped reference recordings."""
    from simtune.reference import REFERENCE_DIR

    return Path(os.path.abspath(data)) if data is not None else REFERENCE_DIR


def _project_data(data: Path | None, project: Path | None) -> Path | None:
    """--data, else the project's data root (None: each task's own recordings folder; see Project.data_root)."""
    from simtune.project import load_project

    if data is not None or project is None:
        return _data_root(data)
    return load_project(project).data_root()


def _run_data(data: Path | None, project: Path | None) -> str | None:
    root = _project_data(data, project)
    return None if root is None else str(root)


def _run_project(project: Path | None) -> str | None:
    """The project as a run stores it: its project file, absolute (resume and report work from any folder)."""
    from simtune.project import find_project_file

    return None if project is None else str(find_project_file(project).resolve())


def _show_warning(message, category, filename, lineno, file=None, line=None) -> None:
    err.print(f"[yellow]warning:[/] {message}", highlight=False, soft_wrap=True)


def _fmt(value: float | None) -> str:
    return "-" if value is None else f"{value:.4f}"


@app.command()
def evaluate(
    engine: EngineOpt = "mujoco",
    task: TaskOpt = "cube",
    data: DataOpt = None,
    params_file: Annotated[
        Path | None,
        typer.Option(
            "--params-file",
            "-p",
            help="JSON of parameter values (e.g. a run's best_params.json); default: the engine's generic values.",
            callback=_path,
        ),
    ] = None,
    weights: WeightsOpt = None,
    joint_topic: JointTopicOpt = None,
    project: ProjectOpt = None,
    align_clock: Annotated[
        bool | None,
        typer.Option(
            "--align-clock/--no-align-clock",
            help="Align each task's recording clock first: its command delay estimated from its recordings "
            "(motion onset, then a 1-D search over the delay with the physics held fixed). Default: the tasks "
            "a run's --params-file was not tuned on (its 'tasks' field), which carry another recording's delay.",
            show_default=False,
        ),
    ] = None,
    as_json: JsonOpt = False,
) -> None:
    """Fitness of an engine's generic parameters (or of --params-file) on recorded tasks."""
    from simtune import api

    score = api.evaluate(
        engine,
        task,
        project=project,
        data=_project_data(data, project),
        params=params_file,
        weights=weights,
        joint_topic=joint_topic,
        align_clock=_tasks_to_align(align_clock, params_file, task, project),
    )
    estimates = score.alignments
    result = {
        "engine": engine,
        "task": task,
        "space": None,
        "fitness": score.fitness,
        "wrist_error": score.wrist_error,
        "object_error": score.object_error,
        "joint_error": score.joint_error,
        "generic_fitness": score.generic_fitness,
        "stable": score.stable,
        "wall_s": score.wall_s,
        "tasks": [t.__dict__ for t in score.parts.values()],
        "fitness_unaligned": score.fitness if score.fitness_unaligned is None else score.fitness_unaligned,
        "clock_aligned": score.clock_aligned,
    }
    if as_json:
        print(json.dumps(result))
        return
    # the joint column only where joint logs were scored: motion-capture tables stay as they were
    joint_col = score.joint_error is not None
    table = text_table(
        f"{engine} on {task}" + (f" with {params_file}" if params_file else " (generic parameters)"),
        (
            "task",
            "fitness",
            "wrist error [m]",
            "object error [m]",
            *(["joint error [rad]"] if joint_col else []),
            "note",
        ),
    )
    parts: list = list(score.parts.values())
    rows = [(t.task, t) for t in parts] + ([("all", score)] if len(parts) > 1 else [])
    for name, part in rows:
        joint = [_fmt(part.joint_error)] if joint_col else []
        table.add_row(name, _fmt(part.fitness), _fmt(part.wrist_error), _fmt(part.object_error), *joint, part.message)
    out.print(table)
    if score.x:
        out.print(f"generic fitness: {score.generic_fitness:.4f}")
    for e in estimates:
        out.print(
            f"clock aligned: {e.task}'s command delay {e.delay_s:.2f} s, estimated from its recordings (motion onset "
            f"{_fmt_g(e.recorded_onset_s)} s) with the physics held fixed; without alignment the fitness is "
            f"{score.fitness_unaligned:.4f} (--no-align-clock)"
        )


def _tasks_to_align(align_clock: bool | None, params_file: Path | None, task: str, project: Path | None) -> list[str]:
    """The tasks whose clocks evaluate aligns: all (--align-clock), none (--no-align-clock), or by default those a
    run's parameter file was not tuned on (its 'tasks' field) and does not time with its own delay."""
    from simtune.params import read_params_file
    from simtune.project import get_project

    names = [t.name for t in get_project(project).parse_tasks(task)]
    if align_clock is not None:
        return names if align_clock else []
    if params_file is None:
        return []
    try:
        tuned_on = json.loads(params_file.read_text(encoding="utf-8-sig")).get("tasks")
    except (OSError, ValueError, AttributeError):
        tuned_on = None
    if not isinstance(tuned_on, str):
        return []
    try:
        seen = {t.name for t in get_project(project).parse_tasks(tuned_on)}
        params = read_params_file(params_file)
    except SimtuneError:
        return []
    return [name for name in names if name not in seen and f"command_delay_{name}" not in params]


def _report_tune(result, run_dir: Path, config, store, as_json: bool) -> None:
    from simtune.runs import BEST_PARAMS_FILE

    store_generic = store.get("generic")
    searched, inactive = store.get("parameters"), store.get("inactive_parameters") or {}

    payload = {
        "engine": config.engine,
        "task": config.tasks,
        "space": config.space,
        "optimizer": config.optimizer,
        "fitness": result.score.fitness,
        "wrist_error": result.score.wrist_error,
        "object_error": result.score.object_error,
        "joint_error": result.score.joint_error,
        "generic_fitness": store_generic["fitness"],
        "evaluations": result.evaluations,
        "generations": result.generations,
        "wall_s": result.wall_s,
        "best_params_file": str(run_dir / BEST_PARAMS_FILE),
        "message": result.message,
        "search_dimension": len(searched),
        "inactive_parameters": inactive,
    }
    if as_json:
        print(json.dumps(payload))
        return
    out.print(
        f"[bold]{config.engine}[/] on [bold]{config.tasks}[/], space {config.space}, optimizer "
        f"{config.optimizer}{' + least squares' if config.refine else ''}: "
        f"fitness {store_generic['fitness']:.4f} (generic) -> [bold green]{result.score.fitness:.4f}[/] (tuned)"
    )
    joint = "" if result.score.joint_error is None else f", joint error {_fmt(result.score.joint_error)} rad"
    out.print(
        f"  wrist error {_fmt(result.score.wrist_error)} m, object error {_fmt(result.score.object_error)} m{joint}; "
        f"{result.evaluations} evaluations, {result.generations} generations, {result.wall_s:.0f} s "
        f"({result.message})"
    )
    out.print(f"  best parameters: {payload['best_params_file']}")
    summary = store.get("uncertainty")
    if summary:
        _print_uncertainty(summary, short=True, run_dir=run_dir)
    if inactive:
        kept = "kept in the search (--keep-inactive)" if set(inactive) & set(searched) else "left out of the search"
        out.print(
            f"  search dimension D = {len(searched)}; {len(inactive)} parameters change no rollout of "
            f"{config.tasks} and were {kept} (`simtune params --task {config.tasks}` says why)"
        )


@app.command()
def tune(
    engine: EngineOpt = "mujoco",
    task: TaskOpt = "cube",
    data: DataOpt = None,
    space: SpaceOpt = "extended",
    optimizer: Annotated[
        str | None,
        typer.Option(
            "--optimizer",
            help=f"Default auto (de with --paper-exact). {OPTIMIZER_HELP}",
            show_default=False,
        ),
    ] = None,
    refine: Annotated[
        bool,
        typer.Option(
            "--refine",
            help="Afterwards, polish the best point with bounded least "
            "squares (SciPy) on the per-sample residuals; its evaluations are stored "
            "too.",
        ),
    ] = False,
    seed: SeedOpt = 0,
    workers: WorkersOpt = 1,
    threads: Annotated[
        bool,
        typer.Option(
            "--threads",
            help="Evaluate on --workers threads of this process instead of worker processes (MuJoCo; the same "
            "results; no --eval-timeout and no crash isolation).  On 2 cores processes are faster: "
            "benchmarks/batch_threads.py.",
        ),
    ] = False,
    max_seconds: Annotated[
        float | None, typer.Option(help="Stop after this much wall time [s].", callback=_seconds)
    ] = None,
    max_generations: Annotated[
        int,
        typer.Option(
            min=1,
            help="Stop after this many generations (bo and random: D evaluations count as one; auto: each batch, a DE "
            "generation, a least-squares trial point or a Jacobian).",
        ),
    ] = 1000,
    max_evaluations: MaxEvalsOpt = None,
    target_fitness: Annotated[
        float | None, typer.Option(help="Stop once the best fitness reaches this.", callback=_not_negative)
    ] = None,
    no_prune: Annotated[
        bool,
        typer.Option(
            "--no-prune",
            help="Simulate every trial to the end (by default a "
            "DE trial that can no longer beat its parent stops early: same search, "
            "its stored fitness a lower bound).",
        ),
    ] = False,
    only: OnlyOpt = None,
    keep_inactive: KeepInactiveOpt = False,
    eval_timeout: EvalTimeoutOpt = 600.0,
    paper_exact: Annotated[
        bool,
        typer.Option(
            "--paper-exact",
            help="Differential evolution exactly as the paper ran SciPy: immediate updating, SciPy's polish, "
            "one worker, no pruning, the paper's whole parameter list (--space shared or individual; "
            "parameters the engine lacks are kept, without effect).",
        ),
    ] = False,
    out_dir: Annotated[
        Path,
        typer.Option(
            "--out",
            "-o",
            help="Run folder to create (store, best_params.json): a new or empty folder, held by this run alone.",
            callback=_path,
        ),
    ] = Path("runs/latest"),
    weights: WeightsOpt = None,
    joint_topic: JointTopicOpt = None,
    project: ProjectOpt = None,
    quiet: Annotated[bool, typer.Option("--quiet", "-q", help="No progress bar.")] = False,
    as_json: JsonOpt = False,
) -> None:
    """Tune an engine's parameters to recorded tasks (global then local by default; --optimizer de: the paper's DE).

    Every evaluation is stored in OUT/run.sqlite as it finishes; if the run is
    killed, `simtune resume OUT` continues it without redoing any evaluation
    (every optimiser replays its search from its seed).

    Example: simtune tune --engine mujoco --task cube --data DATA --optimizer cmaes --refine --max-evaluations 2000
    """
    from simtune.fitness import FitnessWeights
    from simtune.runs import RunConfig, start_run
    from simtune.store import RunStore

    config = RunConfig(
        engine=engine,
        tasks=task,
        space=space,
        data=_run_data(data, project),
        seed=seed,
        workers=workers,
        max_seconds=max_seconds,
        max_generations=max_generations,
        only=_only(only),
        eval_timeout=eval_timeout,
        target_fitness=target_fitness,
        prune=not no_prune,
        optimizer=optimizer or ("de" if paper_exact else "auto"),
        refine=refine,
        max_evaluations=max_evaluations,
        paper_exact=paper_exact,
        weights=None if weights is None else FitnessWeights.parse(weights).as_dict(),
        joint_topic=joint_topic,
        project=_run_project(project),
        keep_inactive=keep_inactive,
        threads=threads,
    )
    result = start_run(config, out_dir, show_progress=not quiet and not as_json)
    _report_tune(result, out_dir, config, RunStore(out_dir), as_json)


def _print_uncertainty(summary: dict, short: bool, run_dir: Path) -> None:
    """The uncertainty table: every parameter (or, ``short``, the searched ones) with its 95 % interval."""
    if summary.get("error"):
        out.print(f"  uncertainty not computed: {escape(summary['error'])}")
        return
    rows = summary["parameters"]
    if short:  # the pinned ones; the others named in one line
        loose = [e["name"] for e in rows if e["active"] and not e["identifiable"]]
        rows = [e for e in rows if e["identifiable"]]
    table = text_table(
        f"uncertainty at the best point: rank {summary['rank']} of {summary['searched']} searched, "
        f"condition number {_fmt_g(summary['condition_number'])}",
        ("parameter", "value", "95 % low", "95 % high", "active", "identifiable"),
    )
    for e in rows:
        table.add_row(
            e["name"],
            _fmt_g(e["value"]),
            _fmt_g(e["low"]) if e["low"] is not None else "unbounded",
            _fmt_g(e["high"]) if e["high"] is not None else "unbounded",
            "yes" if e["active"] else "no",
            "yes" if e["identifiable"] else "no",
        )
    out.print(table)
    pairs = summary.get("correlated_pairs") or []
    if pairs:
        listed = ", ".join(f"{p['a']} ~ {p['b']} ({p['correlation']:+.2f})" for p in pairs[:3])
        out.print(f"  most correlated: {listed}")
    if short:
        if loose:
            out.print(f"  unbounded (the recordings cannot pin them here): {', '.join(loose)}")
        out.print(f"  `simtune uncertainty {run_dir}` lists every parameter (--json for scripts)")


def _fmt_g(value: float | None) -> str:
    return "-" if value is None else f"{value:.4g}"


@app.command()
def uncertainty(
    run_dir: Annotated[Path, typer.Argument(help="A finished run folder made by `simtune tune`.", callback=_path)],
    workers: WorkersOpt = 1,
    as_json: JsonOpt = False,
) -> None:
    """How well the recordings pin each parameter at a run's best point: 95 % intervals (Gauss-Newton).

    The Jacobian of the per-sample residuals (finite differences, 2D + 1 rollouts as one batch over
    --workers), its rank and condition number, a 95 % interval per parameter (unbounded where the
    recordings cannot pin it) and the most correlated pairs; stored in the run for `simtune report`.
    With --json: one object with a list `parameters` (name, value, low, high, active, identifiable).
    """
    from simtune.runs import run_uncertainty

    summary = run_uncertainty(run_dir, workers)
    if as_json:
        print(json.dumps(summary))
        return
    _print_uncertainty(summary, short=False, run_dir=run_dir)


def _check_project(project_dir: Path) -> None:
    """``simtune check DIR``: one line per finding (problems on stderr); exit 2 if any is a problem."""
    from simtune.project_check import check_project

    findings = check_project(project_dir)
    for finding in findings:
        stream = err if finding.level == "problem" else out
        stream.print(escape(str(finding)), highlight=False, soft_wrap=True)
    if any(f.level == "problem" for f in findings):
        raise typer.Exit(2)


@app.command()
def check(
    project_dir: Annotated[
        Path | None,
        typer.Argument(
            help="Project folder to check (its simtune.toml); with --task, the project whose tasks are checked.",
            show_default=False,
            callback=_path,
        ),
    ] = None,
    engine: Annotated[str | None, typer.Option("--engine", "-e", help="Physics engine (default mujoco).")] = None,
    task: Annotated[
        str | None,
        typer.Option("--task", "-t", help="Task name, or several joined by commas (checked together)."),
    ] = None,
    data: DataOpt = None,
    space: SpaceOpt = "extended",
    workers: WorkersOpt = 1,
    as_json: JsonOpt = False,
) -> None:
    """Before tuning: a project's files (simtune check DIR), or a task's data and what it can inform (--task).

    simtune check DIR: robot, joints and links, recordings, start pose, engines; one line per finding,
    exit 2 if any is a problem.  With --task T (and --data ROOT, or DIR's recordings): per task, lost
    marker frames and the longest gap of each recording, how well the repeats agree, how far each starts
    from the simulated arm, each repeat's motion onset (and the command delay it implies); then the rank
    and singular values of the residuals' Jacobian at the generic point and, per active parameter,
    whether the recordings can inform it.
    """
    from simtune.check import check as run_check
    from simtune.project import get_project

    if task is None:
        if project_dir is None:
            raise SimtuneError(
                "check: name a project folder (simtune check DIR) or the tasks to check (--task T --data ROOT)"
            )
        _check_project(project_dir)
        return
    root = _project_data(data, project_dir)
    if root is None:
        raise SimtuneError(f"check: the project {project_dir} names no data root: give the recordings with --data")
    result = run_check(engine or "mujoco", get_project(project_dir).parse_tasks(task), root, space, workers)
    if as_json:
        print(json.dumps(result))
        return
    for part in result["data_quality"]:
        table = text_table(
            f"{part['task']}: {len(part['repeats'])} repeats, spread {1000 * part['repeat_spread_m']:.1f} mm",
            ("file", "lost frames", "longest gap [s]", "to mean [mm]", "start distance [mm]", "onset [s]"),
        )
        for r in part["repeats"]:
            table.add_row(
                r["file"],
                str(r["lost_frames"]),
                f"{r['longest_gap_s']:.2f}",
                f"{1000 * r['distance_to_mean_m']:.1f}" + (" (outlier)" if r["outlier"] else ""),
                f"{1000 * r['start_distance_m']:.1f}",
                _fmt_g(r["onset_s"]),
            )
        out.print(table)
        for line in part["left_out"]:
            out.print(f"  left out: {escape(line)}")
        out.print(
            f"  motion onset {_fmt_g(part['onset_mean_s'])} s (std {_fmt_g(part['onset_std_s'])} s); the generic "
            f"simulation moves at {_fmt_g(part['simulated_onset_s'])} s: command delay about "
            f"{_fmt_g(part['implied_command_delay_s'])} s"
        )
    jac = result["jacobian"]
    shown = ", ".join(f"{v:.3g}" for v in jac["singular_values"])
    out.print(
        f"Jacobian at the generic point: rank {jac['rank']} of {jac['searched']} active parameters "
        f"({jac['cutoff']}); singular values: {shown}"
    )
    table = text_table("what the recordings can inform", ("parameter", "informed", "sensitivity", "note"))
    for p in sorted(result["parameters"], key=lambda p: -p["sensitivity"]):
        table.add_row(
            p["name"],
            "yes" if p["informed"] else "no",
            f"{p['sensitivity']:.3g}",
            f"inactive: {p['inactive']}" if "inactive" in p else "",
        )
    out.print(table)


@app.command()
def resume(
    run_dir: Annotated[Path, typer.Argument(help="A run folder made by `simtune tune`.", callback=_path)],
    rescore: Annotated[
        bool,
        typer.Option(
            "--rescore",
            help="Start a new run in RUN_DIR on the data as it is now (for when the recordings, a task or the "
            "engine changed since the run started): same settings, its search starting from the old run's last "
            "population, every member scored anew; the old store and best_params.json move to RUN_DIR/superseded/.",
        ),
    ] = False,
    quiet: Annotated[bool, typer.Option("--quiet", "-q", help="No progress bar.")] = False,
    as_json: JsonOpt = False,
) -> None:
    """Continue a tuning run that was stopped or killed, keeping every finished evaluation.

    Refused (naming what changed) when the data, a task definition or the engine
    version changed since the run started: its stored fitness values would be
    stale; --rescore starts over from its last population instead.  Evaluations
    that failed by running past --eval-timeout are retried once.
    """
    from simtune.runs import RunConfig, resume_run
    from simtune.store import STORE_FILE, RunStore

    result = resume_run(run_dir, show_progress=not quiet and not as_json, rescore=rescore)
    store = RunStore(run_dir)
    config = RunConfig.from_stored(store.get("config"), str(run_dir / STORE_FILE))
    rescored = store.get("rescored_from")
    if rescore and rescored and not as_json:
        changed = "; ".join(rescored["changes"]) or "nothing changed"
        start = f"its {rescored['members']} last members" if rescored["members"] else "scratch (it had no checkpoint)"
        err.print(
            f"rescored ({changed}): new run from {start}; old run kept in {run_dir / rescored['store']}",
            markup=False,
            highlight=False,
            soft_wrap=True,
        )
    _report_tune(result, run_dir, config, store, as_json)


@app.command()
def demo(
    out_dir: Annotated[
        Path, typer.Option("--out", "-o", help="Run folder for the demo's tuning run.", callback=_path)
    ] = Path("runs/demo"),
    workers: Annotated[int, typer.Option("--workers", "-w", min=1)] = 2,
    max_seconds: Annotated[float, typer.Option(help="Time budget of the tuning run [s].", callback=_seconds)] = 120.0,
) -> None:
    """Tune MuJoCo to the shipped reference recording and print generic vs tuned error (about a minute)."""
    from simtune.reference import run_demo

    run_demo(out_dir, workers=workers, max_seconds=max_seconds, console=out)


def _split(text: str) -> list[str]:
    return [part.strip() for part in text.split(",") if part.strip()]


def _only(text: str | None) -> list[str] | None:
    """--only's parameter names (None without the option); an --only that names none is an error, never the
    whole space."""
    if text is None:
        return None
    names = _split(text)
    if not names:
        raise SimtuneError(f"--only: no parameter named in {text!r}: name one or more, e.g. --only command_delay")
    return names


@app.command()
def grid(
    engines: Annotated[str, typer.Option(help="Engines, comma-separated.")] = "mujoco,pybullet",
    tasks: Annotated[
        str,
        typer.Option(
            help="Experiments, comma-separated; join tasks tuned together with '+' "
            "(single+cube), or name a group (seed-11)."
        ),
    ] = "single,cube",
    spaces: Annotated[str, typer.Option(help="Parameter spaces, comma-separated.")] = "shared,individual",
    repeats: Annotated[int, typer.Option(min=1, help="Optimisations per engine x task x space (seeds 0..N-1).")] = 10,
    data: DataOpt = None,
    out_dir: Annotated[
        Path, typer.Option("--out", "-o", help="Grid folder: grid.sqlite index and runs/.", callback=_path)
    ] = Path("runs/grid"),
    executor: Annotated[str, typer.Option(help="local (process pool here) or dask (a distributed cluster).")] = "local",
    scheduler: Annotated[
        str | None,
        typer.Option(help="Dask scheduler address (tcp://host:8786); default: a LocalCluster on this machine."),
    ] = None,
    workers: Annotated[
        int,
        typer.Option(
            "--workers",
            "-w",
            min=1,
            help="Local processes / LocalCluster workers (one optimisation each, one core each).",
        ),
    ] = 2,
    index_url: Annotated[
        str | None,
        typer.Option(
            "--index",
            help="PostgreSQL URL (postgresql://user@host/db) for a long-lived index shared by many grids; "
            "default: GRID/grid.sqlite. Needs pip install 'simtune[postgres]'.",
        ),
    ] = None,
    max_seconds_per_run: Annotated[
        float | None, typer.Option(help="Wall-time limit of each optimisation [s].", callback=_seconds)
    ] = None,
    max_generations: Annotated[int, typer.Option(min=1, help="Generation limit of each optimisation.")] = 1000,
    only: Annotated[str | None, typer.Option(help="Tune only these parameters (comma-separated).")] = None,
    keep_inactive: KeepInactiveOpt = False,
    plan: Annotated[bool, typer.Option("--plan", help="Print the grid's size and cost estimate; run nothing.")] = False,
    cluster_cores: Annotated[int, typer.Option(min=1, help="With --plan: cores of the cluster to estimate for.")] = 100,
) -> None:
    """Run an experiment grid (engines x tasks x spaces x repeats), resumably, locally or on Dask.

    Running the same command again skips finished optimisations and resumes
    unfinished ones; `--plan` prints the grid's size and its estimated
    core-hours from measured evaluation costs.
    """
    import os

    from rich.live import Live

    from simtune.grid import GridSpec, plan_grid, run_grid

    spec = GridSpec(
        engines=_split(engines),
        tasks=_split(tasks),
        spaces=_split(spaces),
        repeats=repeats,
        data=str(_data_root(data)),
        max_seconds_per_run=max_seconds_per_run,
        max_generations=max_generations,
        only=_only(only),
        keep_inactive=keep_inactive,
    )
    if plan:
        rows = plan_grid(spec)
        table = text_table(
            f"grid plan: {len(spec.units())} optimisations",
            ("engine", "tasks", "space", "params", "s / eval", "evals / run", "h / run", "core-hours"),
        )
        for r in rows:
            table.add_row(
                r["engine"],
                r["tasks"],
                r["space"],
                str(r["parameters"]),
                f"{r['eval_s']:.3f}",
                str(r["evaluations_per_run"]),
                f"{r['run_hours']:.2f}",
                f"{r['core_hours']:.1f}",
            )
        out.print(table)
        total = sum(r["core_hours"] for r in rows)
        here = os.cpu_count() or 1
        out.print(
            f"total {total:.1f} core-hours (upper bound: {max_generations} generations per run unless "
            f"--max-seconds-per-run caps it): {total / here:.1f} h on this machine ({here} cores), "
            f"{total / cluster_cores:.1f} h on a {cluster_cores}-core cluster"
        )
        return

    started = time.time()

    def view(index) -> Table:
        counts = index.counts()
        done, total = counts.get("done", 0), sum(counts.values())
        elapsed = time.time() - started
        eta = f"{elapsed / done * (total - done) / 60:.1f} min" if done else "-"
        table = text_table(
            f"grid {out_dir}: {done}/{total} done, {counts.get('running', 0)} running, "
            f"{counts.get('failed', 0)} failed, {counts.get('pending', 0)} pending; ETA {eta}",
            ("engine", "tasks", "best fitness"),
        )
        for engine_name, task_names, best in index.best():
            table.add_row(engine_name, task_names, f"{best:.4f}")
        return table

    with Live(console=err, auto_refresh=False) as live:
        index = run_grid(
            spec,
            out_dir,
            executor=executor,
            workers=workers,
            scheduler=scheduler,
            index_url=index_url,
            on_event=lambda idx: live.update(view(idx), refresh=True),
        )
    counts = index.counts()
    out.print(f"{counts.get('done', 0)} done, {counts.get('failed', 0)} failed; index: {index.location}")
    for row in index.rows():
        if row["status"] == "failed":
            err.print(f"[red]failed:[/] {row['id']}: {row['error']}", soft_wrap=True)
    if counts.get("failed"):
        raise typer.Exit(1)


@app.command()
def engines() -> None:
    """List the physics engines, their versions, what each computes on (a GPU, if found), and how to install a
    missing one."""
    import importlib

    from simtune.engines import ENGINES

    table = text_table("physics engines", ("engine", "version", "installed", "device", "install"))
    for name, entry in ENGINES.items():
        engine = getattr(importlib.import_module(entry.module), entry.cls)
        version = engine.version()
        installed = version != "not installed"
        table.add_row(
            name,
            version if installed else "-",
            "yes" if installed else "[red]no[/]",
            engine.device() if installed else "-",
            escape(entry.install),
        )
    out.print(table)


@app.command()
def tasks(
    contact: Annotated[
        bool,
        typer.Option(
            "--contact",
            help="Simulate each seed task with an object (generic parameters) and report whether and when "
            "the arm first touches the object, and how far the object moves.",
        ),
    ] = False,
    engine: Annotated[
        str | None,
        typer.Option("--engine", "-e", help="With --contact: this engine only (default: every installed engine)."),
    ] = None,
    task: Annotated[
        str | None,
        typer.Option("--task", "-t", help="With --contact: these tasks (default: the seed tasks with an object)."),
    ] = None,
    figure: Annotated[
        Path | None,
        typer.Option(help="With --contact: write the arm at first contact to FIGURE/contact-<engine>.png (and .svg)."),
    ] = None,
    as_json: Annotated[
        bool, typer.Option("--json", help="With --contact: one JSON object per line, one per engine and task.")
    ] = False,
    project: ProjectOpt = None,
) -> None:
    """List a project's tasks: duration, object and whether public recordings exist (--contact: simulate contact)."""
    from simtune.project import get_project

    proj = get_project(project)
    if contact:
        _tasks_contact(engine, task, figure, as_json, proj)
        return
    if engine or task or figure or as_json:
        raise SimtuneError("--engine, --task, --figure and --json go with --contact")
    table = text_table(
        f"tasks of project {proj.name}", ("task", "duration [s]", "object", "public recordings", "description")
    )
    for t in proj.tasks.values():
        obj = f"{t.object.material} {t.object.shape} {t.object.mass:g} kg" if t.object else "-"
        table.add_row(t.name, f"{t.duration:g}", obj, "yes" if t.has_public_recordings else "-", t.description)
    for name, members in proj.groups.items():
        table.add_row(name, "-", "-", "-", f"all of {members[0]} .. {members[-1]}, fitness summed")
    out.print(table)


def _tasks_contact(engine: str | None, task: str | None, figure: Path | None, as_json: bool, project) -> None:
    import importlib

    from simtune.engines import ENGINES, engine_class, make_engine
    from simtune.engines.contact import probe_contact

    if task is None:
        # the bundled project's seed tasks, or every task with an object of another project
        chosen = [t for t in project.tasks.values() if t.object is not None]
        if any(t.name.startswith("seed-") for t in chosen):
            chosen = [t for t in chosen if t.name.startswith("seed-")]
    else:
        chosen = project.parse_tasks(task)
        for t in chosen:
            if t.object is None:
                raise SimtuneError(f"task {t.name!r} has no object: --contact needs tasks with one")
    if engine is not None:
        engine_class(engine)  # unknown or not installed: one line, before any simulation
        names = [engine]
    else:
        names = [
            name
            for name, (module, cls, _) in ENGINES.items()
            if getattr(importlib.import_module(module), cls).version() != "not installed"
        ]
        skipped = [name for name in ENGINES if name not in names]
        if skipped:
            err.print(f"[yellow]note:[/] not installed, skipped: {', '.join(skipped)}")
    for name in names:
        probes = []
        for t in chosen:
            sim = make_engine(name, t)
            try:
                probe = probe_contact(sim)
            finally:
                sim.close()
            probes.append(probe)
            if not probe.stable:
                err.print(f"[yellow]warning:[/] {name} on {t.name}: {probe.message}")
            if as_json:
                print(json.dumps(probe.as_json()), flush=True)
        if not as_json:
            table = text_table(
                f"contact in {name} (generic parameters)",
                ("task", "object", "touched", "first contact [s]", "object moved [cm]"),
                right=("first contact [s]", "object moved [cm]"),
            )
            for t, p in zip(chosen, probes):
                assert t.object is not None, "chosen for its object"
                table.add_row(
                    p.task,
                    f"{t.object.material} {t.object.shape}",
                    "yes" if p.touched else "[red]no[/]",
                    "-" if p.first_contact_s is None else f"{p.first_contact_s:.3f}",
                    f"{p.object_displacement_m * 100:.1f}",
                )
            out.print(table)
        if figure is not None:
            from simtune.report.contact import contact_figure
            from simtune.report.figures import save

            figure.mkdir(parents=True, exist_ok=True)
            save(contact_figure(probes, {t.name: t for t in chosen}), figure, f"contact-{name}")
            if not as_json:
                out.print(f"figure: {figure / f'contact-{name}.png'}")


@app.command()
def params(
    space: Annotated[
        str, typer.Option("--space", "-s", help="shared, individual, extended or calibrated.")
    ] = "extended",
    engine: Annotated[str | None, typer.Option("--engine", "-e", help="Only what this engine supports.")] = None,
    project: ProjectOpt = None,
    task: Annotated[
        str | None,
        typer.Option(
            "--task",
            "-t",
            help="Also say which parameters change a rollout of these tasks (comma-separated; measured by a probe "
            "of the engine, default mujoco, and cached): an active column and the reason for each inactive one.",
        ),
    ] = None,
) -> None:
    """List a parameter space: names, ranges, units (with --task: whether each can change the task's rollout)."""
    from simtune.engines import engine_class
    from simtune.params import get_space
    from simtune.project import get_project
    from simtune.tasks.spec import common_robot

    proj = get_project(project)
    robot = common_robot(proj.tasks.values())  # the spaces follow the project's robot
    if task is not None and engine is None:
        engine = "mujoco"
    supported = engine_class(engine).supported(robot) if engine else None
    sp = get_space(space, supported, robot=robot)
    inactive: dict[str, str] = {}
    headers: tuple[str, ...] = ("parameter", "low", "high", "unit", "meaning")
    if task is not None:
        from simtune.activity import inactive_parameters

        assert engine is not None, "set above"
        inactive = inactive_parameters(engine, proj.parse_tasks(task), sp)
        headers = ("parameter", "low", "high", "unit", "active", "meaning / why inactive")
    title = f"space {space}" + (f" in {engine}" if engine else "") + f": {len(sp)} parameters"
    if task is not None:
        title += f", {len(sp) - len(inactive)} active on {task}"
    table = text_table(title, headers)
    for p in sp.parameters:
        if task is None:
            table.add_row(p.name, f"{p.low:g}", f"{p.high:g}", p.unit, p.description)
        else:
            why = inactive.get(p.name)
            table.add_row(p.name, f"{p.low:g}", f"{p.high:g}", p.unit, "no" if why else "yes", why or p.description)
    out.print(table)


@app.command()
def synth(
    *,  # keyword-only, so that the required --out may follow options with defaults
    engine: EngineOpt = "mujoco",
    task: Annotated[
        str,
        typer.Option(
            "--task",
            "-t",
            help="Task(s) to record, comma-separated or a group (seed-11 = seed-1 ... seed-10); see `simtune tasks`.",
        ),
    ] = "cube",
    truth: Annotated[
        Path | None,
        typer.Option(
            "--truth",
            help="JSON of the true parameter values (a flat mapping or a params file such as "
            "best_params.json), checked against the engine's parameters. Default: the engine's generic values "
            "and a command delay.",
            callback=_path,
        ),
    ] = None,
    noise_mm: Annotated[
        float,
        typer.Option(
            help="Motion-capture noise: Gaussian, per axis, on every 100 Hz "
            "sample of the wrist marker [mm] (a quarter of it on base and object).",
            callback=_not_negative,
        ),
    ] = 2.0,
    delay_s: Annotated[
        float | None,
        typer.Option(
            help="True command delay [s], overriding the truth file's (default without --truth: 1.5).",
            callback=_finite,
        ),
    ] = None,
    jitter_s: Annotated[
        float,
        typer.Option(
            help="Each repeat's start moves by a uniform jitter within +- this [s], as real repeats do.",
            callback=_not_negative,
        ),
    ] = 0.05,
    repeats: Annotated[int, typer.Option(min=1, help="Recordings per task.")] = 10,
    seed: Annotated[int, typer.Option(min=0, max=MAX_SEED, help="Seed of the noise (same seed, same files).")] = 0,
    fmt: Annotated[
        str,
        typer.Option(
            "--format",
            help="What each recording holds: tsv (markers, Qualisys TSV), csv (markers and joint angles, simtune "
            "CSV), joints-csv (joint angles alone), mcap or rosbag2 (joint angles alone as ROS 2 JointState "
            "messages: an MCAP file, a rosbag2 folder), lerobot or lerobot-v2.1 (joint angles and commanded "
            "targets as one LeRobot dataset per task, OUT/<task>/, v3.0 or v2.1 layout; the task file states "
            "the unit: [recordings] units).",
        ),
    ] = "tsv",
    joint_noise_deg: Annotated[
        float | None,
        typer.Option(
            help="Encoder noise of the joint logs: Gaussian, on every 100 Hz sample of each joint angle [deg] "
            "(default 0.05).",
            callback=_not_negative,
            show_default=False,
        ),
    ] = None,
    out_dir: Annotated[
        Path,
        typer.Option(
            "--out",
            "-o",
            help="Data root to write: `OUT/<task>/<task>NNNN.tsv` (or --format's kind), each task's truth "
            "`OUT/truth-<task>.json` and `OUT/truth.json`.",
            show_default=False,
            callback=_path,
        ),
    ],
    project: ProjectOpt = None,
    force: Annotated[
        bool,
        typer.Option(
            "--force",
            help="Replace the truth files of an earlier synth into OUT (OUT/truth.json holding another truth); "
            "each task's own OUT/truth-<task>.json is kept.",
        ),
    ] = False,
) -> None:
    """Make recordings with a known ground truth: simulate with chosen parameters, add mocap-like noise.

    Writes Qualisys 6D TSV files (with header) to `OUT/<task>/` (or joint logs:
    --format), read by every command's --data OUT like real recordings, each
    task's truth to OUT/truth-<task>.json and OUT/truth.json (the truth of every
    task synthesised into OUT with it; each file also a --params-file).  Tune on
    them to check that tuning recovers the truth.  Another truth already in OUT
    is never overwritten without --force.

    Example: simtune synth --engine mujoco --task single,cube,double --delay-s 1.5 --out data/synthetic
    """
    from simtune.synth import DEFAULT_JOINT_NOISE_DEG, TRUTH_FILE, load_truth, make_synthetic, truth_file

    values = load_truth(truth, engine, delay_s)
    result = make_synthetic(
        engine,
        task,
        out_dir,
        truth=values,
        noise_m=noise_mm / 1000.0,
        repeats=repeats,
        seed=seed,
        jitter_s=jitter_s,
        fmt=fmt,
        joint_noise_rad=math.radians(DEFAULT_JOINT_NOISE_DEG if joint_noise_deg is None else joint_noise_deg),
        project=project,
        force=force,
    )
    for name, files in result.files.items():
        held = f"{repeats} episodes of a LeRobot dataset" if fmt.startswith("lerobot") else f"{len(files)} recordings"
        out.print(f"{name}: {held} in {out_dir / name}")
    shown = ", ".join(f"{k}={v:g}" for k, v in values.items())
    noises = {
        "tsv": f"{noise_mm:g} mm",
        "csv": f"{noise_mm:g} mm and {math.degrees(result.joint_noise_rad):g} deg",
    }
    noise = noises.get(fmt, f"{math.degrees(result.joint_noise_rad):g} deg")
    written = ", ".join(str(out_dir / truth_file(name)) for name in result.files)
    out.print(
        f"truth ({engine}): {shown}; noise {noise}, jitter +-{jitter_s:g} s -> {written} and {out_dir / TRUTH_FILE}",
        highlight=False,
        soft_wrap=True,
    )


@app.command()
def init(
    robot: Annotated[
        Path,
        typer.Option("--robot", help="The robot's URDF file (meshes beside it), used in place.", callback=_path),
    ],
    out_dir: Annotated[
        Path,
        typer.Option("--out", "-o", help="The new project folder (must not exist, or be empty).", callback=_path),
    ],
    tracked_link: Annotated[
        str | None,
        typer.Option(
            "--tracked-link",
            help="The link the motion capture follows (default: the end of the longest chain of arm joints).",
        ),
    ] = None,
    driven_joints: Annotated[
        str | None,
        typer.Option(
            "--driven-joints",
            help="The joints the controller drives, in order, joined by commas (default: the arm joints up to "
            "the tracked link; gripper joints are held).",
        ),
    ] = None,
    package_path: Annotated[
        list[Path] | None,
        typer.Option(
            "--package-path",
            help="A folder where the URDF's package:// names are found (a package, or a folder of packages); "
            "repeat for several. Also read: $SIMTUNE_PACKAGE_PATH, $ROS_PACKAGE_PATH.",
        ),
    ] = None,
) -> None:
    """Start a project for your robot: a commented simtune.toml and an example task `reach`.

    Prints what it chose (tracked link, driven and held joints) and why.
    Example: simtune init --robot arm.urdf --out myproject; then simtune check myproject
    """
    from simtune.project_init import init_project

    joints = None if driven_joints is None else _split(driven_joints)
    if joints is not None and not joints:
        raise SimtuneError("init: --driven-joints names no joint (joint names joined by commas)")
    loaded: list = []
    file = init_project(
        robot, out_dir, tracked_link=tracked_link, driven_joints=joints, package_path=package_path or (), loaded=loaded
    )
    description = loaded[0]
    out.print(f"robot {description.name!r} from {robot}:", highlight=False, soft_wrap=True)
    out.print(f"  driven joints: {', '.join(description.arm_joints)}", highlight=False, soft_wrap=True)
    for note in description.choices:
        out.print(f"  {note}", highlight=False, soft_wrap=True, markup=False)
    out.print(f"wrote {file} and {out_dir / 'tasks' / 'reach.toml'}", highlight=False, soft_wrap=True)
    out.print(f"next: simtune check {out_dir}", highlight=False, soft_wrap=True)


@app.command()
def compare(
    optimizers: Annotated[
        str, typer.Option(help="Optimisers to compare, comma-separated: de, cmaes, bo, random.")
    ] = "de,cmaes,bo,random",
    engine: EngineOpt = "mujoco",
    task: TaskOpt = "cube",
    data: DataOpt = None,
    space: SpaceOpt = "extended",
    budget_evals: Annotated[int, typer.Option("--budget-evals", min=1, help="Evaluations each run may use.")] = 300,
    seeds: Annotated[int, typer.Option(min=1, help="Runs per optimiser (seeds 0..N-1); medians are over them.")] = 3,
    target: Annotated[
        float | None,
        typer.Option(
            help="Fitness to reach: the table gives the evaluations each optimiser needed (median over seeds).",
            callback=_not_negative,
        ),
    ] = None,
    workers: WorkersOpt = 1,
    only: OnlyOpt = None,
    eval_timeout: EvalTimeoutOpt = 600.0,
    out_dir: Annotated[
        Path,
        typer.Option(
            "--out",
            "-o",
            help="Folder for the runs (`OUT/<optimizer>/seed-<s>`) and "
            "compare.json; existing finished runs are reused.",
            callback=_path,
        ),
    ] = Path("runs/compare"),
    as_json: JsonOpt = False,
) -> None:
    """Compare optimisers on the same budget of evaluations: best fitness at 25/50/100 % of it, evaluations to a target.

    Every optimiser x seed is an ordinary run; the table reads each run store's
    evaluations in the order they were stored (the first --budget-evals of them).
    Running the command again reuses finished runs and resumes unfinished ones.

    Example: simtune compare --engine mujoco --task cube --data DATA --budget-evals 300 --seeds 3 --target 0.05
    """
    from simtune.compare import markdown_table, run_compare
    from simtune.runs import RunConfig

    base = RunConfig(
        engine=engine,
        tasks=task,
        space=space,
        data=str(_data_root(data)),
        workers=workers,
        only=_only(only),
        eval_timeout=eval_timeout,
    )

    def note(name: str, seed: int, what: str) -> None:
        if not as_json:
            err.print(f"{what} {name} seed {seed} ...", highlight=False)

    result = run_compare(base, _split(optimizers), seeds, budget_evals, out_dir, target, on_run=note)
    if as_json:
        print(json.dumps({k: v for k, v in result.items() if k != "runs"}))
        return
    text = markdown_table(result)
    print(f"{engine} on {task}, space {space}: {budget_evals} evaluations x {seeds} seeds (median over seeds)\n")
    print(text)
    (out_dir / "compare.md").write_text(text)
    out.print(f"runs and compare.json, compare.md in {out_dir}", highlight=False, soft_wrap=True)


@app.command()
def transfer(
    engine: EngineOpt = "mujoco",
    train: Annotated[str, typer.Option(help="Tasks to tune on together (comma-separated).")] = "single,cube",
    test: Annotated[str, typer.Option(help="Unseen tasks to evaluate the tuned parameters on.")] = "double",
    data: DataOpt = None,
    test_data: Annotated[
        Path | None, typer.Option(help="Data root of the test tasks (default: --data).", callback=_path)
    ] = None,
    space: SpaceOpt = "extended",
    optimizer: OptimizerOpt = "de",
    refine: Annotated[bool, typer.Option("--refine", help="Polish the tuned point with least squares.")] = False,
    seed: SeedOpt = 0,
    workers: WorkersOpt = 1,
    max_seconds: Annotated[float | None, typer.Option(help="Tuning wall-time limit [s].", callback=_seconds)] = None,
    max_generations: Annotated[int, typer.Option(min=1, help="Tuning generation limit.")] = 1000,
    max_evaluations: MaxEvalsOpt = None,
    only: OnlyOpt = None,
    eval_timeout: EvalTimeoutOpt = 600.0,
    out_dir: Annotated[
        Path,
        typer.Option("--out", "-o", help="Folder for the tuning run (OUT/run) and transfer.json.", callback=_path),
    ] = Path("runs/transfer"),
    align_clock: Annotated[
        bool,
        typer.Option(
            "--align-clock/--no-align-clock",
            help="Also score each test task with its own recording clock aligned: its command delay estimated "
            "from its recordings with the tuned physics held fixed (so the transfer measures the physics, not "
            "the clocks).",
        ),
    ] = True,
    quiet: Annotated[bool, typer.Option("--quiet", "-q", help="No progress bar.")] = False,
    as_json: JsonOpt = False,
) -> None:
    """Tune on some tasks, then test the tuned parameters on tasks never tuned on, against generic.

    The tuning run is an ordinary run (resumable; OUT/run/best_params.json works
    with `simtune evaluate --params-file` on any task). Running the command again
    resumes or reuses it.

    Example: simtune transfer --engine mujoco --train single,cube --test double --data DATA --max-evaluations 500
    """
    from simtune.runs import RunConfig
    from simtune.transfer import run_transfer

    config = RunConfig(
        engine=engine,
        tasks=train,
        space=space,
        data=str(_data_root(data)),
        seed=seed,
        workers=workers,
        max_seconds=max_seconds,
        max_generations=max_generations,
        max_evaluations=max_evaluations,
        only=_only(only),
        eval_timeout=eval_timeout,
        optimizer=optimizer,
        refine=refine,
    )
    result = run_transfer(
        config, test, out_dir, test_data, show_progress=not quiet and not as_json, align_clock=align_clock
    )
    if as_json:
        print(json.dumps({k: v for k, v in result.items() if k != "params"}))
        return
    table = text_table(
        f"{engine}: tuned on {train} ({space}, {optimizer}), tested on {test}",
        ("task", "set", "generic", "tuned", "change", "wrist [m]", "object [m]"),
        right=("generic", "tuned", "change", "wrist [m]", "object [m]"),
    )
    for r in result["tasks"]:
        table.add_row(
            r["task"],
            r["role"],
            _fmt(r["generic"]),
            _fmt(r["tuned"]),
            f"{r['change'] * 100:+.0f} %",
            _fmt(r["tuned_wrist"]),
            _fmt(r["tuned_object"]),
        )
    for role, t in result["totals"].items():
        table.add_row(
            f"[bold]all {role}[/]", role, _fmt(t["generic"]), _fmt(t["tuned"]), f"{t['change'] * 100:+.0f} %", "", ""
        )
        if "tuned_aligned" in t:
            table.add_row(
                f"[bold]all {role}, clock aligned[/]",
                role,
                _fmt(t["generic"]),
                _fmt(t["tuned_aligned"]),
                f"{t['change_aligned'] * 100:+.0f} %",
                "",
                "",
            )
    out.print(table)
    for r in result["tasks"]:
        if r["delay_s"] is not None:
            out.print(
                f"clock aligned: {r['task']}'s command delay {r['delay_s']:.2f} s, estimated from its recordings "
                f"with the tuned physics held fixed: tuned fitness {r['tuned']:.4f} -> {r['tuned_aligned']:.4f} "
                "(--no-align-clock leaves clocks alone)"
            )
    out.print(f"tuned parameters: {result['best_params_file']}; result: {out_dir / 'transfer.json'}")


@app.command()
def sensitivity(
    engine: EngineOpt = "mujoco",
    task: TaskOpt = "cube",
    data: DataOpt = None,
    space: SpaceOpt = "extended",
    samples: Annotated[
        int,
        typer.Option(
            min=2,
            help="morris: trajectories (N (D+1) evaluations); sobol: base "
            "samples, a power of two (N (D+2) evaluations).",
        ),
    ] = 10,
    method: Annotated[
        str, typer.Option(help="morris (elementary effects, cheap screening) or sobol (variance shares S1 and ST).")
    ] = "morris",
    seed: Annotated[int, typer.Option(min=0, max=MAX_SEED, help="Seed of the sampling.")] = 0,
    workers: WorkersOpt = 1,
    only: OnlyOpt = None,
    eval_timeout: EvalTimeoutOpt = 600.0,
    out_dir: Annotated[
        Path,
        typer.Option(
            "--out", "-o", help="Folder for sensitivity.json/.csv/.md/.png and the evaluation cache.", callback=_path
        ),
    ] = Path("runs/sensitivity"),
    as_json: JsonOpt = False,
) -> None:
    """Global sensitivity of the fitness to each parameter (SALib Morris or Sobol), most influential first.

    Evaluations run through the same process pool as tuning and are cached in
    OUT/sensitivity.sqlite. `simtune report` picks up OUT/sensitivity.json when
    OUT is under or next to its input folders.

    Example: simtune sensitivity --engine mujoco --task cube --data DATA --samples 20 --workers 2 --out runs/sens
    """
    from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn

    from simtune.engines import engine_class
    from simtune.params import get_space
    from simtune.sensitivity import evaluation_count, run_sensitivity, sensitivity_table

    dim = len(get_space(space, engine_class(engine).supported(), _only(only)))
    total = evaluation_count(method, samples, dim)
    with Progress(
        TextColumn("[bold]sensitivity[/]"),
        BarColumn(),
        MofNCompleteColumn(),
        TimeElapsedColumn(),
        console=err,
        disable=as_json,
    ) as bar:
        job = bar.add_task("evaluate", total=total)
        result = run_sensitivity(
            engine,
            task,
            _data_root(data),
            space,
            out_dir,
            samples=samples,
            method=method,
            only=_only(only),
            seed=seed,
            workers=workers,
            eval_timeout=eval_timeout,
            on_evaluation=lambda score, reused: bar.advance(job),
        )
    if as_json:
        print(json.dumps(result))
        return
    table = sensitivity_table(result)
    view = text_table(
        table.title,
        [col.name for col in table.columns],
        right=[col.name for col in table.columns if col.name != "parameter"],
    )
    for row in table.rows:
        view.add_row(*(table.cell(v, c) for v, c in zip(row, table.columns)))
    out.print(view)
    out.print(table.note, highlight=False, markup=False)
    out.print(f"{result['new_evaluations']} new evaluations; files in {out_dir}: sensitivity.json, .csv, .md, .png")


@app.command("export")
def export_command(
    run_dirs: Annotated[
        list[Path],
        typer.Argument(
            help="A finished run folder; with --all-engines, run folders or folders holding them (a grid).",
            show_default=False,
        ),
    ],
    out_dir: Annotated[
        Path,
        typer.Option(
            "--out", "-o", help="Folder to write (with --all-engines: one sub-folder per run).", show_default=False
        ),
    ],
    engine: Annotated[
        str | None,
        typer.Option("--engine", "-e", help="The run's engine (checked against it); default: the run's."),
    ] = None,
    all_engines: Annotated[
        bool,
        typer.Option(
            "--all-engines", help="Export every finished run found under RUN_DIRS, each as its own engine's files."
        ),
    ] = False,
    dr: Annotated[
        bool, typer.Option("--dr", help="Also write dr_ranges.yaml: the ranges the exported runs' tuned values span.")
    ] = False,
    force: Annotated[
        bool, typer.Option("--force", help="Replace a previous export in a non-empty --out folder.")
    ] = False,
    as_json: JsonOpt = False,
) -> None:
    """Export a tuned run as the engine's own model files, with provenance: MJCF, URDF + sidecar, SDFormat ...

    MuJoCo: scene_<task>.xml; PyBullet and DART: URDF files, a JSON sidecar and a
    load script; Drake: URDF and SDFormat with Drake's tags, a sidecar and a load
    script; ODE: the sidecar only (ODE has no model file). Every export has
    controller.yaml (how the run drove the model) and provenance.json (run,
    versions, data files with SHA-256, fitness, command line). See docs/parameters.md.

    Example: simtune export runs/cube --out exported/cube --dr
    """
    from simtune.export import export_run, export_runs

    if all_engines and engine is not None:
        raise SimtuneError("--all-engines exports each run with its own engine: leave out --engine")
    if all_engines:
        results, skipped = export_runs(run_dirs, out_dir, dr=dr, force=force)
        for path, why in skipped:
            err.print(f"[yellow]warning:[/] skipped {escape(str(path))}: {escape(why)}", soft_wrap=True)
    else:
        if len(run_dirs) != 1:
            raise SimtuneError(f"give one run folder (got {len(run_dirs)}), or --all-engines for several")
        results = [export_run(run_dirs[0], out_dir, engine=engine, dr=dr, force=force)]
    if as_json:
        print(
            json.dumps([{"run": str(r.run), "engine": r.engine, "out": str(r.out), "files": r.files} for r in results])
        )
        return
    for r in results:
        out.print(f"{r.engine}: {r.run} -> {r.out} ({', '.join(r.files)})", highlight=False, soft_wrap=True)


app.command()(report)  # defined beside the report package it drives

#: the exception class of the Click that Typer runs on (Typer may bundle its own copy)
_CLICK_ERROR: type[Exception] = next(c for c in typer.BadParameter.__mro__ if c.__name__ == "ClickException")


def _say_interrupted(exc: BaseException) -> None:
    run_dir = getattr(exc, "run_dir", None)
    message = "interrupted" if run_dir is None else f"interrupted - resume with: simtune resume {run_dir}"
    err.print(message, markup=False, highlight=False, soft_wrap=True)


def _interruptible(command):
    """Ctrl-C inside a command: say how to resume and exit 130 (Typer itself would exit 130 without a word)."""

    @functools.wraps(command)
    def run(*args, **kwargs):
        try:
            return command(*args, **kwargs)
        except KeyboardInterrupt as exc:
            _say_interrupted(exc)
            raise SystemExit(130) from None

    return run


for _info in app.registered_commands:
    _info.callback = _interruptible(_info.callback)


def _usage_error(exc) -> int:
    """A command-line mistake (an option's value, an unknown option) as one line; its exit status."""
    ctx = getattr(exc, "ctx", None)
    message = exc.format_message()
    if not message and ctx is not None:  # `simtune` alone: the help is the answer
        ctx.get_help()
        return exc.exit_code
    command = f"simtune {ctx.info_name} --help" if ctx is not None and ctx.parent is not None else "simtune --help"
    err.print(f"[red]error:[/] {escape(message)} (see `{command}`)", highlight=False, soft_wrap=True)
    return exc.exit_code


def main() -> None:
    warnings.showwarning = _show_warning
    try:
        code = app(standalone_mode=False)
    except SimtuneError as exc:
        err.print(f"[red]error:[/] {escape(str(exc))}", highlight=False, soft_wrap=True)
        sys.exit(2)
    except _CLICK_ERROR as exc:
        sys.exit(_usage_error(exc))
    except KeyboardInterrupt as exc:  # before or after a command
        _say_interrupted(exc)
        sys.exit(130)
    sys.exit(code if isinstance(code, int) else 0)


if __name__ == "__main__":
    main()
