"""The ``simtune report`` command (registered in the CLI with ``app.command()(report)``): its options and its
printing; the work is :func:`simtune.api.report`."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

_RunsOption = Annotated[
    list[Path],
    typer.Argument(
        help="Run folders (made by `simtune tune`) or folders holding run folders at any depth "
        "(a grid); every run.sqlite below them is read.",
        show_default=False,
    ),
]

_OutOption = Annotated[
    Path,
    typer.Option(
        "--out",
        "-o",
        help="Report folder to write: index.html, figures/ (PNG, SVG), tables/ (CSV, Markdown), dr_ranges.yaml, "
        "and .simtune-report.json listing them. A new or empty folder, or one an earlier report made: only the "
        "files that report listed are replaced or removed, any other file is left alone; a folder with other "
        "files and no such list is refused.",
        show_default=False,
    ),
]

_PublishedSimsOption = Annotated[
    Path | None,
    typer.Option(
        "--published-sims",
        help="Folder of published simulations `<task>_<Engine>.csv` (e.g. "
        "qrg2019/published_sims), scored with simtune's fitness next to the engines' generic fitness.",
    ),
]

_Figure4ParameterOption = Annotated[
    str,
    typer.Option(
        "--figure4-parameter",
        help="The parameter of the paper's Figure 4: its tuned values, raw, per experiment and engine.",
    ),
]

_ProjectOption = Annotated[
    Path | None,
    typer.Option(
        "--project",
        help="Read the runs' tasks from this project folder (docs/task-files.md) instead of the one each "
        "run names (for a project moved since); default: each run's own, the bundled MICO project for runs "
        "made without --project.",
    ),
]

_ReferenceOption = Annotated[
    str | None,
    typer.Option(
        "--reference",
        help="Re-score every run against aligned (the repeats on one clock) or mean (the paper's plain mean); "
        "default: each run against its own (runs made before the choice: mean).",
    ),
]

_RepeatsOption = Annotated[
    str | None,
    typer.Option(
        "--repeats",
        help="Re-score every run against all, the even (1st, 3rd ...) or the odd (2nd, 4th ...) repeats of each "
        "task, in sorted file order: a run tuned on the even ones scored on the held-out odd ones; default: each "
        "run against its own (runs made before the choice: all).",
    ),
]

_QuietOption = Annotated[bool, typer.Option("--quiet", "-q", help="No progress bar.")]


def report(
    runs: _RunsOption,
    out: _OutOption,
    published_sims: _PublishedSimsOption = None,
    figure4_parameter: _Figure4ParameterOption = "timestep",
    project: _ProjectOption = None,
    reference: _ReferenceOption = None,
    repeats: _RepeatsOption = None,
    quiet: _QuietOption = False,
) -> None:
    """Write an HTML report of tuning runs: fitness tables, convergence, parameters, trajectories.

    Runs are grouped by engine, tasks and parameter space; runs that
    differ only in their seed are repeats.  An unfinished or unreadable
    run folder is named in a warning and left out.  index.html is
    self-contained (figures embedded) and opens offline; see docs/report.md.

    The report never deletes or overwrites a file it did not write: it is
    drawn completely before --out is touched (a bad input leaves an earlier
    report there as it was), and into a folder that holds files it refuses
    unless an earlier report made it.
    """
    from rich.console import Console

    from simtune import api

    index = api.report(
        runs,
        out,
        published_sims,
        show_progress=not quiet,
        figure4_parameter=figure4_parameter,
        project=project,
        reference=reference,
        repeats=repeats,
    )
    Console().print(f"report: {index}", highlight=False, soft_wrap=True)
