"""The report's tables, built from plain records (see :mod:`simtune.report.collect`).

Each builder returns a :class:`simtune.common.table.Table`; nothing here simulates or draws.
"""

from __future__ import annotations

import math
from collections import defaultdict
from dataclasses import dataclass

import numpy as np

from simtune.check.project import floor_words
from simtune.common.table import Column, Table
from simtune.data.clock import spread_per_sample
from simtune.data.screen import JOINT_WEIGHT
from simtune.fitness import RepeatFloor
from simtune.params.space import PARAMETERS
from simtune.report.collect import Group, ReportedRun
from simtune.report.simulate import GroupSimulation

#: q below which the report calls a parameter's narrowing by tuning significant
SIGNIFICANCE = 0.05


def _f(x) -> float | None:
    return None if x is None else float(x)


def _degrees(radians) -> float | None:
    return None if radians is None else math.degrees(float(radians))


def _stats(values: list[float]) -> tuple[float, float, float, float | None]:
    a = np.asarray(values, dtype=float)
    return float(a.min()), float(a.mean()), float(a.max()), float(a.std(ddof=1)) if a.size > 1 else None


# --- what the fitness is measured in --------------------------------------------------------------------
#: the motion-capture fitness, in words
MOCAP_FITNESS = "mean wrist error + final object error [m]"


def joint_log_runs(runs: list[ReportedRun]) -> list[ReportedRun]:
    """The runs whose recordings log joint angles (their fitness has a joint term)."""
    return [r for r in runs if r.best_score.get("joint_error") is not None]


def fitness_definition(runs: list[ReportedRun]) -> str:
    """What the runs' fitness is, with its unit, in words: the motion-capture sum in metres and, for joint logs, the
    joint weight [m/rad] times the mean absolute joint-angle error [rad] (:mod:`simtune.fitness`).

    Args:
        runs: the report's runs.
    Returns:
        A phrase such as ``"mean wrist error + final object error [m]"``.
    """
    joints = joint_log_runs(runs)
    if not joints:
        return MOCAP_FITNESS
    weights = sorted({float((r.config.weights or {}).get("joint", JOINT_WEIGHT)) for r in joints})
    if weights == [1.0]:
        joint = "the mean absolute joint-angle error of the logged joints [rad] (--weights joint=1)"
    else:
        joint = (
            f"{' or '.join(f'{w:g}' for w in weights)} m/rad (the joint weight, --weights joint=W) x the mean "
            "absolute joint-angle error of the logged joints [rad]"
        )
    if len(weights) == 1:
        joint += f" (a fitness of 0.01 is a mean joint error of {math.degrees(0.01 / weights[0]):.2f} deg)"
    if all(r.best_score.get("wrist_error") is None for r in joints) and len(joints) == len(runs):
        return joint
    return f"{MOCAP_FITNESS}, plus for joint logs {joint}"


def fitness_unit(runs: list[ReportedRun]) -> str:
    """The sentence under the report's title that says what the fitness is measured in."""
    if not joint_log_runs(runs):
        return "Fitness is in metres (lower is better)."
    return f"Fitness = {fitness_definition(runs)} (lower is better)."


# --- 1. generic fitness (the paper's Table II) -------------------------------------------------
@dataclass
class GenericEntry:
    """Generic (untuned) score of one engine on one task."""

    engine: str
    source: str  # "simtune" or "published"
    version: str
    task: str
    fitness: float
    wrist_error: float | None
    object_error: float | None
    stable: bool = True
    joint_error: float | None = None  # [rad]; None: the recordings log no joint angles


def generic_entries(groups: list[Group]) -> tuple[list[GenericEntry], list[str]]:
    """One entry per engine x task from the runs' stored generic scores; notes where repeats disagree."""
    seen: dict[tuple[str, str], GenericEntry] = {}
    notes: list[str] = []
    for group in groups:
        for run in group.runs:
            for task in run.task_names:
                part = run.task_score(run.generic, task)
                if part is None:
                    continue
                entry = GenericEntry(
                    run.engine,
                    "simtune",
                    run.record.versions.get(run.engine, ""),
                    task,
                    float(part["fitness"]),
                    _f(part.get("wrist_error")),
                    _f(part.get("object_error")),
                    bool(part.get("stable", True)),
                    _f(part.get("joint_error")),
                )
                key = (run.engine, task)
                if key not in seen:
                    seen[key] = entry
                elif abs(seen[key].fitness - entry.fitness) > 1e-9 and not any(
                    n.startswith(f"{run.engine} on {task}:") for n in notes
                ):
                    notes.append(
                        f"{run.engine} on {task}: runs disagree on the generic fitness "
                        f"({seen[key].fitness:.4f} vs {entry.fitness:.4f} in {run.label}): "
                        "different recordings or engine versions; the first is shown"
                    )
    return list(seen.values()), notes


def generic_table(entries: list[GenericEntry], tasks: list[str], fitness: str = MOCAP_FITNESS) -> Table:
    """Each engine's generic fitness and its parts per task; ``fitness``: what the fitness is, in words
    (:func:`fitness_definition`).  A joint error column per task is there where the recordings log joint angles."""
    engines: list[tuple[str, str, str]] = []
    for e in entries:
        if (e.engine, e.source, e.version) not in engines:
            engines.append((e.engine, e.source, e.version))
    with_joints = any(e.joint_error is not None for e in entries)
    width = 4 if with_joints else 3  # columns per task
    columns = [Column("engine"), Column("source"), Column("version")]
    for task in tasks:
        columns += [
            Column(f"{task} fitness", ".4f"),
            Column(f"{task} wrist error [m]", ".4f"),
            Column(f"{task} object error [m]", ".4f"),
            *([Column(f"{task} joint error [deg]", ".2f")] if with_joints else []),
        ]
    index = {(e.engine, e.source, e.task): e for e in entries}
    rows = []
    for engine, source, version in engines:
        row: list = [engine, source, version]
        for task in tasks:
            found = index.get((engine, source, task))
            parts: list[float | None] = [None] * width
            if found is not None:
                joint = None if found.joint_error is None else math.degrees(found.joint_error)
                parts = [found.fitness, found.wrist_error, found.object_error, joint][:width]
            row += parts
        rows.append(row)
    table = Table(
        "generic_fitness",
        "Generic (untuned) fitness per engine and task",
        columns,
        rows,
        note=f"Fitness = {fitness} (lower is better), simtune's fitness "
        "for every row. simtune rows: the engine with its generic parameters, as stored by each "
        "run. Published rows: the data set authors' own untuned simulations, read from files and "
        "scored against the same recordings."
        + (" Joint error: the mean absolute joint-angle error of the logged joints." if with_joints else ""),
    )
    for t in range(len(tasks)):
        col = 3 + width * t
        values = [(r[col], i) for i, r in enumerate(rows) if r[col] is not None]
        if values:
            table.highlight.add((min(values)[1], col))
    return table


