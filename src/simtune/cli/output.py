"""What the commands print: the two consoles, number formats, and the tables several commands share."""

from __future__ import annotations

import json
import textwrap
from collections.abc import Sequence
from pathlib import Path

from rich.console import Console
from rich.markup import escape
from rich.measure import Measurement

from simtune.common.console import text_table
from simtune.errors import SimtuneError

err = Console(stderr=True)
out = Console()


#: The texts of the warnings this process has printed: a command prints each once (:func:`show_warning`).
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
    share = f" ({100 * half / abs(entry['value']):.2g} %)" if entry["value"] else ""
    return f"{half:.2g}{share}"


def _rank_in_words(summary: dict) -> str:
    """What the Jacobian's rank and condition number say, in words (the rank: its singular values above
    ``RCOND`` x the largest, :func:`simtune.uncertainty.directions`)."""
    from simtune.uncertainty import RCOND  # here: the module imports the engines, and only this needs it

    rank, searched = summary["rank"], summary["searched"]
    text = f"rank {rank} of {searched}: the recordings respond to "
    if rank == searched:
        text += "the one direction" if rank == 1 else f"all {searched} independent directions"
        text += " in which the searched parameters can move"
    else:
        text += (
            f"{rank} of the {searched} independent directions in which the searched parameters can move; "
            + ("the other one changes" if searched - rank == 1 else f"the other {searched - rank} change")
            + f" the motion less than {RCOND:g} times as much as the strongest"
        )
    if summary.get("condition_number") is not None and rank > 1:
        text += (
            f". Condition number {fmt_g(summary['condition_number'])}: the strongest of the {rank} moves the "
            "motion that many times more than the weakest"
        )
    return text


def _unbounded_groups(entries: list[dict], non_smooth: set[str]) -> list[tuple[str, list[dict]]]:
    """The parameters the recordings do not pin, grouped by why (:mod:`simtune.uncertainty` decides each)."""
    loose = [e for e in entries if not e["identifiable"]]
    groups = [
        (
            "change no simulated motion of these tasks (`simtune params --task TASK` says why)",
            [e for e in loose if not e["active"]],
        ),
        (
            "make the motion jump rather than slope here (forward and backward differences disagree)",
            [e for e in loose if e["active"] and e["name"] in non_smooth],
        ),
        (
            "trade off against other parameters, or their 95 % interval is wider than their range",
            [e for e in loose if e["active"] and e["name"] not in non_smooth],
        ),
    ]
    return [(why, members) for why, members in groups if members]


def _say(text: str, indent: int = 2) -> None:
    """``text`` as written (no markup), wrapped at spaces with every line indented by ``indent``: a wrapped line
    still reads as part of its item, and a parameter name (no spaces) is never broken, however narrow the
    terminal."""
    pad = " " * indent
    lines = textwrap.wrap(
        text,
        max(out.width, 40),
        initial_indent=pad,
        subsequent_indent=pad,
        break_long_words=False,
        break_on_hyphens=False,
    )
    for line in lines:
        out.print(line, markup=False, highlight=False, soft_wrap=True)


def print_whole_table(title: str, headers: Sequence[str], rows: Sequence[Sequence[str]]) -> None:
    """A table where it fits the terminal (or the pipe's 80 columns) whole; narrower, one line per row, each cell
    named by its header: Rich would squeeze it by cutting cells short ("CubeE…", "0.00…"), and a user acts on them.

    Args:
        title: the table's title.
        headers: the column headers.
        rows: the cells of each row, as text.
    """
    table = text_table(title, headers)
    for row in rows:
        table.add_row(*row)
    if Measurement.get(out, out.options.update(max_width=10_000), table).maximum <= out.width:
        out.print(table)
        return
    out.print(escape(title), highlight=False)
    for row in rows:  # wrapped between words only: a file name stays whole
        cells = [row[0], *(f"{header} {cell}" for header, cell in zip(headers[1:], row[1:]))]
        out.print("  " + escape("; ".join(cells)), highlight=False)


def _cut(entry: dict) -> str:
    """`` (cut at its range)`` where an interval reached past the parameter's range (a damping below 0)."""
    ends = entry.get("cut") or ()
    if not ends:
        return ""
    which = " and ".join("lower" if end == "low" else "upper" for end in ends)
    return f" (cut at its range's {which} end)"


