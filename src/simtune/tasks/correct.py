"""A task file corrected to the targets the robot ran: ``simtune check --task T --write-task FILE``.

The check measures where the real arm rested after each phase and, where that lies far from where the
phase's targets put it, proposes targets that put it there (:func:`simtune.check.task.propose_targets`).  This module
writes the task file again with those targets: the file's own text, line for line, with each corrected phase's
``targets_deg`` replaced, its former targets kept as ``published_targets_deg`` (docs/task-files.md, "Corrected
targets") and the evidence in a comment.  It edits the text rather than writing the parsed task back so that
the user's comments, order and spelling stay; only TOML files whose schedule is ``[[phases]]`` can be edited so.
"""

from __future__ import annotations

import os
import re
import tomllib
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path

from simtune.errors import SimtuneError

_PHASES = re.compile(r"^\s*\[\[\s*phases\s*\]\]\s*(#.*)?$")
_TABLE = re.compile(r"^\s*\[")
_TARGETS = re.compile(r"^(\s*)targets_deg\s*=\s*(\[[^\]]*\])\s*(#.*)?$")
_COMMENT = re.compile(r"^\s*#")
_PUBLISHED = re.compile(r"^\s*published_targets_deg\s*=")


@dataclass(frozen=True)
class Correction:
    """One phase's new targets and why: ``evidence`` is said in the comment above them."""

    targets_deg: tuple[float, ...]
    evidence: str


def _numbers(values) -> str:
    return "[" + ", ".join(f"{v:g}" for v in values) + "]"


def _no_phase_tables(text: str, source: Path) -> SimtuneError:
    """The error for a task file without ``[[phases]]`` tables: its phases an inline array (``phases = [{...}]``,
    which the text cannot be edited line for line in), or a schedule that is data."""
    try:
        inline = isinstance(tomllib.loads(text).get("phases"), list)
    except tomllib.TOMLDecodeError:
        inline = False
    if inline:
        return SimtuneError(
            f"{source}: its phases are an inline array (`phases = [{{...}}, ...]`); --write-task corrects only "
            "[[phases]] tables: write each phase as a [[phases]] table, or edit its targets_deg by hand"
        )
    return SimtuneError(f"{source}: no [[phases]] tables to correct (a schedule_csv or a LeRobot schedule is data)")


def _published(text: str, phase: int) -> tuple | None:
    """The ``published_targets_deg`` that phase ``phase`` of the TOML ``text`` names already; None where none."""
    try:
        phases = tomllib.loads(text).get("phases")
    except tomllib.TOMLDecodeError:
        return None  # the task loaded, so this cannot be
    named = phases[phase].get("published_targets_deg") if isinstance(phases, list) and phase < len(phases) else None
    return tuple(named) if isinstance(named, list) else None


def _stale_comments(
    lines: list[str], header: int, table: range, before: list, after: tuple, published: tuple
) -> str | None:
    """Where a comment of one phase (the block of comment lines right above its ``[[phases]]`` header, and those in
    its table) names a former value of a joint the correction changes and the file no longer holds (probe 5:
    "Phase 2: joint 3 at 74 deg" kept above the 75.1 that replaced it; a value kept as the published one stays
    true): a phrase naming the values and quoting the comments; None where none does."""
    changed = {
        f"{old:g}": f"{new:g}"
        for old, new, kept in zip(before, after, published)
        if float(old) != float(new) and float(old) != float(kept)
    }
    if not changed:
        return None
    above = header
    while above > 0 and _COMMENT.match(lines[above - 1]):
        above -= 1
    end = table.stop
    if end < len(lines):  # the comments right above the next table's header are that table's
        while end > table.start and (_COMMENT.match(lines[end - 1]) or not lines[end - 1].strip()):
            end -= 1
    named, quoted = [], []
    for k in [*range(above, header), *range(table.start, end)]:
        comment = lines[k].strip().lstrip("#").strip() if _COMMENT.match(lines[k]) else ""
        values = [old for old in changed if re.search(rf"(?<![\d.]){re.escape(old)}(?![\d.])", comment)]
        if values:
            named += [v for v in values if v not in named]
            quoted.append(comment if len(comment) <= 60 else comment[:57] + "...")
    if not quoted:
        return None
    former = ", ".join(f"{old} (now {changed[old]})" for old in named)
    return f"a comment of this phase names the former {former}: " + "; ".join(f'"{q}"' for q in quoted)


