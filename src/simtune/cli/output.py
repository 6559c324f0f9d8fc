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


#: The warnings this process has printed: each is printed once per command.
_shown: set[str] = set()


def show_warning(message, category, filename, lineno, file=None, line=None) -> None:
    """``warnings.showwarning`` for the command line: one ``warning:`` line on stderr, once per distinct text.

    Python's own once-per-place rule does not hold across loads: it forgets what it has shown whenever the
    warning filters change, and every ``catch_warnings`` block changes them (the C3D reader opens one per file,
    MuJoCo's scene builder one per model), so a command that loads the recordings more than once (``compare``
    and ``transfer`` load them per run) would print the same data warning again whenever such a block ran in
    between.  Here the text decides.

    Args:
        message: the warning (its text is printed, markup-escaped).
        category, filename, lineno, file, line: as :func:`warnings.showwarning` passes them; unused.
    """
    text = str(message)
    if text in _shown:
        return
    _shown.add(text)
    err.print(f"[yellow]warning:[/] {escape(text)}", highlight=False, soft_wrap=True)


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


def _tightness(entry: dict) -> str:
    """An identified parameter's 95 % half-width, and as a share of its value where the value is not zero."""
    half = (entry["high"] - entry["low"]) / 2
    share = f" ({100 * half / abs(entry['value']):.2g} % of the value)" if entry["value"] else ""
    return f"+-{half:.2g}{share}"


def _rank_in_words(summary: dict) -> str:
    """What the Jacobian's rank and condition number say, in words (the rank: its singular values above
    ``RCOND`` x the largest, :func:`simtune.uncertainty.directions`)."""
    from simtune.uncertainty import RCOND  # here: the module imports the engines, and only this needs it

    rank, searched = summary["rank"], summary["searched"]
    text = (
        f"the recordings respond to {rank} of the {searched} independent directions in which the searched "
        "parameters can move together (rank of the Jacobian)"
    )
    if rank < searched:
        text += (
            f"; along the other {searched - rank} the simulated motion changes by less than {RCOND:g} of its "
            "largest response"
        )
    if summary.get("condition_number") is not None and rank > 1:
        text += (
            f"; the strongest of the {rank} moves it {fmt_g(summary['condition_number'])} times more than the "
            "weakest (condition number)"
        )
    return text


def _unbounded_groups(entries: list[dict], non_smooth: set[str]) -> list[tuple[str, list[dict]]]:
    """The parameters the recordings do not pin, grouped by why (:mod:`simtune.uncertainty` decides each)."""
    loose = [e for e in entries if not e["identifiable"]]
    groups = [
        (
            "change no simulated motion of these tasks, so no recording can pin them "
            "(`simtune params --task TASK` says why)",
            [e for e in loose if not e["active"]],
        ),
        (
            "make the motion jump rather than slope at this point (forward and backward differences disagree), "
            "so no local slope bounds them",
            [e for e in loose if e["active"] and e["name"] in non_smooth],
        ),
        (
            "are not pinned on their own: they trade off against other parameters, or their 95 % interval is "
            "wider than their range",
            [e for e in loose if e["active"] and e["name"] not in non_smooth],
        ),
    ]
    return [(why, members) for why, members in groups if members]


def print_uncertainty(summary: dict, short: bool, run_dir: Path) -> None:
    """How well the recordings pin the parameters at a run's best point, for someone reading it the first time.

    First the identified parameters with their 95 % intervals and how tight they are (a table whose names are
    never cut: they fold at a narrow terminal), then the Jacobian's rank in words, then the unbounded ones in one
    line per reason, then the most correlated pairs.

    Args:
        summary: :func:`simtune.uncertainty.uncertainty`'s summary as a run stores it (``error`` where it failed).
        short: after ``tune``: unbounded parameters by name only, and a pointer to ``simtune uncertainty``;
            otherwise each with its value.
        run_dir: the run's folder, for that pointer.
    """
    if summary.get("error"):
        out.print(f"  uncertainty not computed: {escape(summary['error'])}")
        return
    entries = summary["parameters"]
    identified = [e for e in entries if e["identifiable"]]
    searched = summary["searched"]
    out.print("uncertainty at the best point (Gauss-Newton, 95 % intervals):", highlight=False)
    if identified:
        out.print(f"  identified: {len(identified)} of the {searched} searched parameters", highlight=False)
        table = text_table("", ("parameter", "value", "95 % interval", "tightness"))
        # a name is what the reader acts on: it keeps its whole width, and folds rather than being cut
        table.columns[0].min_width = min(max(len(e["name"]) for e in identified), max(out.width // 2, 12))
        table.columns[0].overflow = "fold"
        for e in identified:
            table.add_row(e["name"], fmt_g(e["value"]), f"{fmt_g(e['low'])} to {fmt_g(e['high'])}", _tightness(e))
        out.print(table)
    else:
        out.print(f"  identified: none of the {searched} searched parameters (why: below)", highlight=False)
    out.print(f"  {escape(_rank_in_words(summary))}", highlight=False)
    for why, members in _unbounded_groups(entries, set(summary.get("non_smooth") or ())):
        names = (e["name"] if short or e["value"] is None else f"{e['name']} {fmt_g(e['value'])}" for e in members)
        out.print(f"  unbounded, {len(members)} that {escape(why)}: {', '.join(names)}", highlight=False)
    pairs = summary.get("correlated_pairs") or []
    if pairs:
        listed = ", ".join(f"{p['a']} ~ {p['b']} ({p['correlation']:+.2f})" for p in pairs[:3])
        out.print(f"  most correlated (one can partly make up for the other): {listed}", highlight=False)
    if short:
        out.print(
            f"  `simtune uncertainty {escape(str(run_dir))}` recomputes it with every value (--json for scripts)",
            highlight=False,
        )


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