def print_uncertainty(summary: dict, short: bool, run_dir: Path) -> None:
    """How well the recordings pin the parameters at a run's best point, for someone reading it the first time.

    First the identified parameters with their 95 % intervals and how tight they are (a table where it fits the
    terminal whole, else one line each: a name is never cut short), then the Jacobian's rank in words, then the
    unbounded ones in one group per reason, then the most correlated pairs.

    Args:
        summary: :func:`simtune.uncertainty.uncertainty`'s summary as a run stores it (``error`` where it failed).
        short: after ``tune``: unbounded parameters by name only, and a pointer to ``simtune uncertainty``;
            otherwise each with its value.
        run_dir: the run's folder, for that pointer.
    """
    if summary.get("error"):
        _say(f"uncertainty not computed: {summary['error']}")
        return
    entries = summary["parameters"]
    identified = [e for e in entries if e["identifiable"]]
    searched = summary["searched"]
    draws = int(summary.get("bootstrap_draws") or 0)
    method = f"Gauss-Newton and {draws} bootstrap draws of the repeats" if draws else "Gauss-Newton"
    _say(f"uncertainty at the best point ({method}, 95 % intervals):", 0)
    if identified:
        _say(f"identified: {len(identified)} of the {searched} searched parameters")
        table = text_table("", ("parameter", "value", "95 % interval", "+- (of value)"))
        cells = [
            (e["name"], fmt_g(e["value"]), f"{fmt_g(e['low'])} to {fmt_g(e['high'])}{_cut(e)}", _tightness(e))
            for e in identified
        ]
        for row in cells:
            table.add_row(*row)
        # the table only where it fits whole: Rich squeezes a table wider than the terminal by cutting its cells
        # short ("max_torque_join…") or folding them; narrower, one line each, broken only between words
        if Measurement.get(out, out.options.update(max_width=10_000), table).maximum <= out.width:
            out.print(table)
        else:
            for name, value, interval, tightness in cells:
                _say(f"{name} = {value}, 95 % {interval}, +-{tightness}", 4)
    else:
        _say(f"identified: none of the {searched} searched parameters (why: below)")
    for e in identified:
        if e.get("remaining_step") is not None:
            _say(
                f"{e['name']}: the fit has not converged in this parameter: the data's minimum lies about "
                f"{e['remaining_step']:+.2g} away (Gauss-Newton's step left at the best point); its interval is "
                "widened to hold it, and a longer tune (a larger --max-evaluations) would move it there",
                4,
            )
    _say(_rank_in_words(summary))
    # with draws, a non-smooth parameter has the draws' interval: one still unbounded is too wide
    non_smooth = set() if draws else set(summary.get("non_smooth") or ())
    groups = _unbounded_groups(entries, non_smooth)
    if groups:
        _say(f"not identified ({sum(len(m) for _, m in groups)}, intervals unbounded), by reason:")
    for why, members in groups:
        _say(f"{len(members)} {why}:", 4)
        _say(
            ", ".join(
                e["name"] if short or e["value"] is None else f"{e['name']} = {fmt_g(e['value'])}" for e in members
            ),
            6,
        )
    pairs = summary.get("correlated_pairs") or []
    if pairs:
        listed = ", ".join(f"{p['a']} ~ {p['b']} ({p['correlation']:+.2f})" for p in pairs[:3])
        _say(f"most correlated (one can partly make up for the other): {listed}")
    if any(e["active"] and not e["identifiable"] and e["name"] in non_smooth for e in entries):
        _say(f"`simtune uncertainty {run_dir} --bootstrap 30` gives the non-smooth ones intervals from refits", 0)
    if short:
        _say(f"`simtune uncertainty {run_dir}` recomputes it with every value (--json for scripts)")


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
        # the delay each task ran with [s] (None: none given, so 0; a task whose clock was aligned: the estimate)
        "command_delay_s": command_delays(score),
    }
    if score.repeats != "all":
        payload["repeats"] = score.repeats
        payload["repeat_files"] = score.repeat_files
    return payload


def command_delays(score) -> dict[str, float | None]:
    """Per task, the command delay it ran with [s] (its clock's estimate where aligned; None where none is given)."""
    from simtune.engines.controller import given_delay

    aligned = {e.task: e.delay_s for e in score.alignments}
    return {task: aligned.get(task, given_delay(task, score.x or {})) for task in score.parts}


