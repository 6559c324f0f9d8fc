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


def evaluation_json(engine: str, task: str, score) -> dict:
    """``evaluate --json``: one object; with a selection of repeats other than all, ``repeats`` and, per task, the
    files of the repeats that built its reference (``repeat_files``)."""
    payload = {
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
        "reference": score.reference,
    }
    if score.repeats != "all":
        payload["repeats"] = score.repeats
        payload["repeat_files"] = score.repeat_files
    return payload


def print_evaluation(score, title: str) -> None:
    """``evaluate``'s table: per task (and all of them) the fitness and its parts; the generic fitness, each
    clock aligned, and the repeats scored against when not all of them."""
    # the joint column only where joint logs were scored: motion-capture tables stay as they were
    joint_col = score.joint_error is not None
    if score.repeats != "all":
        title += f", repeats {score.repeats}"
    table = text_table(
        title,
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
        joint = [fmt(part.joint_error)] if joint_col else []
        table.add_row(name, fmt(part.fitness), fmt(part.wrist_error), fmt(part.object_error), *joint, part.message)
    out.print(table)
    if score.x:
        out.print(f"generic fitness: {score.generic_fitness:.4f}")
    for e in score.alignments:
        out.print(
            f"clock aligned: {e.task}'s command delay {e.delay_s:.2f} s, estimated from its recordings (motion onset "
            f"{fmt_g(e.recorded_onset_s)} s) with the physics held fixed; without alignment the fitness is "
            f"{score.fitness_unaligned:.4f} (--no-align-clock)"
        )
    if score.repeats != "all":
        for task, files in score.repeat_files.items():
            out.print(
                f"repeats {score.repeats}: {task} scored against {len(files)} repeats: {', '.join(files)}",
                highlight=False,
                soft_wrap=True,
            )
