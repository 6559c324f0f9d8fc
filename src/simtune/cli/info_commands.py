"""What simtune offers: ``engines``, ``tasks`` (with --contact: simulated), ``params``, and the ``demo``."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Annotated

import typer
from rich.markup import escape

from simtune.cli.options import ProjectOpt, out_option, seconds
from simtune.cli.output import err, out
from simtune.common.console import text_table
from simtune.errors import SimtuneError


def demo(
    out_dir: Annotated[Path, out_option("Run folder for the demo's tuning run.")] = Path("runs/demo"),
    workers: Annotated[int, typer.Option("--workers", "-w", min=1)] = 2,
    max_seconds: Annotated[float, typer.Option(help="Time budget of the tuning run [s].", callback=seconds)] = 120.0,
) -> None:
    """Tune MuJoCo to the shipped reference recording and print generic vs tuned error (about a minute)."""
    from simtune import api

    api.demo(out_dir, workers=workers, max_seconds=max_seconds, console=out)


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


ContactOpt = Annotated[
    bool,
    typer.Option(
        "--contact",
        help="Simulate each seed task with an object (generic parameters) and report whether and when "
        "the arm first touches the object, and how far the object moves.",
    ),
]
ContactEngineOpt = Annotated[
    str | None,
    typer.Option("--engine", "-e", help="With --contact: this engine only (default: every installed engine)."),
]
ContactTaskOpt = Annotated[
    str | None,
    typer.Option("--task", "-t", help="With --contact: these tasks (default: the seed tasks with an object)."),
]
FigureOpt = Annotated[
    Path | None,
    typer.Option(help="With --contact: write the arm at first contact to `FIGURE/contact-<engine>.png` (and .svg)."),
]
ContactJsonOpt = Annotated[
    bool, typer.Option("--json", help="With --contact: one JSON object per line, one per engine and task.")
]


def tasks(
    contact: ContactOpt = False,
    engine: ContactEngineOpt = None,
    task: ContactTaskOpt = None,
    figure: FigureOpt = None,
    as_json: ContactJsonOpt = False,
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


def _contact_tasks(task: str | None, project) -> list:
    """The tasks --contact simulates: those named, or the bundled project's seed tasks (every task with an
    object of another project)."""
    if task is None:
        chosen = [t for t in project.tasks.values() if t.object is not None]
        if any(t.name.startswith("seed-") for t in chosen):
            chosen = [t for t in chosen if t.name.startswith("seed-")]
        return chosen
    chosen = project.parse_tasks(task)
    for t in chosen:
        if t.object is None:
            raise SimtuneError(f"task {t.name!r} has no object: --contact needs tasks with one")
    return chosen


def _contact_engines(engine: str | None) -> list[str]:
    """The engines --contact simulates: the one named, or every installed one (the others noted)."""
    import importlib

    from simtune.engines import ENGINES, engine_class

    if engine is not None:
        engine_class(engine)  # unknown or not installed: one line, before any simulation
        return [engine]
    names = [
        name
        for name, entry in ENGINES.items()
        if getattr(importlib.import_module(entry.module), entry.cls).version() != "not installed"
    ]
    skipped = [name for name in ENGINES if name not in names]
    if skipped:
        err.print(f"[yellow]note:[/] not installed, skipped: {', '.join(skipped)}")
    return names


def _tasks_contact(engine: str | None, task: str | None, figure: Path | None, as_json: bool, project) -> None:
    from simtune.engines import make_engine
    from simtune.engines.contact import probe_contact

    chosen = _contact_tasks(task, project)
    for name in _contact_engines(engine):
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
            _print_contact(name, chosen, probes)
        if figure is not None:
            from simtune.report.contact import contact_figure
            from simtune.report.figures import save

            figure.mkdir(parents=True, exist_ok=True)
            save(contact_figure(probes, {t.name: t for t in chosen}), figure, f"contact-{name}")
            if not as_json:
                out.print(f"figure: {figure / f'contact-{name}.png'}")


def _print_contact(engine: str, chosen: list, probes: list) -> None:
    table = text_table(
        f"contact in {engine} (generic parameters)",
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


ParamsTaskOpt = Annotated[
    str | None,
    typer.Option(
        "--task",
        "-t",
        help="Also say which parameters change a rollout of these tasks (comma-separated; measured by a probe "
        "of the engine, default mujoco, and cached): an active column and the reason for each inactive one.",
    ),
]


def params(
    space: Annotated[
        str, typer.Option("--space", "-s", help="shared, individual, extended or calibrated.")
    ] = "extended",
    engine: Annotated[str | None, typer.Option("--engine", "-e", help="Only what this engine supports.")] = None,
    project: ProjectOpt = None,
    task: ParamsTaskOpt = None,
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
            table.add_row(p.name, *p.shown_bounds(), p.unit, p.description)
        else:
            why = inactive.get(p.name)
            table.add_row(p.name, *p.shown_bounds(), p.unit, "no" if why else "yes", why or p.description)
    out.print(table)