# --- 2. best tuned per task and space (the paper's Table III) ---------------------------------------
def experiment_generic(entries: list[GenericEntry], tasks: list[str], source: str | None) -> dict[str, float]:
    """Generic fitness of each engine on a set of tasks (summed, as tuned together); engines with all tasks."""
    per: dict[str, dict[str, float]] = defaultdict(dict)
    for e in entries:
        if source is None or e.source == source:
            label = e.engine if e.source == "simtune" else f"{e.engine} (published)"
            per[label][e.task] = e.fitness
    return {label: sum(v[t] for t in tasks) for label, v in per.items() if all(t in v for t in tasks)}


def best_tuned_table(groups: list[Group], entries: list[GenericEntry]) -> Table:
    columns = [
        Column("tasks"),
        Column("space"),
        Column("best tuned fitness", ".4f"),
        Column("engine"),
        Column("seed", "d"),
        Column("run"),
        Column("best generic fitness", ".4f"),
        Column("best generic engine"),
        Column("improvement [%]", ".1f"),
        Column("best generic incl. published", ".4f"),
        Column("its engine"),
        Column("improvement vs it [%]", ".1f"),
    ]
    rows = []
    keys = sorted({(g.tasks, g.space) for g in groups})
    for tasks, space in keys:
        runs = [r for g in groups if (g.tasks, g.space) == (tasks, space) for r in g.runs]
        best = min(runs, key=lambda r: (r.best_fitness, r.engine, r.config.seed))
        names = best.task_names
        ours = experiment_generic(entries, names, "simtune")
        every = experiment_generic(entries, names, None)
        row = [tasks, space, best.best_fitness, best.engine, best.config.seed, best.label]
        for pool in (ours, every):
            if pool:
                engine, g = min(pool.items(), key=lambda kv: kv[1])
                row += [g, engine, 100.0 * (g - best.best_fitness) / g if g > 0 else None]
            else:
                row += [None, None, None]
        rows.append(row)
    return Table(
        "best_tuned",
        "Best tuned fitness per task and parameter space",
        columns,
        rows,
        note="Best fitness over all engines and repeats, and its improvement over the best generic engine "
        "(100 x (generic - tuned) / generic). Tasks tuned together sum their fitness, and so does "
        "the generic fitness they are compared with.",
    )


def tuned_by_group_table(groups: list[Group]) -> Table:
    columns = [
        Column("engine"),
        Column("tasks"),
        Column("space"),
        Column("repeats", "d"),
        Column("seeds"),
        Column("parameters", "d"),
        Column("generic fitness", ".4f"),
        Column("tuned best", ".4f"),
        Column("tuned mean", ".4f"),
        Column("tuned worst", ".4f"),
        Column("tuned std", ".4f"),
        Column("improvement of best [%]", ".1f"),
        Column("best run"),
    ]
    rows = []
    for g in groups:
        lo, mean, hi, std = _stats([r.best_fitness for r in g.runs])
        generic = g.runs[0].generic_fitness
        rows.append(
            [
                g.engine,
                g.tasks,
                g.space,
                len(g.runs),
                " ".join(str(r.config.seed) for r in g.runs),
                len(g.searched),
                generic,
                lo,
                mean,
                hi,
                std,
                100.0 * (generic - lo) / generic if generic > 0 else None,
                g.best_run.label,
            ]
        )
    return Table(
        "tuned_by_group",
        "Tuned fitness per engine, tasks and space, over repeats",
        columns,
        rows,
        note="Tuned = the best evaluation of each repeat (seed); std is the sample standard deviation.",
    )


# --- the paper's Tables II and III, in its layout -------------------------------------------------------
def experiment_label(tasks: str) -> str:
    """The paper's experiment number for a seed task (``seed-3`` -> ``3``) or task group; else the tasks as named."""
    from simtune.tasks import GROUPS

    if tasks in GROUPS:
        return f"{tasks.removeprefix('seed-')} (all of {GROUPS[tasks][0]} .. {GROUPS[tasks][-1]})"
    return tasks.removeprefix("seed-") if tasks.startswith("seed-") else tasks


