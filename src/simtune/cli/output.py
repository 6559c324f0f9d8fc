"""What the commands print: the two consoles, number formats, and the tables several commands share."""

from __future__ import annotations

import json
from pathlib import Path

from rich.console import Console
from rich.markup import escape

from simtune.console import text_table
from simtune.errors import SimtuneError

err = Console(stderr=True)
out = Console()


def show_warning(message, category, filename, lineno, file=None, line=None) -> None:
    """``warnings.showwarning`` for the command line: one ``warning:`` line on stderr."""
    err.print(f"[yellow]warning:[/] {message}", highlight=False, soft_wrap=True)


def fmt(value: float | None) -> str:
    return "-" if value is None else f"{value:.4f}"


def fmt_g(value: float | None) -> str:
    return "-" if value is None else f"{value:.4g}"


def split(text: str) -> list[str]:
    return [part.strip() for part in text.split(",") if part.strip()]


def only_names(text: str | None) -> list[str] | None:
    """--only's parameter names (None without the option); an --only that names none is an error, never the
    whole space."""
    if text is None:
        return None
    names = split(text)
    if not names:
        raise SimtuneError(f"--only: no parameter named in {text!r}: name one or more, e.g. --only command_delay")
    return names


def print_json(payload) -> None:
    print(json.dumps(payload))


def print_uncertainty(summary: dict, short: bool, run_dir: Path) -> None:
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
        f"condition number {fmt_g(summary['condition_number'])}",
        ("parameter", "value", "95 % low", "95 % high", "active", "identifiable"),
    )
    for e in rows:
        table.add_row(
            e["name"],
            fmt_g(e["value"]),
            fmt_g(e["low"]) if e["low"] is not None else "unbounded",
            fmt_g(e["high"]) if e["high"] is not None else "unbounded",
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
