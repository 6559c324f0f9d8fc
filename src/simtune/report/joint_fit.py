"""The report's joint fit: each task's part of a multi-task run beside its floor and its alone-best, and the
tables of ``simtune generalise`` studies found with the runs.

A run tuned on several tasks together (``--task single,cube``) fits each of them with one parameter set.  Whether
that set is one of the robot or a compromise between tasks shows in each task's part of the fit against the best
a simulator does for that task alone (its *alone-best*): ``part / alone-best`` is the joint-fit penalty, 1 where
one simulator fits every task as well as each alone (issue 67).  The alone-best is looked for

* among the report's runs: a one-task run of that task with the same engine, space, data, reference, repeats,
  weights, targets and project;
* beside the run: for a run at ``OUT/joint`` (``simtune generalise``'s layout), the run at ``OUT/alone/<task>``;
* in a ``generalise.json`` next to the run (or among the inputs) of the same engine, space, data and reference;

the lowest of those found.  A study's own table (:func:`study_table`) is the study's ``generalise.json`` as it is.
"""

from __future__ import annotations

import json
from collections.abc import Callable, Iterable
from dataclasses import dataclass
from pathlib import Path

from simtune.common.table import Column, Table
from simtune.fitness import RepeatFloor
from simtune.report.collect import Group, ReportedRun, Skipped, load_run
from simtune.store import STORE_FILE
from simtune.studies.generalise import ALONE_FOLDER, JOINT_FOLDER, RESULT_FILE, WITHOUT_FOLDER

Warn = Callable[[str], None]

#: what an alone-best cell says where none was found
NOT_FOUND = "none found"


@dataclass(frozen=True)
class AloneBest:
    """The lowest fitness a one-task tuning reached for a task, and where it comes from (a run's folder, or a
    ``generalise.json``)."""

    fitness: float
    source: str


@dataclass(frozen=True)
class Study:
    """A ``simtune generalise`` result file and its contents (:func:`simtune.studies.generalise.run_generalisation`)."""

    path: Path
    result: dict


def _data_key(data: str | None) -> str | None:
    return None if data is None else str(Path(data).resolve())


def _settings(run: ReportedRun) -> tuple:
    """What two runs must share for one's task part to compare with the other's: the same recordings scored the
    same way by the same engine in the same space."""
    c = run.config
    weights = tuple(sorted((c.weights or {}).items()))
    return (c.engine, c.space, _data_key(c.data), c.reference, c.repeats, weights, c.targets, c.project)


def _study_settings(run: ReportedRun) -> tuple:
    """The part of :func:`_settings` a ``generalise.json`` records."""
    c = run.config
    return (c.engine, c.space, _data_key(c.data), c.reference)


def task_part(run: ReportedRun, task: str) -> float | None:
    """The fitness of ``task``'s part of ``run``'s best evaluation (None: the run did not tune ``task``)."""
    part = run.task_score(run.best_score, task)
    if part is not None:
        return float(part["fitness"])
    return run.best_fitness if run.task_names == [task] else None


def find_studies(paths: Iterable[Path]) -> list[Path]:
    """The ``generalise.json`` files under each of ``paths``, next to each (a study's ``OUT/joint`` given: its
    ``OUT``), and two up from a study's one-task run (``OUT/alone/<task>``, ``OUT/without/<task>``).

    Args:
        paths: the folders given to the report.
    Returns:
        Each file once, in the order found.
    """
    found: list[Path] = []
    for path in map(Path, paths):
        candidates = sorted(path.rglob(RESULT_FILE)) if path.is_dir() else []
        candidates.append(path.parent / RESULT_FILE)
        if path.parent.name in (ALONE_FOLDER, WITHOUT_FOLDER):
            candidates.append(path.parent.parent / RESULT_FILE)
        for c in candidates:
            if c.is_file() and c.resolve() not in {f.resolve() for f in found}:
                found.append(c)
    return found


def load_study(path: Path) -> Study:
    """The study in ``path``, its rows checked.

    Raises:
        ValueError, KeyError, TypeError, OSError: ``path`` is not a readable ``generalise.json`` (the report names it
        in a warning and leaves it out).
    """
    result = json.loads(Path(path).read_text())
    if not isinstance(result, dict) or not isinstance(result.get("rows"), list) or not result["rows"]:
        raise ValueError("no rows")
    if not (result.get("data") is None or isinstance(result["data"], str)):
        raise TypeError(f"data: expected a folder or null, got {result['data']!r}")
    for row in result["rows"]:
        for key in ("alone", "joint", "held_out"):
            float(row[key]["fitness"])
        str(row["task"])
    return Study(Path(path), result)