def paper_generic_table(entries: list[GenericEntry], tasks: list[str]) -> Table:
    """Table II as the paper prints it: one row per experiment (and one summing them all, as its
    experiment 11), one column per engine, and which engines' simulations were unstable."""
    engines = list(dict.fromkeys(e.engine if e.source == "simtune" else f"{e.engine} (published)" for e in entries))
    index = {(e.engine if e.source == "simtune" else f"{e.engine} (published)", e.task): e for e in entries}
    columns = [Column("experiment"), *(Column(name, ".4f") for name in engines)]
    columns += [Column("unstable (blew up)"), Column("best engine"), Column("best generic fitness", ".4f")]
    rows: list[list] = []
    for task in tasks:
        found = [index.get((name, task)) for name in engines]
        values = [None if e is None else e.fitness for e in found]
        unstable = [name for name, e in zip(engines, found) if e is not None and not e.stable]
        scored = [(v, name) for v, name in zip(values, engines) if v is not None]
        best = min(scored) if scored else (None, None)
        rows.append([experiment_label(task), *values, ", ".join(unstable) or "-", best[1], best[0]])
    if len(tasks) > 1:  # the paper's experiment 11: the sum over the tasks, for engines that ran them all
        complete = [
            sum(index[name, t].fitness for t in tasks) if all((name, t) in index for t in tasks) else None
            for name in engines
        ]
        unstable = [name for name in engines if any((name, t) in index and not index[name, t].stable for t in tasks)]
        scored = [(v, name) for v, name in zip(complete, engines) if v is not None]
        best = min(scored) if scored else (None, None)
        label = "11 (sum of 1-10)" if tasks == [f"seed-{n}" for n in range(1, 11)] else f"all {len(tasks)} (sum)"
        rows.append([label, *complete, ", ".join(unstable) or "-", best[1], best[0]])
    table = Table(
        "paper_table_ii",
        "The paper's Table II in its layout: generic fitness per experiment and engine",
        columns,
        rows,
        note="Rows: experiments (seed task N = the paper's experiment N; other tasks by name), the last row "
        "their sum (the paper's experiment 11 sums tasks 1-10). Unstable: engines whose generic simulation "
        "blew up on that experiment (scored with the finite penalty; the paper printed the raw values, "
        "491-995). Columns after the engines are simtune's.",
    )
    for i, row in enumerate(rows):
        cells: list[tuple[float, int]] = [
            (float(v), j) for j, v in enumerate(row[1 : 1 + len(engines)], start=1) if v is not None
        ]
        if cells:
            table.highlight.add((i, min(cells)[1]))
    return table


def paper_tuned_table(groups: list[Group], entries: list[GenericEntry]) -> Table:
    """Table III as the paper prints it, one row per experiment, space and engine, with each engine's
    dimension D and population size; then simtune's columns (spread over repeats, budgets, how the run searched)."""
    columns = [
        Column("experiment"),
        Column("space"),
        Column("engine"),
        Column("D", "d"),
        Column("population", "d"),
        Column("best tuned fitness", ".4f"),
        Column("improvement over best generic [%]", ".1f"),
        Column("repeats", "d"),
        Column("mean tuned", ".4f"),
        Column("std tuned", ".4f"),
        Column("generations (mean)", ".1f"),
        Column("stopped by time cap", "d"),
        Column("search"),
    ]
    rows: list[list] = []
    for g in sorted(groups, key=lambda g: (g.tasks, g.space, g.engine)):
        lo, mean, _, std = _stats([r.best_fitness for r in g.runs])
        generic = experiment_generic(entries, g.task_names, None)
        best_generic = min(generic.values()) if generic else None
        sizes = sorted({r.population_size for r in g.runs})
        exact = sum(r.config.paper_exact for r in g.runs)
        search = "paper-exact" if exact == len(g.runs) else "simtune" if exact == 0 else f"{exact} paper-exact"
        optimizer = g.runs[0].config.optimizer
        rows.append(
            [
                experiment_label(g.tasks),
                g.space,
                g.engine,
                len(g.searched),
                sizes[0] if len(sizes) == 1 else None,
                lo,
                100.0 * (best_generic - lo) / best_generic if best_generic else None,
                len(g.runs),
                mean,
                std,
                float(np.mean([len(r.record.generations) for r in g.runs])),
                sum(r.stopped_by_time_cap for r in g.runs),
                f"{optimizer}, {search}",
            ]
        )
    table = Table(
        "paper_table_iii",
        "The paper's Table III in its layout: best tuned fitness per experiment, space and engine",
        columns,
        rows,
        note="D: parameters in the search vector (the space as the engine maps it; --paper-exact keeps the "
        "paper's whole list). Population: members of the initial population (SciPy: max(5, 1 x D)). "
        "Improvement: over the best generic engine of the experiment, published simulations included. "
        "Search: simtune = deferred updating, pruning, no polish; paper-exact = SciPy's immediate "
        "updating and polish, one worker. Bold: the best engine per experiment and space.",
    )
    best_rows: dict[tuple, tuple[float, int]] = {}
    for i, row in enumerate(rows):
        key, fitness = (row[0], row[1]), float(row[5])
        if key not in best_rows or fitness < best_rows[key][0]:
            best_rows[key] = (fitness, i)
    for _, i in best_rows.values():
        table.highlight.add((i, 5))
    return table


def summary_counts_table(groups: list[Group]) -> Table:
    """The paper's summary counts: individual against shared parameters, and how the runs stopped."""
    pairs: dict[tuple[str, str], dict[str, Group]] = defaultdict(dict)
    for g in groups:
        pairs[(g.engine, g.tasks)][g.space] = g
    compared = [(k, v["shared"], v["individual"]) for k, v in pairs.items() if "shared" in v and "individual" in v]
    best_wins = sum(ind.best_run.best_fitness < sh.best_run.best_fitness for _, sh, ind in compared)
    mean_wins = sum(
        np.mean([r.best_fitness for r in ind.runs]) < np.mean([r.best_fitness for r in sh.runs])
        for _, sh, ind in compared
    )
    runs = [r for g in groups for r in g.runs]
    capped = sum(r.stopped_by_time_cap for r in runs)
    converged = sum(r.record.converged for r in runs)
    rows = [
        ["individual better than shared (best repeat)", best_wins, len(compared)],
        ["individual better than shared (mean over repeats)", mean_wins, len(compared)],
        ["runs stopped by the time cap (--max-seconds)", capped, len(runs)],
        ["runs that met the convergence criterion", converged, len(runs)],
        ["runs searched as the paper did (--paper-exact)", sum(r.config.paper_exact for r in runs), len(runs)],
    ]
    return Table(
        "summary_counts",
        "Summary counts (as the paper reports them): N of M",
        [Column("count"), Column("N", "d"), Column("of M", "d")],
        rows,
        note="Individual vs shared: engine x experiment pairs tuned in both spaces, compared by the best "
        "repeat's fitness and by the mean over repeats. Time cap: runs whose wall time reached their "
        "--max-seconds. Convergence: SciPy's criterion (population fitness std below 1 % of its mean).",
    )