def corrected_text(
    text: str,
    source: Path,
    corrections: Mapping[int, Correction],
    previous: Mapping[int, tuple],
    notes: list[str] | None = None,
) -> str:
    """``text`` (a TOML task file) with the phases of ``corrections`` (by index, from 0) given their new targets.

    A targets line's own trailing comment stays on it.  Where the file's targets differ from those the check ran
    (``previous``: ``--targets published``), the comment says both.  A comment of the phase that names a former
    value of a changed joint is flagged in the comment and in ``notes``.

    Args:
        text: the task file's text.
        source: its path (named in errors).
        corrections: phase index -> its new targets and the evidence for them.
        previous: phase index -> the targets the check ran for it [deg] (the file's own, or its published ones),
            kept as its published ones unless the phase already names published targets.
        notes: where given, one line is appended per phase whose comments name a value the correction replaced.
    Returns:
        The corrected text.
    Raises:
        SimtuneError: the file's schedule is not ``[[phases]]`` tables with one ``targets_deg = [...]`` line each.
    """
    lines = text.splitlines(keepends=True)
    starts = [i for i, line in enumerate(lines) if _PHASES.match(line)]
    if not starts:
        raise _no_phase_tables(text, source)
    ends = [*starts[1:], len(lines)]
    for i, (first, end) in enumerate(zip(starts, ends)):
        for j in range(first + 1, end):  # a phase table ends at the next table header
            if _TABLE.match(lines[j]):
                ends[i] = j
                break
    edits: dict[int, list[str]] = {}
    for phase, correction in corrections.items():
        if not 0 <= phase < len(starts):
            raise SimtuneError(f"{source}: it has {len(starts)} [[phases]] tables, not a phase {phase + 1}")
        table = range(starts[phase] + 1, ends[phase])
        found = [j for j in table if _TARGETS.match(lines[j])]
        if len(found) != 1:
            raise SimtuneError(
                f"{source}: phases[{phase}] has no single one-line `targets_deg = [...]` to correct: edit it by hand"
            )
        j = found[0]
        match = _TARGETS.match(lines[j])
        assert match is not None
        indent, own_comment = match.group(1), match.group(3)
        try:
            own = tuple(tomllib.loads(f"t = {match.group(2)}")["t"])
        except tomllib.TOMLDecodeError:
            own = tuple(previous[phase])  # the task loaded, so this cannot be
        newline = "\n" if lines[j].endswith("\n") else ""
        evidence = correction.evidence.splitlines()
        if len(own) != len(previous[phase]) or any(float(a) != float(b) for a, b in zip(own, previous[phase])):
            evidence.append(
                f"(checked with the targets {_numbers(previous[phase])}, not this file's: its targets_deg "
                f"{_numbers(own)} -> {_numbers(correction.targets_deg)})"
            )
        published = _published(text, phase) or tuple(previous[phase])  # what the file will say was published
        stale = _stale_comments(lines, starts[phase], table, list(own), correction.targets_deg, published)
        if stale:
            evidence.append(f"note: {stale}; update it")
            if notes is not None:
                notes.append(f"phases[{phase}] (phase {phase + 1}): {stale}; update it in the file written")
        replacement = [f"{indent}# {line}\n" for line in evidence]
        kept = "" if own_comment is None else f"  {own_comment}"  # the user's comment on the line stays on it
        replacement.append(f"{indent}targets_deg = {_numbers(correction.targets_deg)}{kept}{newline or chr(10)}")
        if not any(_PUBLISHED.match(lines[k]) for k in table):
            replacement.append(f"{indent}published_targets_deg = {_numbers(previous[phase])}{newline}")
        edits[j] = replacement
    return "".join(line for k, old in enumerate(lines) for line in edits.get(k, [old]))


