"""Run commands: ``evaluate``, ``tune``, ``resume`` and ``uncertainty``, each a call into :mod:`simtune.api`."""

from __future__ import annotations

import json
import sys
import time
from contextlib import nullcontext
from pathlib import Path
from typing import Annotated, Any

import typer

from simtune.cli.options import (
    AlignClockOpt,
    DataOpt,
    EngineOpt,
    JointTopicOpt,
    JsonOpt,
    KeepRepeatsOpt,
    LoadingOpt,
    ProjectOpt,
    QuietOpt,
    ReferenceOpt,
    RepeatsOpt,
    TargetsOpt,
    TaskOpt,
    WeightsOpt,
    WorkersOpt,
    out_option,
    path,
)
from simtune.cli.output import (
    err,
    evaluation_json,
    fmt,
    out,
    print_evaluation,
    print_json,
    print_uncertainty,
    print_validation,
    print_verdict,
)
from simtune.cli.run_options import run_options
from simtune.common.limits import MAX_BOOTSTRAP
from simtune.errors import SimtuneError

ParamsFileOpt = Annotated[
    Path | None,
    typer.Option(
        "--params-file",
        "-p",
        help="JSON of parameter values (e.g. a run's best_params.json); default: the engine's generic values.",
        callback=path,
    ),
]
TuneOutOpt = Annotated[
    Path,
    out_option("Run folder to create (store, best_params.json): a new or empty folder, held by this run alone."),
]
RescoreOpt = Annotated[
    bool,
    typer.Option(
        "--rescore",
        help="Start a new run in RUN_DIR on the data as it is now (for when the recordings, a task or the "
        "engine changed since the run started): same settings, its search starting from the old run's last "
        "population, every member scored anew; the old store and best_params.json move to RUN_DIR/superseded/.",
    ),
]


def evaluate(
    engine: EngineOpt = "mujoco",
    task: TaskOpt = "cube",
    data: DataOpt = None,
    params_file: ParamsFileOpt = None,
    weights: WeightsOpt = None,
    joint_topic: JointTopicOpt = None,
    project: ProjectOpt = None,
    align_clock: AlignClockOpt = None,
    reference: ReferenceOpt = None,
    repeats: RepeatsOpt = None,
    keep_repeats: KeepRepeatsOpt = False,
    targets: TargetsOpt = None,
    loading: LoadingOpt = None,
    as_json: JsonOpt = False,
) -> None:
    """Fitness of an engine's generic parameters (or of --params-file) on recorded tasks.

    Held-out repeats: a run tuned with --repeats even is scored on the others with
    `simtune evaluate --params-file RUN/best_params.json --repeats odd`.
    """
    from simtune import api

    aligning = _tasks_to_align(align_clock, params_file, task, project)
    # aligning a clock scans its delay (about a hundred rollouts a task): minutes in a slow engine, so say so
    doing = f"{engine}: scoring {task}" + (f", aligning the clock of {', '.join(aligning)}" if aligning else "")
    with err.status(doing) if sys.stderr.isatty() and not as_json else nullcontext():
        score = api.evaluate(
            engine,
            task,
            project=project,
            data=data,
            params=params_file,
            weights=weights,
            joint_topic=joint_topic,
            align_clock=aligning,
            reference=reference,
            repeats=repeats,
            targets=targets,
            keep_repeats=keep_repeats,
            loading=loading,
        )
    if as_json:
        print_json(evaluation_json(engine, task, score))
        return
    with_what = f" with {params_file}" if params_file else " (generic parameters)"
    print_evaluation(score, f"{engine} on {task}{with_what}; reference: {score.reference}")


def _tasks_to_align(align_clock: bool | None, params_file: Path | None, task: str, project: Path | None) -> list[str]:
    """The tasks whose clocks evaluate aligns: all (--align-clock), none (--no-align-clock), or by default those a
    run's parameter file was not tuned on (its 'tasks' field) and does not time with its own delay."""
    from simtune.params import read_params_file
    from simtune.params.kinds import task_delay_name
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
        specs = get_project(project).parse_tasks(tuned_on)
        seen = {t.name for t in specs}
        params = read_params_file(params_file, robot=specs[0].robot if specs else None)
    except SimtuneError:
        return []
    return [name for name in names if name not in seen and task_delay_name(name) not in params]