# --- 5. parameter importance and Mann-Whitney U ------------------------------------------------------
def spread_test(tuned: np.ndarray, initial: np.ndarray) -> float | None:
    """One-sided Brown-Forsythe test: p of "the tuned values spread less than the initial population's".

    Brown-Forsythe compares the absolute deviations from each sample's median; with two samples its
    F statistic is the square of the pooled two-sample t statistic of those deviations, whose one-sided
    p-value is returned.  None when either sample has fewer than two values or neither varies.
    """
    import warnings

    from scipy.stats import ttest_ind

    if tuned.size < 2 or initial.size < 2:
        return None
    dev_tuned = np.abs(tuned - np.median(tuned))
    dev_initial = np.abs(initial - np.median(initial))
    if not dev_tuned.any() and not dev_initial.any():
        return None
    with warnings.catch_warnings():  # repeats that agree closely: SciPy warns of precision, the p stands
        warnings.simplefilter("ignore", RuntimeWarning)
        return float(ttest_ind(dev_tuned, dev_initial, alternative="less").pvalue)


def _initial_values(group: Group, name: str) -> np.ndarray:
    """The values of parameter ``name`` in the random starts of the group's repeats, pooled."""
    values = [x[r.parameters.index(name)] for r in group.runs if name in r.parameters for x in r.random_start]
    return np.asarray(values, dtype=float)


_IMPORTANCE_COLUMNS = [
    Column("engine"),
    Column("tasks"),
    Column("space"),
    Column("rank", "d"),
    Column("parameter"),
    Column("repeats", "d"),
    Column("std / range", ".3f"),
    Column("(max - min) / range", ".3f"),
    Column("initial std / range", ".3f"),
    Column("p (Brown-Forsythe)", ".3g"),
    Column("q (BH)", ".3g"),
    Column("significant", ""),
    Column("mean (normalised)", ".3f"),
    Column("mean", ".4g"),
    Column("unit"),
    Column("best repeat", ".4g"),
    Column("95 % interval (best repeat)"),
    Column("active"),
]


def _spread_entries(g: Group) -> list[list]:
    """Per parameter of ``g`` that can act: name, repeats, std and spread of its tuned values and std of its
    initial values (each over its range), the Brown-Forsythe p, its normalised mean and its mean."""
    entries = []
    for name in g.parameters:
        values = np.asarray(g.values(name))
        initial = _initial_values(g, name)
        low, high = g.bounds(name)
        width = high - low if high > low else 1.0
        std = float(values.std(ddof=1)) / width if values.size > 1 else None
        spread = float(values.max() - values.min()) / width
        initial_std = float(initial.std(ddof=1)) / width if initial.size > 1 else None
        p = spread_test(values, initial)
        entries.append(
            [name, values.size, std, spread, initial_std, p, float((values.mean() - low) / width), values.mean()]
        )
    return entries


def _importance_rows(g: Group) -> list[list]:
    """The rows of one engine, tasks and space: its parameters that can act, ranked; then the inactive ones."""
    from scipy.stats import false_discovery_control

    best = g.best_run.best_params
    intervals = interval_texts(g.best_run.record.uncertainty)
    entries = _spread_entries(g)
    tested = [i for i, e in enumerate(entries) if e[5] is not None]
    q: dict[int, float] = {}
    if tested:  # Benjamini-Hochberg over the parameters of this engine, tasks and space
        adjusted = false_discovery_control([entries[i][5] for i in tested], method="bh")
        q = {i: float(v) for i, v in zip(tested, np.atleast_1d(adjusted))}
    order = sorted(
        range(len(entries)),
        key=lambda i: (math.inf if entries[i][2] is None else entries[i][2], entries[i][3], entries[i][0]),
    )
    rows = []
    for rank, i in enumerate(order, start=1):
        name, n, std, spread, initial_std, p, mean_norm, mean = entries[i]
        unit = PARAMETERS[name].unit if name in PARAMETERS else ""
        significant = None if i not in q else ("yes" if q[i] < SIGNIFICANCE else "no")
        rows.append(
            [
                *(g.engine, g.tasks, g.space, rank if std is not None else None, name, n, std, spread, initial_std),
                *(p, q.get(i), significant, mean_norm, float(mean), unit, best.get(name)),
                *(intervals.get(name, "-"), "yes"),
            ]
        )
    for name, why in g.inactive.items():  # marked, never ranked: their spread is the search's wandering
        unit = PARAMETERS[name].unit if name in PARAMETERS else ""
        rows.append([g.engine, g.tasks, g.space, None, name, 0, *[None] * 8, unit, None, "-", f"no: {why}"])
    return rows


def importance_table(groups: list[Group]) -> Table:
    columns = _IMPORTANCE_COLUMNS
    rows = [row for g in groups for row in _importance_rows(g)]
    return Table(
        "parameter_importance",
        "Parameter importance: spread of tuned values across repeats, and its significance",
        columns,
        rows,
        note="The paper's measure: a parameter whose tuned value is tightly bounded across independent repeats "
        "matters to the fitness; one that wanders over its range does not. Spread = sample std (and max - "
        "min) of the best value of each repeat, divided by the parameter's range. Rank 1 = the tightest (most"
        " influential) parameter of that engine, tasks and space. With one repeat there is no spread and no "
        "rank. Significance: the one-sided Brown-Forsythe test (absolute deviations from the median; "
        "scipy.stats.ttest_ind on them, whose square is the Brown-Forsythe F) of the tuned values across "
        "repeats against their values in each repeat's random start (parameter sets drawn over the whole box "
        "before any search step: DE's initial latin hypercube; auto's the latin-hypercube half of its first "
        "global phase), pooled over repeats: p = chance of a spread this small if tuning had not narrowed it."
        " q: Benjamini-Hochberg adjusted over the parameters of the row's engine, tasks and space; "
        f"significant: q < {SIGNIFICANCE:g}. Best repeat: the tuned value of the best repeat; its 95 % "
        "interval is the Gauss-Newton interval at that point (`simtune uncertainty`, with `--bootstrap N` refits "
        "against N draws of the repeats too; 'unbounded' where the "
        "recordings cannot pin the parameter, '-' where not computed). Active: whether the parameter changes "
        "any rollout of the tasks (measured before the search); an inactive one is listed with the reason and"
        " never ranked.",
    )