def _before_offset(
    text: str, corrections: Mapping[int, Correction], previous: Mapping[int, tuple]
) -> tuple[dict[int, Correction], dict[int, tuple]]:
    """The proposals and previous targets as the file writes them: the check measures the targets the robot ran,
    the file's ``target_offset_deg`` added (the seed tasks' re-aim); written as they are, the offset would run twice."""
    try:
        offset = tomllib.loads(text).get("target_offset_deg")
    except tomllib.TOMLDecodeError:
        offset = None  # the task loaded, so this cannot be; corrected_text names a file it cannot edit
    if not isinstance(offset, list) or not offset:
        return dict(corrections), dict(previous)

    def less(values) -> tuple[float, ...]:
        return tuple(round(float(v) - float(d), 6) for v, d in zip(values, offset))

    note = f"(as the file writes them: its target_offset_deg {_numbers(offset)} is added when it runs)"
    return (
        {k: Correction(less(c.targets_deg), f"{c.evidence}\n{note}") for k, c in corrections.items()},
        {k: less(v) for k, v in previous.items()},
    )


def check_task_out(source: Path, out: Path) -> None:
    """Refuse, before any check runs, a ``--write-task`` file that could not be written or a task file that could not
    be corrected (probe 5: refused, or a traceback, only after the whole check, its report lost).

    Args:
        source: the task file as it is.
        out: where the corrected file would go.

    Raises:
        SimtuneError: ``out`` is ``source``, exists (a dangling link too), lies in no folder or one that cannot be
            written; ``source`` is not a TOML file of ``[[phases]]`` tables.
    """
    source, out = Path(source), Path(out)
    if out.resolve() == source.resolve():
        raise SimtuneError(f"--write-task {out}: that is the task file itself; write the corrected one beside it")
    if os.path.lexists(out):
        raise SimtuneError(f"--write-task {out}: the file exists; name a new one (simtune never writes over a file)")
    if not out.parent.is_dir():
        raise SimtuneError(f"--write-task {out}: no folder {out.parent}")
    if not os.access(out.parent, os.W_OK | os.X_OK):
        raise SimtuneError(f"--write-task {out}: the folder {out.parent} cannot be written; name a file elsewhere")
    if source.suffix.lower() != ".toml":
        raise SimtuneError(f"{source}: only TOML task files are corrected here; edit its targets_deg by hand")
    text = source.read_text(encoding="utf-8")
    if not any(_PHASES.match(line) for line in text.splitlines()):
        raise _no_phase_tables(text, source)


def write_corrected_task(
    source: Path,
    out: Path,
    corrections: Mapping[int, Correction],
    previous: Mapping[int, tuple],
    notes: list[str] | None = None,
) -> Path:
    """Write ``source`` corrected by ``corrections`` (:func:`corrected_text`) to the new file ``out``.

    Args:
        source: the task file as it is (never written).
        out: where the corrected file goes: a new file, not ``source``.
        corrections: phase index -> new targets and evidence.
        previous: phase index -> the targets the check ran for it [deg] (``source``'s, or its published ones).
        notes: where given, :func:`corrected_text`'s notes (a comment naming a replaced value) are appended.
    Returns:
        ``out``.
    Raises:
        SimtuneError: ``out`` is ``source`` or exists already, its folder does not, or ``source`` cannot be edited.
    """
    source, out = Path(source), Path(out)
    check_task_out(source, out)
    text = source.read_text(encoding="utf-8")
    corrections, previous = _before_offset(text, corrections, previous)
    text = corrected_text(text, source, corrections, previous, notes)
    try:
        with open(out, "x", encoding="utf-8") as fh:  # "x": never over a file that appeared meanwhile
            fh.write(text)
    except OSError as exc:
        raise SimtuneError(f"--write-task {out}: cannot write it ({exc.strerror or exc})") from None
    return out
