"""``simtune report``: tables, figures and domain-randomisation ranges from finished tuning runs.

:func:`make_report` reads run folders (or folders of them), groups the runs by
engine x tasks x parameter space (repeats = seeds), and writes a
self-contained ``index.html`` with every figure also as PNG and SVG, every
table also as CSV and Markdown, and ``dr_ranges.yaml``; ``.simtune-report.json`` lists them, so that
a later report into the folder replaces only those (:mod:`simtune.report.folder`).  See docs/report.md.

matplotlib and the engines are imported only when a report is made, so that
importing the command costs the CLI nothing.
"""

from __future__ import annotations

from pathlib import Path


def make_report(
    paths,
    out,
    published_sims=None,
    *,
    show_progress: bool = True,
    figure4_parameter: str = "timestep",
    project: Path | str | None = None,
    reference: str | None = None,
    repeats: str | None = None,
) -> Path:
    """Write the report for the runs under ``paths`` into folder ``out``; return its ``index.html``.

    ``paths``: run folders (holding run.sqlite) or folders searched recursively
    for them.  ``published_sims``: optional folder of ``<task>_<Engine>.csv``
    published simulations to score next to the engines' generic fitness.
    Unfinished or unreadable runs are skipped with a
    :class:`simtune.report.builder.ReportWarning` naming them.  ``figure4_parameter``:
    the parameter whose tuned values the paper's Figure 4 shows.  ``project``: the project folder to
    read the runs' tasks from (default: the one each run names, else the bundled MICO project).  ``reference``:
    re-score every run against ``aligned`` or ``mean`` (default: each run against its own).  ``repeats``: of the
    ``all``, ``even`` or ``odd`` repeats of each task (default: each run's own).
    """
    from simtune.report.builder import make_report as _make

    return _make(
        paths,
        out,
        published_sims,
        show_progress=show_progress,
        figure4_parameter=figure4_parameter,
        project=project,
        reference=reference,
        repeats=repeats,
    )


__all__ = ["make_report"]