def interval_texts(uncertainty: dict | None) -> dict[str, str]:
    """Parameter -> its 95 % interval as text, from a run's stored uncertainty (empty when not computed)."""
    if not uncertainty:
        return {}
    texts = {}
    for entry in uncertainty.get("parameters", []):
        if entry.get("low") is None or entry.get("high") is None:
            texts[entry["name"]] = "unbounded" if entry.get("active") else "-"
        else:
            texts[entry["name"]] = f"[{entry['low']:.4g}, {entry['high']:.4g}]"
    return texts


def importance_top_table(full: Table, top: int = 5) -> Table:
    """The ``top`` most tightly bounded parameters of each engine, tasks and space (ranked groups only)."""
    keep = [
        "engine",
        "tasks",
        "space",
        "rank",
        "parameter",
        "repeats",
        "std / range",
        "(max - min) / range",
        "initial std / range",
        "q (BH)",
        "significant",
    ]
    idx = [full.headers.index(k) for k in keep]
    rows = [[row[i] for i in idx] for row in full.rows if row[3] is not None and row[3] <= top]
    return Table(
        "parameter_importance_top",
        f"The {top} most influential parameters per engine, tasks and space",
        [full.columns[i] for i in idx],
        rows,
        note=f"The first {top} ranks of the parameter importance table (groups with at least two repeats); that table, "
        "next, has every parameter.",
    )


def mann_whitney_table(groups: list[Group]) -> Table:
    from scipy.stats import mannwhitneyu

    columns = [
        Column("engine"),
        Column("tasks"),
        Column("space"),
        Column("tuned n", "d"),
        Column("untuned n", "d"),
        Column("generic fitness", ".4f"),
        Column("median untuned", ".4f"),
        Column("median tuned", ".4f"),
        Column("U", ".1f"),
        Column("p two-sided", ".3g"),
        Column("p tuned < untuned", ".3g"),
    ]
    rows = []
    for g in groups:
        tuned = [r.best_fitness for r in g.runs]
        untuned = [f for r in g.runs for f in r.random_start_fitness]
        u = p2 = p1 = None
        if tuned and untuned:
            res2 = mannwhitneyu(tuned, untuned, alternative="two-sided")
            res1 = mannwhitneyu(tuned, untuned, alternative="less")
            u, p2, p1 = float(res2.statistic), float(res2.pvalue), float(res1.pvalue)
        rows.append(
            [
                g.engine,
                g.tasks,
                g.space,
                len(tuned),
                len(untuned),
                g.runs[0].generic_fitness,
                float(np.median(untuned)) if untuned else None,
                float(np.median(tuned)),
                u,
                p2,
                p1,
            ]
        )
    return Table(
        "mann_whitney",
        "Mann-Whitney U test: tuned vs untuned fitness",
        columns,
        rows,
        note="Tuned sample: the best fitness of each repeat. The generic fitness is one deterministic "
        "number, so the untuned sample is instead the fitness of each repeat's random start (parameter "
        "sets drawn over the whole box before any search step: DE's initial latin hypercube; auto's the "
        "latin-hypercube half of its first global phase, where the run got that far), pooled over "
        "repeats. U is the statistic of the tuned sample; the one-sided p tests whether tuned fitness is lower.",
    )


# --- 6. object final positions ------------------------------------------------------------------------
@dataclass
class FinalPosition:
    task: str
    source: str  # "recorded", "untuned", "tuned", "published"
    engine: str
    space: str
    position: np.ndarray
    spread: float | None = None  # recorded: mean distance of the repeats from their mean


def object_final_table(finals: list[FinalPosition]) -> Table:
    columns = [
        Column("task"),
        Column("source"),
        Column("engine"),
        Column("space"),
        Column("x [m]", ".4f"),
        Column("y [m]", ".4f"),
        Column("z [m]", ".4f"),
        Column("distance to recorded mean [m]", ".4f"),
        Column("repeat spread [m]", ".4f"),
    ]
    recorded = {f.task: f.position for f in finals if f.source.startswith("recorded")}
    rows = []
    for f in finals:
        ref = recorded.get(f.task)
        dist = None if ref is None or f.source.startswith("recorded") else float(np.linalg.norm(f.position - ref))
        rows.append([f.task, f.source, f.engine, f.space, *(float(v) for v in f.position), dist, f.spread])
    return Table(
        "object_final",
        "Final object position: recorded vs simulated",
        columns,
        rows,
        note="Recorded: mean over the kept repeats of the last seen object position (spread = mean "
        "distance of a repeat from that mean). Untuned / tuned: re-simulated with the engine's generic "
        "parameters and with the best run's tuned parameters. The distance is the fitness's object term.",
    )


# --- 6a. wrist error per phase ------------------------------------------------------------------------------
#: the recorded mean wrist moving slower than this [m/s] is at rest (a rest pose), faster it moves
REST_SPEED = 0.01


@dataclass
class PhaseError:
    """The wrist (marker) error of one group's best run over one stretch of one task, and reality's own spread."""

    engine: str
    tasks: str
    space: str
    task: str
    phase: str
    start: float
    end: float
    samples: int
    untuned: float  # mean distance from the recorded mean wrist [m]
    tuned: float
    tuned_at_rest: float | None  # over the samples where the recorded wrist rests (None: none there)
    tuned_moving: float | None
    tuned_offset: np.ndarray  # mean signed tuned - recorded, x y z [m]
    repeat_spread: float  # mean distance of a recorded repeat from the recorded mean [m]


