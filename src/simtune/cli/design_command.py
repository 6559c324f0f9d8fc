"""``simtune design``: the motion a lab should record (docs/design.md)."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer
from rich.markup import escape

from simtune.cli.options import EngineOpt, JsonOpt, OnlyOpt, ProjectOpt, SpaceOpt, WorkersOpt, out_option, seed_option
from simtune.cli.output import err, fmt_g, only_names, out, print_json, print_whole_table
from simtune.run_config import DEFAULT_SPACE

DesignOutOpt = Annotated[
    Path,
    out_option("The task file to write (*.toml); its .csv, .trajectory.yaml and .design.json are written beside it."),
]
DurationOpt = Annotated[float, typer.Option("--duration", help="The designed task's length [s].", min=1.0)]
DesignTaskOpt = Annotated[
    str | None,
    typer.Option(
        "--task",
        "-t",
        help="The project's task(s) the design is set beside (comma-separated); the first's robot, start pose, gain "
        "and marker the design keeps. Default: the project's first task.",
    ),
]
SignalsOpt = Annotated[
    str, typer.Option("--signals", help="What the lab records: marker, joints, or marker,joints (the default).")
]
RepeatsOpt = Annotated[int, typer.Option("--repeats", min=1, max=1000, help="Repeats the lab records of it.")]


def design(
    engine: EngineOpt = "mujoco",
    project: ProjectOpt = None,
    task: DesignTaskOpt = None,
    space: SpaceOpt = DEFAULT_SPACE,
    only: OnlyOpt = None,
    duration: DurationOpt = 30.0,
    signals: SignalsOpt = "marker,joints",
    repeats: RepeatsOpt = 10,
    workers: WorkersOpt = 2,
    seed: Annotated[int, seed_option("Seed of the library's every-joint excursions.")] = 0,
    out_file: DesignOutOpt = Path("designed.toml"),
    as_json: JsonOpt = False,
) -> None:
    """Design the motion to record: a task whose recordings identify the space's (or --only's) parameters.

    From the task's start pose, steps of single joints (small, below the velocity clamp; large, at it) and of all of
    them at once, each held until the arm rests, are chained to fill --duration so that the smallest, over a few
    points of the parameters' ranges, log det of the noise-weighted J^T J of the rollout residuals is largest. The
    chain is checked in simulation at every point: within the joint and velocity limits, clear of the floor and of
    the arm itself, at rest at start and end. Prints each parameter's predicted 95 % interval width on the design
    beside the project's current task, and which combinations stay unidentifiable and why.

    Example: simtune design --project so101 --engine mujoco --space drivetrain --duration 40 --out so101/tasks/id.toml
    """
    from rich.progress import BarColumn, Progress, TextColumn, TimeElapsedColumn

    from simtune import api

    columns = (TextColumn("[bold]design[/] {task.description}"), BarColumn(), TimeElapsedColumn())
    with Progress(*columns, console=err, disable=as_json, transient=True) as bar:
        job = bar.add_task("", total=None)

        def progress(what: str, done: int, total: int) -> None:
            bar.update(job, description=what, completed=done, total=total)

        summary = api.design(
            engine,
            out=out_file,
            project=project,
            task=task,
            space=space,
            only=only_names(only),
            duration=duration,
            signals=signals,
            repeats=repeats,
            workers=workers,
            seed=seed,
            on_progress=progress,
        )
    if as_json:
        print_json(summary)
        return
    print_design(summary)


def _width(value: float | None, share: float | None, identified: bool | None) -> str:
    if value is None:
        return "none (not identified)"
    mark = "" if identified else " (wider than its range)"
    return f"{fmt_g(value)} ({share:.1%}){mark}" if share is not None else fmt_g(value)


def print_design(summary: dict) -> None:
    """The design's table (each parameter's predicted 95 % interval widths), its combinations and its files."""
    current = ", ".join(summary["current_tasks"]) or "-"
    rows = [
        [
            p["name"],
            f"{fmt_g(p['range'][0])} - {fmt_g(p['range'][1])}",
            _width(p["predicted_width"], p["predicted_share"], p["identified"]),
            _width(p["current_width"], p["current_share"], p["current_identified"]),
        ]
        for p in summary["parameters"]
    ]
    print_whole_table(  # whole or one line a row: a parameter's name is never cut short
        f"design {summary['task']}: {summary['duration_s']:g} s, {len(summary['parameters'])} parameters of "
        f"{summary['space']!r} in {summary['engine']}",
        ["parameter", "range", "95 % width, designed (share of range)", f"95 % width, {current}"],
        rows,
    )
    criterion = summary["criterion"]
    now = criterion["current_log_det"]
    out.print(
        f"criterion {criterion['rule']}: {criterion['value']:.4g}"
        + ("" if now is None else f" (the design's own {criterion['design_log_det']:.4g}; {current}: {now:.4g})"),
        highlight=False,
        soft_wrap=True,
    )
    weak = (summary.get("identifiability") or {}).get("directions") or []
    if not weak:
        out.print("the design tells every designed parameter apart", highlight=False)
    for direction in weak:
        out.print(
            f"  not told apart: {escape(direction['combination'])} - {escape(direction['separate_by'])}",
            highlight=False,
            soft_wrap=True,
        )
    out.print(
        f"velocity clamp {fmt_g(summary['velocity_clamp_deg_s'])} deg/s (part of the design: run the controller at it);"
        f" {len(summary['excursions'])} excursions chosen of {summary['library_size']}; checked at "
        f"{len(summary['checks'])} points; {summary['wall_s']:g} s",
        highlight=False,
        soft_wrap=True,
    )
    files = summary["files"]
    out.print(
        f"wrote {escape(files['task'])} (and {escape(Path(files['csv']).name)}, "
        f"{escape(Path(files['trajectory']).name)}, {escape(Path(files['summary']).name)})",
        highlight=False,
        soft_wrap=True,
    )