def read_studies(paths: Iterable[Path], warn: Warn) -> list[Study]:
    """:func:`load_study` of each of :func:`find_studies`; one that cannot be read is named in a warning."""
    studies = []
    for path in find_studies(paths):
        try:
            studies.append(load_study(path))
        except (OSError, ValueError, KeyError, TypeError) as exc:
            warn(f"{path}: skipped: not a readable `simtune generalise` result ({type(exc).__name__}: {exc})")
    return studies


def _sibling_alone(run: ReportedRun, task: str, known: set[Path], warn: Warn) -> ReportedRun | None:
    """The one-task run of ``task`` beside ``run`` in a study's layout (``OUT/joint`` -> ``OUT/alone/<task>``),
    where there is one the report was not given; None otherwise."""
    if run.path.name != JOINT_FOLDER:
        return None
    folder = run.path.parent / ALONE_FOLDER / task
    if not (folder / STORE_FILE).is_file() or folder.resolve() in known:
        return None
    loaded = load_run(folder, project=run.project)
    if isinstance(loaded, Skipped):
        warn(f"{folder}: not taken as {task}'s alone-best: {loaded.reason}")
        return None
    if loaded.task_names != [task] or _settings(loaded) != _settings(run):
        warn(f"{folder}: not taken as {task}'s alone-best: tuned with other settings than {run.label}")
        return None
    return loaded


def alone_bests(groups: list[Group], studies: list[Study], warn: Warn) -> dict[tuple[str, str, str, str], AloneBest]:
    """Each task of each multi-task group: its alone-best (see the module's notes), where one is found.

    Args:
        groups: the report's groups.
        studies: the ``generalise.json`` files found with the runs (:func:`read_studies`).
        warn: names a one-task run beside a run that cannot be used.
    Returns:
        (engine, tasks, space, task) -> the task's lowest fitness tuned alone and where it comes from.
    """
    known = {r.path.resolve() for g in groups for r in g.runs}
    found: dict[tuple[str, str, str, str], AloneBest] = {}
    for g in groups:
        if len(g.task_names) < 2:
            continue
        best = g.best_run
        for task in g.task_names:
            candidates: list[AloneBest] = []
            for other in groups:
                if other.task_names == [task] and _settings(other.best_run) == _settings(best):
                    candidates += [AloneBest(f, r.label) for r in other.runs if (f := task_part(r, task)) is not None]
            for run in g.runs:
                sibling = _sibling_alone(run, task, known, warn)
                if sibling is not None and (fitness := task_part(sibling, task)) is not None:
                    candidates.append(AloneBest(fitness, str(sibling.path)))
            for study in studies:
                r = study.result
                if (r.get("engine"), r.get("space"), _data_key(r.get("data")), r.get("reference")) != _study_settings(
                    best
                ):
                    continue
                for row in r["rows"]:
                    if row["task"] == task:
                        candidates.append(AloneBest(float(row["alone"]["fitness"]), str(study.path)))
            if candidates:
                found[(g.engine, g.tasks, g.space, task)] = min(candidates, key=lambda c: c.fitness)
    return found


def generalise_command(run: ReportedRun) -> str:
    """The ``simtune generalise`` command that tunes each of ``run``'s tasks alone beside it (and all together)."""
    c = run.config
    data = "" if c.data is None else f" --data {c.data}"
    return f"simtune generalise --engine {c.engine} --task {c.tasks} --space {c.space}{data} --out OUT"


def _ratio(a: float | None, b: float | None) -> float | None:
    return None if a is None or not b else a / b


