"""The report's first screen: how far tuning got, against the untuned simulation and the data's own floor, and
what it changed.

A newcomer opens the report to learn three things: did tuning help and by how much (the generic and the tuned
fitness of each task beside the floor, the fitness of the real arm's repeats against their own mean), does the
tuned simulation follow the recording (the trajectory figure, drawn by the trajectories section), and which
parameters moved and how tightly the recordings pin them (the best run's values with their 95 % intervals).
The paper's tables follow in their own sections.
"""

from __future__ import annotations

from simtune.common.table import Column, Table
from simtune.fitness import RepeatFloor
from simtune.report.collect import Group
from simtune.report.tables import NO_FLOOR, fitness_definition, interval_texts, joint_log_runs


def headline_table(groups: list[Group], floors: list[RepeatFloor]) -> Table:
    """Per engine, tasks, space and task: the generic and the tuned fitness of the best run, the floor, and the ratios.

    Args:
        groups: the report's groups (repeats of one engine, tasks and space).
        floors: each task's floor (the aligned mean against its repeats), where the data allow one.
    Returns:
        The table ``headline``.
    """
    floor_of = {f.task: f.floor for f in floors}
    runs = [r for g in groups for r in g.runs]
    # a joint log's fitness is a fraction of a degree times 0.5 m/rad: significant digits, not four decimals
    fitness_format = ".3g" if joint_log_runs(runs) else ".4f"
    rows = []
    for g in groups:
        best = g.best_run
        for task in g.task_names:
            generic, tuned = best.task_score(best.generic, task), best.task_score(best.best_score, task)
            generic_fit = None if generic is None else float(generic["fitness"])
            tuned_fit = None if tuned is None else float(tuned["fitness"])
            floor = floor_of.get(task)
            rows.append(
                [
                    g.engine,
                    g.space,
                    task,
                    len(g.runs),
                    generic_fit,
                    tuned_fit,
                    None if not (generic_fit and tuned_fit is not None) else 100.0 * (1.0 - tuned_fit / generic_fit),
                    NO_FLOOR if floor is None and task in floor_of else floor,
                    None if not (floor and tuned_fit is not None) else tuned_fit / floor,
                ]
            )
        held = best.record.validation or {}
        for task, fit in (held.get("parts") or {}).items():  # --validate: what the run did not see, with its best
            rows.append([g.engine, g.space, f"{task} (held out)", len(g.runs), None, fit, None, None, None])
    return Table(
        "headline",
        "At a glance: the tuned simulation against the untuned one and the data's floor",
        [
            Column("engine"),
            Column("space"),
            Column("task"),
            Column("runs", "d"),
            Column("generic fitness", fitness_format),
            Column("tuned fitness", fitness_format),
            Column("lower than generic [%]", ".0f"),
            Column("floor", fitness_format),
            Column("tuned / floor", ".1f"),
        ],
        rows,
        note=f"Fitness = {fitness_definition(runs)} (lower is better) of each task, for the best run of "
        "its engine, tasks and space (its tasks tuned together). Floor: the real arm's repeats against their own "
        "aligned mean, scored as a simulation is: a tuned fitness near it is as close as the recordings can tell "
        f"(tuned / floor = 1); '{NO_FLOOR}' where a task has one repeat, which scores 0 against itself; '-' where "
        "its recordings could not be read. A task marked 'held out' was left out of the run's search (--validate) and "
        "scored afterwards with its best parameters.",
    )


def moved_parameters_table(groups: list[Group], nominal: dict[str, dict[str, float]]) -> Table:
    """Each group's best run: every searched parameter's generic and tuned value, how far it moved, its interval.

    Args:
        groups: the report's groups.
        nominal: engine -> generic parameter values.
    Returns:
        The table ``tuned_parameters``, the parameters that moved furthest (as a share of their range) first.
    """
    rows = []
    for g in groups:
        best = g.best_run
        intervals = interval_texts(best.record.uncertainty)
        generic_values = nominal.get(g.engine, {})
        entries: list[tuple[float, list]] = []
        for name, value, (low, high) in zip(best.parameters, best.best_x, best.bounds):
            generic = generic_values.get(name)
            moved = None
            if generic is not None and high > low:
                moved = 100.0 * abs(float(value) - generic) / (high - low)
            row = [g.engine, g.tasks, g.space, name, generic, float(value), moved, intervals.get(name, "-")]
            entries.append((-1.0 if moved is None else moved, row))
        entries.sort(key=lambda entry: -entry[0])
        rows += [row for _, row in entries]
    return Table(
        "tuned_parameters",
        "What tuning changed: the best run's parameters, the furthest moved first",
        [
            Column("engine"),
            Column("tasks"),
            Column("space"),
            Column("parameter"),
            Column("generic", ".4g"),
            Column("tuned", ".4g"),
            Column("moved [% of range]", ".0f"),
            Column("95 % interval"),
        ],
        rows,
        note="Generic: the engine's own value (or the task's, the controller's). Moved: |tuned - generic| as a share "
        "of the parameter's tuning range. 95 % interval: the Gauss-Newton interval at the best point "
        "(`simtune uncertainty RUN`; with `--bootstrap N`, refits against N draws of the repeats too); "
        "'unbounded' where the recordings cannot pin the parameter there, '-' where "
        "it was not computed.",
    )