def phase_errors(
    group: Group,
    task: str,
    spans: list[tuple[str, float, float]],
    times: np.ndarray,
    recorded: tuple[np.ndarray, np.ndarray],
    simulated: tuple[np.ndarray, np.ndarray],
) -> list[PhaseError]:
    """Per stretch of ``task`` (``spans``: label, start, end [s], as :meth:`simtune.tasks.TaskSpec.stretches`
    gives them): the wrist error of the untuned and the tuned marker (``simulated``, each (n, 3) or longer)
    against the recorded mean, and the repeats' spread about it (``recorded``: the mean (n, 3) and the repeats
    (r, n, 3))."""
    mean, repeats = recorded
    n = len(times)
    untuned, tuned = (np.asarray(m)[:n] for m in simulated)
    speed = np.linalg.norm(np.gradient(mean, times, axis=0), axis=1)
    untuned_d, tuned_d = np.linalg.norm(untuned - mean, axis=1), np.linalg.norm(tuned - mean, axis=1)
    spread = spread_per_sample(repeats)
    out = []
    for i, (label, start, end) in enumerate(spans):
        last = i == len(spans) - 1
        inside = (times >= start) & ((times <= end) if last else (times < end))
        if not inside.any():
            continue
        rest, moving = inside & (speed < REST_SPEED), inside & (speed >= REST_SPEED)
        out.append(
            PhaseError(
                group.engine,
                group.tasks,
                group.space,
                task,
                label,
                start,
                end,
                int(inside.sum()),
                float(untuned_d[inside].mean()),
                float(tuned_d[inside].mean()),
                float(tuned_d[rest].mean()) if rest.any() else None,
                float(tuned_d[moving].mean()) if moving.any() else None,
                (tuned[inside] - mean[inside]).mean(axis=0),
                float(spread[inside].mean()),
            )
        )
    return out


def phase_error_table(entries: list[PhaseError]) -> Table:
    mm = [Column(name, ".1f") for name in ("untuned [mm]", "tuned [mm]", "tuned at rest [mm]", "tuned moving [mm]")]
    offsets = [Column(f"tuned - recorded {axis} [mm]", "+.1f") for axis in "xyz"]
    columns = [
        *(Column(name) for name in ("engine", "tasks", "space", "task", "stretch")),
        Column("from [s]", ".2f"),
        Column("to [s]", ".2f"),
        Column("samples", "d"),
        *mm,
        *offsets,
        Column("repeat spread [mm]", ".1f"),
    ]

    def millimetres(value: float | None) -> float | None:
        return None if value is None else 1000.0 * value

    rows = [
        [
            e.engine,
            e.tasks,
            e.space,
            e.task,
            e.phase,
            e.start,
            e.end,
            e.samples,
            *(millimetres(v) for v in (e.untuned, e.tuned, e.tuned_at_rest, e.tuned_moving)),
            *(1000.0 * float(v) for v in e.tuned_offset),
            1000.0 * e.repeat_spread,
        ]
        for e in entries
    ]
    return Table(
        "phase_errors",
        "Where the wrist error sits: per stretch of each task's schedule",
        columns,
        rows,
        note="The best run of each engine, tasks and space, re-simulated (as the trajectory figures): the mean "
        "distance of the simulated wrist marker from the recorded mean over each stretch of the task's schedule "
        "as the tuned simulation runs it (each phase from when its command arrives: the schedule's start plus the "
        "tuned command delay; before the first, the start pose), untuned and tuned; the tuned one "
        f"split where the recorded wrist rests (slower than {100 * REST_SPEED:g} cm/s) and where it moves, and "
        "its mean signed offset per axis. Repeat spread: the mean distance of a recorded repeat from the "
        "recorded mean there - how closely the real arm repeats itself, the floor a simulation is measured "
        "against. Weighted by samples, the tuned column gives the wrist error of the tuned fitness.",
    )


# --- 6b. joint-angle error per joint and stretch (joint logs) -------------------------------------------------
@dataclass
class JointError:
    """The angle error of one logged joint of one group's best run over one stretch of one task [deg]."""

    engine: str
    tasks: str
    space: str
    task: str
    joint: str
    stretch: str  # "whole task" or a stretch of the schedule
    start: float
    end: float
    samples: int
    untuned: float  # mean |simulated - recorded mean| [deg]
    tuned: float
    tuned_max: float  # largest |tuned - recorded mean| [deg]
    tuned_offset: float  # mean signed tuned - recorded mean [deg]
    repeat_spread: float | None  # mean |recorded repeat - recorded mean| [deg]; None: one repeat


WHOLE_TASK = "whole task"


def joint_errors(
    group: Group,
    task: str,
    spans: list[tuple[str, float, float]],
    times: np.ndarray,
    recorded: tuple[list[str], np.ndarray, np.ndarray],
    simulated: tuple[np.ndarray, np.ndarray],
) -> list[JointError]:
    """Per logged joint of ``task``: its angle error over the whole task, then over each stretch of its schedule.

    Args:
        group: the group whose best run was re-simulated.
        task: the task's name.
        spans: label, start and end [s] of each stretch (:meth:`simtune.tasks.TaskSpec.stretches`).
        times: the recordings' sample times [s].
        recorded: the logged joints' names, their mean angles (n, J) and the repeats (r, n, J) [rad].
        simulated: the untuned and the tuned simulation's angles of those joints (n, J) or longer [rad].
    Returns:
        One entry per joint and stretch, in degrees, the whole task first for each joint.
    """
    names, mean, repeats = recorded
    n = len(times)
    untuned, tuned = (np.degrees(np.asarray(a)[:n]) for a in simulated)
    mean, repeats = np.degrees(mean), np.degrees(repeats)
    spread = np.abs(repeats - mean[None]).mean(axis=0) if len(repeats) > 1 else None
    stretches = [(WHOLE_TASK, float(times[0]), float(times[-1]), np.ones(n, dtype=bool))]
    for i, (label, start, end) in enumerate(spans):
        last = i == len(spans) - 1
        stretches.append((label, start, end, (times >= start) & ((times <= end) if last else (times < end))))
    out = []
    for k, joint in enumerate(names):
        for label, start, end, inside in stretches:
            if not inside.any():
                continue
            tuned_d = tuned[inside, k] - mean[inside, k]
            out.append(
                JointError(
                    group.engine,
                    group.tasks,
                    group.space,
                    task,
                    joint,
                    label,
                    start,
                    end,
                    int(inside.sum()),
                    float(np.abs(untuned[inside, k] - mean[inside, k]).mean()),
                    float(np.abs(tuned_d).mean()),
                    float(np.abs(tuned_d).max()),
                    float(tuned_d.mean()),
                    None if spread is None else float(spread[inside, k].mean()),
                )
            )
    return out