def report_tune(result, run_dir: Path, config, as_json: bool, command_s: float | None = None) -> None:
    """What ``tune`` and ``resume`` print: the tuned fitness against the generic one, and where the run is; with
    ``command_s`` (the whole command's seconds), how much of a ``--max-seconds`` cap it kept to."""
    from simtune.runs import BEST_PARAMS_FILE, read_run_record

    record = read_run_record(run_dir)
    store_generic = record.generic_score
    searched, inactive = record.parameters or [], record.inactive

    payload = {
        "engine": config.engine,
        "task": config.tasks,
        "space": config.space,
        "optimizer": config.optimizer,
        "reference": config.reference,
        **({"repeats": config.repeats} if config.repeats != "all" else {}),
        "targets": config.targets,
        "loading": config.loading,
        # the data's fit, comparable with a plain run's; a prior's part beside it (--prior)
        "fitness": result.score.data_fitness,
        **({"prior": config.prior, "prior_penalty": result.score.prior_penalty} if config.prior else {}),
        "wrist_error": result.score.wrist_error,
        "object_error": result.score.object_error,
        "joint_error": result.score.joint_error,
        "generic_fitness": store_generic["fitness"],
        "evaluations": result.evaluations,
        "generations": result.generations,
        "wall_s": result.wall_s,
        "best_params_file": str(run_dir / BEST_PARAMS_FILE),
        "message": result.message,
        "stop_reason": result.stop_reason,
        "search_dimension": len(searched),
        "inactive_parameters": inactive,
        "verdict": record.verdict,
    }
    if record.validation is not None:
        # the held-out tasks (--validate): their mean fitness per task, beside the tuned tasks' (the same measure)
        payload["validation_fitness"] = record.validation.get("fitness")
        payload["validation"] = record.validation
    if as_json:
        print_json(payload)
        return
    out.print(
        f"[bold]{config.engine}[/] on [bold]{config.tasks}[/], space {config.space}, optimizer "
        f"{config.optimizer}{' + least squares' if config.refine else ''}, reference {config.reference}"
        f"{'' if config.repeats == 'all' else f' of the {config.repeats} repeats'}: "
        f"fitness {store_generic['fitness']:.4f} (generic) -> [bold green]{result.score.data_fitness:.4f}[/] (tuned)"
        + (f", prior {config.prior:g}'s penalty {fmt(result.score.prior_penalty)} besides" if config.prior else "")
    )
    joint = "" if result.score.joint_error is None else f", joint error {fmt(result.score.joint_error)} rad"
    out.print(
        f"  wrist error {fmt(result.score.wrist_error)} m, object error {fmt(result.score.object_error)} m{joint}; "
        f"{result.evaluations} evaluations, {result.generations} generations, {result.wall_s:.0f} s "
        f"({result.message})"
    )
    out.print(f"  best parameters: {payload['best_params_file']}")
    if command_s is not None and config.max_seconds is not None and command_s > config.max_seconds + 5:
        # --max-seconds caps the search; the probe before it and the uncertainty after it are not searched
        out.print(
            f"  the command took {command_s:.0f} s: the search {result.wall_s:.0f} s (--max-seconds "
            f"{config.max_seconds:g} caps the search), the rest before and after it (reading the recordings, the "
            "probe of which parameters act, the uncertainty)"
        )
    print_validation(record.validation)
    print_verdict(record.verdict)
    if record.uncertainty:
        print_uncertainty(record.uncertainty, short=True, run_dir=run_dir)
    if inactive:
        flag = "--keep-inactive" if config.keep_inactive or config.paper_exact else "named by --only"
        kept = f"kept in the search ({flag})" if set(inactive) & set(searched) else "left out of the search"
        out.print(
            f"  search dimension D = {len(searched)}; {len(inactive)} parameters change no rollout of "
            f"{config.tasks} and were {kept} (`simtune params --task {config.tasks}` says why)"
        )


