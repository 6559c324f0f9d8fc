"""Data commands: ``check`` (a project or a task's recordings) and ``synth`` (recordings with a known truth), each a
call into :mod:`simtune.api` (``init``, a project for a new robot: :mod:`simtune.cli.init_command`)."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Annotated

import typer
from rich.markup import escape

from simtune.cli.check_output import print_data_quality, print_identifiability, print_informed
from simtune.cli.options import (
    DataOpt,
    EngineOpt,
    JsonOpt,
    KeepRepeatsOpt,
    OnlyOpt,
    ProjectOpt,
    ReferenceOpt,
    RepeatsOpt,
    SpaceOpt,
    TargetsOpt,
    WorkersOpt,
    finite,
    not_negative,
    out_option,
    path,
    seed_option,
)
from simtune.cli.output import err, out, print_json
from simtune.common.limits import MAX_SYNTH_REPEATS
from simtune.data.formats import FORMATS, WRITERS
from simtune.errors import SimtuneError

PROJECT_DIR_HELP = "Project folder to check (its simtune.toml); with --task, the project whose tasks are checked."
ProjectDirArg = Annotated[Path | None, typer.Argument(help=PROJECT_DIR_HELP, show_default=False, callback=path)]
CheckTaskOpt = Annotated[
    str | None,
    typer.Option("--task", "-t", help="Task name, or several joined by commas (checked together)."),
]

CheckParamsFileOpt = Annotated[
    Path | None,
    typer.Option(
        "--params-file",
        "-p",
        help="JSON of parameter values (a run's best_params.json, a synth's truth.json): the point the "
        "Jacobian is taken at; default: the generic values.",
        callback=path,
    ),
]
WriteTaskOpt = Annotated[
    Path | None,
    typer.Option(
        "--write-task",
        help="With --task T (one task): write T's task file, each phase whose rest lies far from its targets "
        "given the proposed ones (the former kept as published_targets_deg, the evidence in a comment), to this "
        "new file; never over the original or any file.",
    ),
]


def check(
    project_dir: ProjectDirArg = None,
    project: ProjectOpt = None,
    engine: Annotated[str | None, typer.Option("--engine", "-e", help="Physics engine (default mujoco).")] = None,
    task: CheckTaskOpt = None,
    data: DataOpt = None,
    space: SpaceOpt = "extended",
    workers: WorkersOpt = 1,
    reference: ReferenceOpt = None,
    repeats: RepeatsOpt = None,
    keep_repeats: KeepRepeatsOpt = False,
    targets: TargetsOpt = None,
    only: OnlyOpt = None,
    params_file: CheckParamsFileOpt = None,
    write_task: WriteTaskOpt = None,
    as_json: JsonOpt = False,
) -> None:
    """Before tuning: a project's files (simtune check DIR), or a task's data and what it can inform (--task).

    simtune check DIR (or --project DIR): robot, joints and links, recordings (and the ingest checks' warnings),
    start pose, engines; one line per finding (--json: one object), exit 2 if any is a problem.  With --task T
    (and --data ROOT, or DIR's recordings): per task, lost marker frames and the longest gap of each recording,
    how well the repeats agree, how far each starts from the simulated arm, each repeat's motion onset (and the
    command delay it implies), each phase's rest against where its targets put the arm, in position and (where
    the recordings give it) orientation, with
    proposed targets where it lies far off; then the rank
    and singular values of the residuals' Jacobian at the generic point (or --params-file's) and, per active
    parameter, whether the recordings can inform it; and the combinations of parameters they cannot tell apart,
    each with the motion that would (over --space, or --only's parameters of it).
    """
    from simtune import api

    if project is not None and project_dir is not None and project != project_dir:
        raise SimtuneError(f"check: two projects named ({project_dir} and --project {project}); name one")
    project_dir = project_dir or project
    if task is None:
        if project_dir is None:
            raise SimtuneError(
                "check: name a project folder (simtune check DIR) or the tasks to check (--task T --data ROOT)"
            )
        _check_project(project_dir, data, as_json)
        return
    result = api.check(
        engine or "mujoco",
        task,
        project=project_dir,
        data=data,
        space=space,
        workers=workers,
        reference=reference,
        repeats=repeats,
        write_task=write_task,
        keep_repeats=keep_repeats,
        targets=targets,
        only=only,
        params=params_file,
    )
    if as_json:
        print_json(result)
        return
    print_data_quality(result["data_quality"])
    print_informed(result)
    print_identifiability(result["identifiability"])
    if write_task is not None:
        _print_written_task(result)


def _print_written_task(result: dict) -> None:
    """What ``check --write-task`` wrote (``result``: :func:`simtune.api.check`'s), or why it wrote nothing, and
    each note on a comment of a corrected phase that names a value the correction replaced."""
    written = result["written_task"]
    unplaced = [r["stretch"] for r in result["data_quality"][0]["rest_poses"] if r.get("out_of_reach")]
    if written:
        said = f"corrected task file: {written}"
    elif unplaced:  # far, but no targets place it: the warning above says why
        said = f"no task file written: no joint targets place the rest of {', '.join(unplaced)} (above)"
    else:
        said = "no rest lies far from its targets: no task file written"
    out.print(said, highlight=False, soft_wrap=True)
    for note in result.get("written_task_notes", []):
        out.print(f"  note: {escape(note)}", highlight=False, soft_wrap=True)


def _check_project(project_dir: Path, data: Path | None, as_json: bool = False) -> None:
    """``simtune check DIR [--data ROOT] [--json]``: one line per finding (problems on stderr), or the findings as
    JSON (:func:`simtune.check.project.findings_json`); exit 2 if any is a problem."""
    from simtune import api
    from simtune.check.project import findings_json

    findings = api.check_project(project_dir, data=data)
    if as_json:
        print_json(findings_json(findings))
    else:
        for finding in findings:
            stream = err if finding.level == "problem" else out
            stream.print(escape(str(finding)), highlight=False, soft_wrap=True)
    if any(f.level == "problem" for f in findings):
        raise typer.Exit(2)


SynthTaskOpt = Annotated[
    str,
    typer.Option(
        "--task",
        "-t",
        help="Task(s) to record, comma-separated or a group (seed-11 = seed-1 ... seed-10); see `simtune tasks`.",
    ),
]
TruthOpt = Annotated[
    Path | None,
    typer.Option(
        "--truth",
        help="JSON of the true parameter values (a flat mapping or a params file such as "
        "best_params.json), checked against the engine's parameters. Default: the engine's generic values "
        "and a command delay.",
        callback=path,
    ),
]
NoiseMmOpt = Annotated[
    float,
    typer.Option(
        help="Motion-capture noise: Gaussian, per axis, on every 100 Hz "
        "sample of the wrist marker [mm] (a quarter of it on base and object).",
        callback=not_negative,
    ),
]
DelayOpt = Annotated[
    float | None,
    typer.Option(
        help="True command delay [s], overriding the truth file's (default without --truth: 1.5).", callback=finite
    ),
]
JitterOpt = Annotated[
    float,
    typer.Option(
        help="Each repeat's start moves by a uniform jitter within +- this [s], as real repeats do.",
        callback=not_negative,
    ),
]
FormatOpt = Annotated[
    str,
    typer.Option(
        "--format",
        help="What each recording holds: " + "; ".join(f"{w.name}: {w.description}" for w in WRITERS.values()) + ".",
    ),
]
JointNoiseOpt = Annotated[
    float | None,
    typer.Option(
        help="Encoder noise of the joint logs: Gaussian, on every 100 Hz sample of each joint angle [deg] "
        "(default 0.05).",
        callback=not_negative,
        show_default=False,
    ),
]
SynthOutOpt = Annotated[
    Path,
    out_option(
        "Data root to write: `OUT/<task>/<task>NNNN.tsv` (or --format's kind), each task's truth "
        "`OUT/truth-<task>.json` and `OUT/truth.json`.",
        show_default=False,
    ),
]
ForceOpt = Annotated[
    bool,
    typer.Option(
        "--force",
        help="Replace the truth files of an earlier synth into OUT (OUT/truth.json holding another truth); "
        "each task's own `OUT/truth-<task>.json` is kept.",
    ),
]


def synth(
    *,  # keyword-only, so that the required --out may follow options with defaults
    engine: EngineOpt = "mujoco",
    task: SynthTaskOpt = "cube",
    truth: TruthOpt = None,
    noise_mm: NoiseMmOpt = 2.0,
    delay_s: DelayOpt = None,
    jitter_s: JitterOpt = 0.05,
    repeats: Annotated[int, typer.Option(min=1, max=MAX_SYNTH_REPEATS, help="Recordings per task.")] = 10,
    episodes: Annotated[
        int | None,
        typer.Option(
            min=1,
            max=MAX_SYNTH_REPEATS,
            help="With a dataset --format (lerobot): N different episodes per task instead of repeats, each its "
            "own seeded command stream within the robot's limits, clear of the floor, all on one clock (the "
            'truth\'s delay, no jitter; --repeats unused). A task file reads them with schedule_episode = "each".',
            show_default=False,
        ),
    ] = None,
    seed: Annotated[int, seed_option("Seed of the noise (same seed, same files).")] = 0,
    fmt: FormatOpt = "tsv",
    joint_noise_deg: JointNoiseOpt = None,
    out_dir: SynthOutOpt,
    project: ProjectOpt = None,
    force: ForceOpt = False,
) -> None:
    """Make recordings with a known ground truth: simulate with chosen parameters, add mocap-like noise.

    Writes Qualisys 6D TSV files (with header) to `OUT/<task>/` (or joint logs:
    --format), read by every command's --data OUT like real recordings, each
    task's truth to `OUT/truth-<task>.json` and OUT/truth.json (the truth of every
    task synthesised into OUT with it; each file also a --params-file).  Tune on
    them to check that tuning recovers the truth.  Another truth already in OUT
    is never overwritten without --force.

    Example: simtune synth --engine mujoco --task single,cube,double --delay-s 1.5 --out data/synthetic
    """
    from simtune.studies.synth import DEFAULT_JOINT_NOISE_DEG, TRUTH_FILE, run_synth, truth_file

    # api.synth's own run, its errors naming the options typed here (--noise-mm, not the API's noise_m)
    result = run_synth(
        engine,
        task,
        out_dir,
        truth_file=truth,
        delay_s=delay_s,
        project=project,
        noise_m=noise_mm / 1000.0,
        repeats=repeats,
        seed=seed,
        jitter_s=jitter_s,
        fmt=fmt,
        joint_noise_rad=math.radians(DEFAULT_JOINT_NOISE_DEG if joint_noise_deg is None else joint_noise_deg),
        force=force,
        episodes=episodes,
    )
    writes = WRITERS[fmt]
    dataset = next(f.folder for f in FORMATS if writes in f.writers)  # what a dataset writer's folder is
    for name, files in result.files.items():
        held = f"{repeats} episodes of a {dataset}" if writes.dataset else f"{len(files)} recordings"
        held = held if episodes is None else f"{episodes} different episodes of a {dataset}"
        out.print(f"{name}: {held} in {out_dir / name}")
    shown = ", ".join(f"{k}={v:g}" for k, v in result.truth.items())
    noises = [f"{noise_mm:g} mm"] * writes.markers + [f"{math.degrees(result.joint_noise_rad):g} deg"] * writes.joints
    noise = " and ".join(noises)
    written = ", ".join(str(out_dir / truth_file(name)) for name in result.files)
    out.print(
        f"truth ({engine}): {shown}; noise {noise}, "
        + (f"jitter +-{jitter_s:g} s" if episodes is None else "one clock (no jitter)")
        + f" -> {written} and {out_dir / TRUTH_FILE}",
        highlight=False,
        soft_wrap=True,
    )