def joint_error_table(entries: list[JointError]) -> Table:
    """The table ``joint_errors``: one row per group, task, logged joint and stretch, in degrees."""
    columns = [
        *(Column(name) for name in ("engine", "tasks", "space", "task", "joint", "stretch")),
        Column("from [s]", ".2f"),
        Column("to [s]", ".2f"),
        Column("samples", "d"),
        Column("untuned [deg]", ".2f"),
        Column("tuned [deg]", ".2f"),
        Column("tuned largest [deg]", ".2f"),
        Column("tuned - recorded [deg]", "+.2f"),
        Column("repeat spread [deg]", ".2f"),
    ]
    rows = [
        [
            e.engine,
            e.tasks,
            e.space,
            e.task,
            e.joint,
            e.stretch,
            e.start,
            e.end,
            e.samples,
            e.untuned,
            e.tuned,
            e.tuned_max,
            e.tuned_offset,
            e.repeat_spread,
        ]
        for e in entries
    ]
    return Table(
        "joint_errors",
        "Where the joint error sits: per logged joint and stretch of each task's schedule",
        columns,
        rows,
        note="Joint logs: the best run of each engine, tasks and space, re-simulated (as the joint-angle figures): "
        "the mean absolute difference between each simulated joint angle and the recorded mean angle, in degrees, "
        "over the whole task and over each stretch of the schedule as the tuned simulation runs it, untuned and "
        "tuned; the tuned one's largest difference and its mean signed offset. Repeat spread: the mean absolute "
        "difference of a recorded repeat from the recorded mean there ('-' with one repeat), how closely the real "
        "arm repeats itself. Averaged over the joints, the whole-task tuned column is the joint error of the tuned "
        "fitness (there in radians).",
    )


# --- contact ---------------------------------------------------------------------------------------------
def contact_table(probes) -> Table:
    """One row per engine and task with an object: ``simtune tasks --contact``'s fields."""
    rows = [
        [
            p.task,
            p.engine,
            "yes" if p.touched else "no",
            p.first_contact_s,
            100.0 * p.object_displacement_m,
            "yes" if p.stable else p.message,
        ]
        for p in probes
    ]
    return Table(
        "contact",
        "Arm-object contact in each engine's generic simulation",
        [
            Column("task"),
            Column("engine"),
            Column("touched"),
            Column("first contact [s]", ".3f"),
            Column("object moved [cm]", ".1f"),
            Column("stable"),
        ],
        rows,
        note="From each engine's own contact list after every physics step (Engine.arm_object_contact): "
        "the first instant an arm or finger shape touches the object, and the distance between the "
        "object's start and end positions.",
    )


# --- 7. compute -------------------------------------------------------------------------------------------
def compute_table(groups: list[Group]) -> Table:
    columns = [
        Column("engine"),
        Column("tasks"),
        Column("space"),
        Column("repeats", "d"),
        Column("evaluations (mean)", ".0f"),
        Column("evaluations (total)", "d"),
        Column("generations (mean)", ".1f"),
        Column("wall time mean [s]", ".1f"),
        Column("wall time total [s]", ".1f"),
        Column("evaluations per second", ".2f"),
        Column("workers"),
        Column("unstable or failed", "d"),
        Column("pruned", "d"),
    ]
    rows = []
    for g in groups:
        evals = [r.record.evaluations for r in g.runs]
        walls = [r.record.elapsed_s for r in g.runs]
        gens = [len(r.record.generations) for r in g.runs]
        workers = sorted({r.config.workers for r in g.runs})
        rows.append(
            [
                g.engine,
                g.tasks,
                g.space,
                len(g.runs),
                float(np.mean(evals)),
                int(sum(evals)),
                float(np.mean(gens)),
                float(np.mean(walls)),
                float(sum(walls)),
                sum(evals) / sum(walls) if sum(walls) > 0 else None,
                " ".join(map(str, workers)),
                sum(r.record.outcomes.get("unstable", 0) for r in g.runs),
                sum(r.record.outcomes.get("pruned", 0) for r in g.runs),
            ]
        )
    return Table(
        "compute",
        "Compute per engine, tasks and space",
        columns,
        rows,
        note="Wall time is the run's elapsed time over all its sessions (meta elapsed_s); evaluations "
        "count the distinct parameter sets simulated. Unstable or failed: simulations that blew up "
        "(or whose worker crashed or hung) and scored the penalty fitness. Pruned: trials stopped "
        "once they could no longer beat their parent (their stored fitness is a lower bound).",
    )


# --- 8. domain-randomisation ranges ----------------------------------------------------------------------
def dr_table(ranges: dict[str, dict[str, dict]]) -> Table:
    columns = [
        Column("engine"),
        Column("parameter"),
        Column("min", ".4g"),
        Column("max", ".4g"),
        Column("nominal", ".4g"),
        Column("low bound", ".4g"),
        Column("high bound", ".4g"),
        Column("unit"),
        Column("runs", "d"),
    ]
    rows = [
        [engine, name, p["min"], p["max"], p["nominal"], p["bounds"][0], p["bounds"][1], p["unit"], p["runs"]]
        for engine, params in ranges.items()
        for name, p in params.items()
    ]
    return Table(
        "dr_ranges",
        "Domain-randomisation ranges (as in dr_ranges.yaml)",
        columns,
        rows,
        note="Per engine and parameter: the range the tuned values span across all its runs (every task "
        "and space), and the nominal (generic) value. Randomising a simulation over these ranges "
        "covers what tuning found plausible.",
    )


#: a floor cell where a task has one repeat (``simtune check``'s words: :func:`simtune.check.project.floor_words`)
NO_FLOOR = "no floor: one repeat"