def joint_fit_table(groups: list[Group], floors: list[RepeatFloor], bests: dict) -> Table:
    """Per multi-task group and task: the floor, the best run's part of the fit, that over the floor, the task's
    alone-best and the joint-fit penalty (part / alone-best).

    Args:
        groups: the report's groups; those of one task give no row.
        floors: each task's floor (the report's ``floors``).
        bests: :func:`alone_bests`.
    Returns:
        The table ``joint_fit`` (no rows where no group has two tasks).
    """
    floor_of = {f.task: f.floor for f in floors}
    rows = []
    for g in groups:
        if len(g.task_names) < 2:
            continue
        best = g.best_run
        for task in g.task_names:
            part, floor = task_part(best, task), floor_of.get(task)
            alone = bests.get((g.engine, g.tasks, g.space, task))
            rows.append(
                [
                    g.engine,
                    g.space,
                    g.tasks,
                    task,
                    floor,
                    part,
                    _ratio(part, floor),
                    None if alone is None else alone.fitness,
                    None if alone is None else _ratio(alone.fitness, floor),
                    None if alone is None else _ratio(part, alone.fitness),
                    f"{NOT_FOUND}: {generalise_command(best)}" if alone is None else alone.source,
                ]
            )
    return Table(
        "joint_fit",
        "Joint fit: each task's part of a fit tuned on several tasks, against its floor and its alone-best",
        [
            Column("engine"),
            Column("space"),
            Column("tuned on"),
            Column("task"),
            Column("floor", ".4g"),
            Column("part", ".4g"),
            Column("part / floor", ".2f"),
            Column("alone-best", ".4g"),
            Column("alone-best / floor", ".2f"),
            Column("joint / alone", ".2f"),
            Column("alone-best from"),
        ],
        rows,
        note="Part: the task's share of the best run's fitness, its tasks tuned together with one parameter set. "
        "Floor: the real arm's repeats against their own aligned mean (the floor table). Alone-best: the lowest "
        "fitness of the task tuned alone with the same engine, space and recordings: a one-task run among the "
        "report's runs, the study's run beside it (OUT/alone/<task> for a run at OUT/joint) or its generalise.json. "
        "Joint / alone: the joint-fit penalty, 1 where one simulator fits every task as well as each alone, above 1 "
        f"where each task bends the parameters its own way. '{NOT_FOUND}': the command given tunes each task alone "
        "beside the joint run; report its OUT.",
    )


def study_table(study: Study, name: str) -> Table:
    """A ``simtune generalise`` study's table, its values as its ``generalise.json`` holds them.

    Args:
        study: the study (:func:`load_study`).
        name: the table's file stem.
    Returns:
        One row per task: floor, alone, joint, joint / alone, held out, held / alone, each fit over the floor, the
        held-out command delay and the tasks the held-out parameters were tuned on.
    """
    r = study.result
    rows = [
        [
            row["task"],
            row.get("floor"),
            row["alone"]["fitness"],
            row.get("alone_over_floor"),
            row["joint"]["fitness"],
            row.get("joint_over_floor"),
            row.get("penalty"),
            row["held_out"]["fitness"],
            row.get("held_out_over_floor"),
            row.get("transfer"),
            row["held_out"].get("delay_s"),
            ", ".join(row.get("held_out_from", [])),
        ]
        for row in r["rows"]
    ]
    tasks = ", ".join(r.get("tasks", [row["task"] for row in r["rows"]]))
    medians = ""
    if isinstance(r.get("joint_penalty"), (int, float)) and isinstance(r.get("transfer"), (int, float)):
        medians = f" Medians over tasks: joint / alone {r['joint_penalty']:.2f}, held / alone {r['transfer']:.2f}."
    return Table(
        name,
        f"Generalisation study: {r.get('engine', '?')} on {tasks} ({r.get('space', '?')}, {r.get('optimizer', '?')}, "
        f"seed {r.get('seed', '?')})",
        [
            Column("task"),
            Column("floor", ".4g"),
            Column("alone", ".4g"),
            Column("alone / floor", ".2f"),
            Column("joint", ".4g"),
            Column("joint / floor", ".2f"),
            Column("joint / alone", ".2f"),
            Column("held out", ".4g"),
            Column("held out / floor", ".2f"),
            Column("held / alone", ".2f"),
            Column("held-out delay [s]", ".3f"),
            Column("held out: tuned on"),
        ],
        rows,
        note=f"From {study.path} (`simtune generalise`). Each task scored against its own recordings: floor, the real "
        "arm against itself ('-': one repeat); alone, tuned on that task alone; joint, its part of the fit tuned on "
        "every task together (joint / alone: the joint-fit penalty); held out, tuned on the other tasks only with "
        "its own clock aligned (the held-out delay: the command delay fitted to its recording, the physics held "
        f"fixed), what a motion never recorded can expect.{medians}",
    )