def delay_lines(score) -> list[str]:
    """Which command delay each task not aligned ran with, where parameters were given: a held-out task scored with
    a parameter file that times no clock of it runs at delay 0 (probe 5: a generic score, without a word)."""
    from simtune.engines.controller import given_delay
    from simtune.params.kinds import TASK_DELAY_PREFIX

    if not score.x:
        return []
    aligned = {e.task for e in score.alignments}
    lines = []
    for task in score.parts:
        if task in aligned:
            continue
        delay = given_delay(task, score.x)
        if delay is None:
            lines.append(
                f"command delay: {task} ran at 0 s, the parameters give it none; if its recordings start at another "
                f"time, --align-clock estimates its delay from them"
            )
        else:
            lines.append(f"command delay: {task} ran at {delay:.3g} s, the parameters' own")
    # a run tuned on several tasks times each one's recordings with its own delay: a clock of those recordings, not
    # a property of the robot, so it times no other task (its shared parameters apply to every task)
    others = [n for n in score.x if n.startswith(TASK_DELAY_PREFIX) and n[len(TASK_DELAY_PREFIX) :] not in score.parts]
    if others:
        lines.append(
            f"not applied: {', '.join(others)} (each the clock of its own task's recordings, not of "
            f"{', '.join(score.parts)}'s); every other parameter given applies"
        )
    return lines


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
    for line in delay_lines(score):
        out.print(line, highlight=False, soft_wrap=True)
    for e in score.alignments:
        onset = "" if e.recorded_onset_s is None else f" (motion onset {fmt_g(e.recorded_onset_s)} s)"
        out.print(
            f"clock aligned: {e.task}'s command delay {e.delay_s:.2f} s, estimated from its recordings{onset} with "
            f"the physics held fixed; without alignment the fitness is {score.fitness_unaligned:.4f} "
            "(--no-align-clock)"
        )
    if score.repeats != "all":
        for task, files in score.repeat_files.items():
            out.print(
                f"repeats {score.repeats}: {task} scored against {len(files)} repeats: {', '.join(files)}",
                highlight=False,
                soft_wrap=True,
            )


def _listed_names(names: Sequence[str], most: int = 4) -> str:
    """Names joined by commas, the first ``most`` of them and how many more."""
    shown = ", ".join(names[:most])
    return shown + (f" and {len(names) - most} more" if len(names) > most else "")


def print_validation(validation: dict | None) -> None:
    """The held-out tasks' line (``--validate``): their fitness per task against the tuned tasks'; nothing without
    them."""
    if validation is None:
        return
    tasks = validation.get("tasks") or []
    if "error" in validation:
        _say(f"held out {len(tasks)} task(s) ({_listed_names(tasks)}): not scored: {validation['error']}")
        return
    ratio = validation.get("ratio")
    aligned = validation.get("clock_aligned") or {}
    clock = f"; the clocks of {_listed_names(list(aligned))} aligned first (no tuned delay)" if aligned else ""
    _say(
        f"held out {len(tasks)} task(s) ({_listed_names(tasks)}): fitness {fmt(validation['fitness'])} per task "
        f"against {fmt(validation['fitted'])} per tuned task" + ("" if ratio is None else f" ({ratio:.2f} x)") + clock
    )


def print_verdict(verdict: dict | None) -> None:
    """After a tune: how close to the data's floor, and which parameters moved far and whether they are pinned."""
    if not verdict:
        return
    if verdict.get("floor"):
        out.print(
            f"  verdict: {verdict['over_floor']:.1f} x the recordings' floor {verdict['floor']:.4f} (the aligned mean "
            "against each repeat: what a simulation as good as the arm's own repeats scores)",
            highlight=False,
            soft_wrap=True,
        )
    for m in verdict.get("moved", [])[:6]:
        pinned = {True: "pinned by the recordings", False: "not pinned: the recordings allow a wide range"}
        out.print(
            f"    {m['name']} {m['generic']:.4g} -> {m['tuned']:.4g} {m['unit']} ({100 * m['share']:.0f} % of its "
            f"range from generic; {pinned.get(m['pinned'], 'uncertainty not computed')})",
            highlight=False,
            soft_wrap=True,
        )