@run_options()
def tune(
    out_dir: TuneOutOpt = Path("runs/latest"),
    quiet: QuietOpt = False,
    as_json: JsonOpt = False,
    **settings: Any,
) -> None:
    """Tune an engine's parameters to recorded tasks (global then local by default; --optimizer de: the paper's DE).

    Every evaluation is stored in OUT/run.sqlite as it finishes; if the run is
    killed, `simtune resume OUT` continues it without redoing any evaluation
    (every optimiser replays its search from its seed).

    Example: simtune tune --engine mujoco --task cube --data DATA --optimizer cmaes --refine --max-evaluations 2000
    """
    from simtune import api

    config = api.run_config(**settings)
    from simtune.activity import announcing

    started = time.perf_counter()
    # the probe's note goes with the progress bar: a terminal's, never with --quiet or --json
    with announcing(not quiet and not as_json and sys.stderr.isatty()):
        result = api.start(config, out_dir, show_progress=not quiet and not as_json)
    report_tune(result, out_dir, config, as_json, command_s=time.perf_counter() - started)


def uncertainty(
    run_dir: Annotated[Path, typer.Argument(help="A finished run folder made by `simtune tune`.", callback=path)],
    workers: WorkersOpt = 1,
    bootstrap: Annotated[
        int,
        typer.Option(
            "--bootstrap",
            min=0,
            max=MAX_BOOTSTRAP,
            help="Also refit the best point against this many draws of the recordings' repeats (with replacement; "
            "each a least-squares phase): intervals where the simulation is not smooth (Coulomb friction, the time "
            "step), and never narrower than the draws' scatter elsewhere. 30 draws: a minute or two on MuJoCo.",
        ),
    ] = 0,
    as_json: JsonOpt = False,
) -> None:
    """How well the recordings pin each parameter at a run's best point: 95 % intervals (Gauss-Newton).

    The Jacobian of the per-sample residuals (finite differences, 2D + 1 rollouts as one batch over
    --workers), its rank and condition number, a 95 % interval per parameter (unbounded where the
    recordings cannot pin it) and the most correlated pairs; stored in the run for `simtune report`.
    With --bootstrap N, refits against N draws of the repeats as well (docs/tuning.md).
    With --json: one object with a list `parameters` (name, value, low, high, active, identifiable).
    """
    from simtune import api
    from simtune.activity import announcing

    with announcing(not as_json and sys.stderr.isatty()):
        summary = api.uncertainty(run_dir, workers, bootstrap)
    if as_json:
        print_json(summary)
        return
    print_uncertainty(summary, short=False, run_dir=run_dir)


def resume(
    run_dir: Annotated[Path, typer.Argument(help="A run folder made by `simtune tune`.", callback=path)],
    rescore: RescoreOpt = False,
    quiet: QuietOpt = False,
    as_json: JsonOpt = False,
) -> None:
    """Continue a tuning run that was stopped or killed, keeping every finished evaluation.

    Refused (naming what changed) when the data, a task definition or the engine
    version changed since the run started: its stored fitness values would be
    stale; --rescore starts over from its last population instead.  Evaluations
    that failed by running past --eval-timeout are retried once.
    """
    from simtune import api
    from simtune.activity import announcing
    from simtune.runs import is_finished, read_run_record

    finished = not rescore and is_finished(run_dir)
    with announcing(not quiet and not as_json and sys.stderr.isatty()):
        result = api.resume(run_dir, show_progress=not quiet and not as_json, rescore=rescore)
    if finished and not as_json:
        err.print(
            f"{run_dir} is already finished ({result.message}): nothing to resume; "
            f"`simtune resume {run_dir} --rescore` starts a new run from its last population",
            markup=False,
            highlight=False,
            soft_wrap=True,
        )
    record = read_run_record(run_dir)
    config = record.settings
    rescored = record.rescored_from
    if rescore and rescored and not as_json:
        changed = "; ".join(rescored["changes"]) or "nothing changed"
        start = f"its {rescored['members']} last members" if rescored["members"] else "scratch (it had no checkpoint)"
        err.print(
            f"rescored ({changed}): new run from {start}; old run kept in {run_dir / rescored['store']}",
            markup=False,
            highlight=False,
            soft_wrap=True,
        )
    report_tune(result, run_dir, config, as_json)
