"""``simtune export``: tuned runs as each engine's own model files, through :mod:`simtune.api`."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Annotated

import typer
from rich.markup import escape

from simtune.cli.options import JsonOpt, out_option
from simtune.cli.output import err, out

RunDirsArg = Annotated[
    list[Path],
    typer.Argument(
        help="A finished run folder; with --all-engines, run folders or folders holding them (a grid).",
        show_default=False,
    ),
]
ExportOutOpt = Annotated[
    Path,
    out_option("Folder to write (with --all-engines: one sub-folder per run).", checked=False, show_default=False),
]
ExportEngineOpt = Annotated[
    str | None,
    typer.Option("--engine", "-e", help="The run's engine (checked against it); default: the run's."),
]
AllEnginesOpt = Annotated[
    bool,
    typer.Option(
        "--all-engines", help="Export every finished run found under RUN_DIRS, each as its own engine's files."
    ),
]
DrOpt = Annotated[
    bool, typer.Option("--dr", help="Also write dr_ranges.yaml: the ranges the exported runs' tuned values span.")
]
ForceOpt = Annotated[bool, typer.Option("--force", help="Replace a previous export in a non-empty --out folder.")]


def export(
    run_dirs: RunDirsArg,
    out_dir: ExportOutOpt,
    engine: ExportEngineOpt = None,
    all_engines: AllEnginesOpt = False,
    dr: DrOpt = False,
    force: ForceOpt = False,
    as_json: JsonOpt = False,
) -> None:
    """Export a tuned run as the engine's own model files, with provenance: MJCF, URDF + sidecar, SDFormat ...

    MuJoCo: `scene_<task>.xml` (an MJCF robot: `scene_<task>.mjb`); PyBullet and DART: URDF files, a JSON sidecar and a
    load script; Drake: URDF and SDFormat with Drake's tags, a sidecar and a load
    script; ODE: the sidecar only (ODE has no model file). Every export has
    controller.yaml (how the run drove the model) and provenance.json (run,
    versions, data files with SHA-256, fitness, command line). See docs/parameters.md.

    Example: simtune export runs/cube --out exported/cube --dr
    """
    from simtune import api

    results, skipped = api.export(run_dirs, out_dir, engine=engine, all_engines=all_engines, dr=dr, force=force)
    for path, why in skipped:
        err.print(f"[yellow]warning:[/] skipped {escape(str(path))}: {escape(why)}", soft_wrap=True)
    if as_json:
        print(
            json.dumps([{"run": str(r.run), "engine": r.engine, "out": str(r.out), "files": r.files} for r in results])
        )
        return
    for r in results:
        out.print(f"{r.engine}: {r.run} -> {r.out} ({', '.join(r.files)})", highlight=False, soft_wrap=True)