def floor_table(
    floors: list[RepeatFloor], references: list[str], joint_spreads: dict[str, float] | None = None
) -> Table:
    """Each task's repeat spread with and without the clocks aligned, and the floor of its fitness.

    Args:
        floors: each task's :class:`RepeatFloor` (:func:`simtune.fitness.reference_floor`).
        references: what the runs were re-scored against, as the report names it.
        joint_spreads: task -> the mean absolute angle difference [deg] of an aligned repeat's logged joints from
            the aligned mean, for the tasks whose recordings log joint angles (None or empty: none do).
    Returns:
        The table ``floor``.
    """
    joint_spreads = joint_spreads or {}
    # a joint log's floor is a fraction of a degree times 0.5 m/rad: significant digits, not four decimals
    floor_format = ".3g" if joint_spreads else ".4f"
    columns = [
        Column("task"),
        Column("repeats", "d"),
        Column("spread as recorded [mm]", ".1f"),
        Column("spread aligned [mm]", ".1f"),
        *([Column("joint spread aligned [deg]", ".3f")] if joint_spreads else []),
        Column("shifts from [s]", "+.3f"),
        Column("shifts to [s]", "+.3f"),
        Column("outlying shifts"),
        Column("floor (aligned mean vs repeats)", floor_format),
    ]
    rows = [
        [
            f.task,
            f.repeats,
            None if f.spread_unaligned_m is None else 1000 * f.spread_unaligned_m,
            None if f.spread_aligned_m is None else 1000 * f.spread_aligned_m,
            *([joint_spreads.get(f.task) if f.repeats > 1 else None] if joint_spreads else []),
            f.shift_min_s,
            f.shift_max_s,
            ", ".join(f.outliers) or "none",
            NO_FLOOR if f.floor is None else f.floor,
        ]
        for f in floors
    ]
    joints = (
        " Joint spread: the mean absolute difference of a repeat's logged joint angles from the aligned mean; a joint "
        "log's floor is its joint term, the joint weight x that difference in radians."
        if joint_spreads
        else ""
    )
    single = f" {floor_words(None).capitalize()}." if any(f.floor is None for f in floors) else ""
    return Table(
        "floor",
        "The floor: the real arm against itself",
        columns,
        rows,
        note="Spread: the mean distance of a repeat's wrist from the repeats' mean, on the repeats' own clocks and "
        "with each repeat's clock shifted onto the task's (its motion onset, refined against the other repeats). "
        "Floor: the fitness of the aligned mean against each repeat, as a simulation is scored: what a simulation "
        f"as good as the arm's own repeats scores.{joints}{single} The runs here were scored against: "
        f"{', '.join(references)}.",
    )


# --- held-out repeats ---------------------------------------------------------------------------------------
def held_out_table(sims: list[GroupSimulation]) -> Table:
    """Each best run tuned on some repeats (``--repeats even``/``odd``): its tuned fitness per task on those and on
    the held-out others (``sims``: re-simulated groups; those without a held-out score give no row).

    Args:
        sims: the report's re-simulated groups (:class:`simtune.report.simulate.GroupSimulation`).
    Returns:
        The table ``held_out``.
    """
    rows = []
    for sim in sims:
        held = sim.held_out
        if held is None or held.score is None:
            continue
        for part in held.score.tasks:
            tuned = sim.tasks[part.task].tuned_score.fitness if part.task in sim.tasks else None
            rows.append(
                [
                    sim.group.engine,
                    sim.group.tasks,
                    sim.group.space,
                    part.task,
                    sim.run.label,
                    sim.run.config.repeats,
                    held.selection,
                    held.repeats.get(part.task),
                    tuned,
                    part.fitness,
                    None if not tuned else part.fitness / tuned,
                    None if part.wrist_error is None else 1000.0 * part.wrist_error,
                    None if part.joint_error is None else math.degrees(part.joint_error),
                ]
            )
    return Table(
        "held_out",
        "Held-out repeats: the tuned parameters scored on repeats they were not fitted to",
        [
            *(Column(name) for name in ("engine", "tasks", "space", "task", "run", "tuned on", "scored on")),
            Column("held-out repeats", "d"),
            Column("tuned fitness", ".4g"),
            Column("held-out fitness", ".4g"),
            Column("held-out / tuned", ".2f"),
            Column("held-out wrist error [mm]", ".1f"),
            Column("held-out joint error [deg]", ".2f"),
        ],
        rows,
        note="The best run of each engine, tasks and space tuned with --repeats even (or odd): its best parameters "
        "scored on the repeats it was tuned on (tuned fitness) and on the others (held-out fitness), with the same "
        "weights; held-out / tuned near 1: the tuning fits the arm, not the noise of the repeats it saw. The same "
        "as `simtune evaluate --params-file RUN/best_params.json --repeats odd` (docs/tuning.md, held-out repeats).",
    )


# --- appendix: every run ---------------------------------------------------------------------------------
def runs_table(runs: list[ReportedRun]) -> Table:
    with_joints = bool(joint_log_runs(runs))  # a joint error column where recordings log joint angles
    columns = [
        Column("run"),
        Column("engine"),
        Column("tasks"),
        Column("space"),
        Column("seed", "d"),
        Column("parameters", "d"),
        Column("generic fitness", ".4f"),
        Column("best fitness", ".4f"),
        Column("wrist error [m]", ".4f"),
        Column("object error [m]", ".4f"),
        *([Column("joint error [deg]", ".2f")] if with_joints else []),
        Column("generations", "d"),
        Column("evaluations", "d"),
        Column("wall time [s]", ".1f"),
        Column("stopped"),
        Column("stop reason"),
    ]
    rows = [
        [
            r.label,
            r.engine,
            r.tasks,
            r.space,
            r.config.seed,
            len(r.parameters),
            r.generic_fitness,
            r.best_fitness,
            _f(r.best_score.get("wrist_error")),
            _f(r.best_score.get("object_error")),
            *([_degrees(r.best_score.get("joint_error"))] if with_joints else []),
            len(r.record.generations),
            r.record.evaluations,
            r.record.elapsed_s,
            r.record.stop_reason or "",
            r.message,
        ]
        for r in runs
    ]
    return Table(
        "runs",
        "Every run in the report",
        columns,
        rows,
        note="Best fitness = the run's best stored evaluation. Stopped: converged (the search met its own "
        "criterion), max-seconds, max-evaluations, max-generations or target-fitness (a budget), finished (the "
        "optimiser ended by itself); empty for runs stored before it was kept.",
    )
