"""Load finished tuning runs into plain records, and group them into repeats.

A *run dir* holds ``run.sqlite`` (made by ``simtune tune``); a *grid dir* is
any folder with run dirs somewhere below it.  Each run is read through
:func:`simtune.runs.read_run_record` (read-only), so a report never changes a run,
not even a broken one; :class:`ReportedRun` is the report's checked view of its record.  A run that is not
finished, or whose store cannot be read, is returned as a :class:`Skipped`
entry naming the folder and the reason: the report warns about it and leaves
it out, it never merges it silently.
"""

from __future__ import annotations

import json
import sqlite3
from collections import defaultdict
from dataclasses import dataclass, field
from functools import cached_property
from pathlib import Path

import numpy as np

from simtune.errors import SimtuneError
from simtune.fitness import Score
from simtune.optimize.pipeline import global_population_size, random_start
from simtune.run_plan import RunConfig
from simtune.runs import read_run_record
from simtune.store import STORE_FILE, RunRecord, RunStore, RunView
from simtune.tasks import TaskSpec, get_task


@dataclass(eq=False)
class ReportedRun(RunView[RunConfig]):
    """The report's view of one finished run's record (:func:`simtune.runs.read_run_record`), checked by
    :func:`reported_run`: what the tables, figures and sections read of it."""

    label: str  # the folder, as shown in the report
    #: the run's tasks, from ``project``, with the targets the run ran (resolved once, by :func:`reported_run`)
    task_specs: list[TaskSpec]
    project: str | None = None  # the project (file or folder) of its tasks; None: the bundled MICO project
    #: the parameter sets the run drew at random over its box before any search step (:func:`untuned_sample`)
    random_start: list[list[float]] = field(default_factory=list)
    random_start_fitness: list[float] = field(default_factory=list)  # of those of them it scored

    @property
    def path(self) -> Path:
        return self.record.path

    @property
    def tasks(self) -> str:
        """The tasks as configured: "cube" or "single,cube"."""
        return self.record.tasks

    @property
    def task_names(self) -> list[str]:
        return [t.name for t in self.task_specs]

    def task(self, name: str) -> TaskSpec:
        """The definition of the run's task ``name``, from the run's project, with the targets the run ran."""
        found = next((t for t in self.task_specs if t.name == name), None)
        return get_task(name, self.project, self.config.targets, self.config.loading) if found is None else found

    @cached_property
    def parameters(self) -> list[str]:
        """The searched parameters, in the order of a vector."""
        return self.record.searched

    @cached_property
    def bounds(self) -> list[tuple[float, float]]:
        return [(float(lo), float(hi)) for lo, hi in self.record.bounds or []]

    @property
    def generic(self) -> dict:
        """Score.to_dict() of the engine's generic parameters."""
        return self.record.generic_score

    @cached_property
    def best_x(self) -> list[float]:
        return [float(v) for v in self.record.best_evaluation["x"]]

    @property
    def best_score(self) -> dict:
        """Score.to_dict() of the best evaluation."""
        return self.record.best_evaluation["score"]

    @property
    def message(self) -> str:
        return str(self.record.message or "")

    @property
    def stopped_by_time_cap(self) -> bool:
        """Whether the run's wall-time budget (``--max-seconds``) ended its search."""
        cap = self.config.max_seconds
        return cap is not None and self.record.elapsed_s >= float(cap)

    @property
    def population_size(self) -> int:
        """Members of the differential evolution's population (``auto``: of its global phases); any other
        optimiser: its first batch of evaluations."""
        if self.config.optimizer == "auto":
            return global_population_size(len(self.parameters))
        return len(self.record.initial_fitness)

    @property
    def best_fitness(self) -> float:
        """The best evaluation's fit to the data: without a prior's penalty (``--prior``), comparable across runs."""
        return Score.from_dict(self.best_score).data_fitness

    @property
    def best_params(self) -> dict[str, float]:
        return dict(zip(self.parameters, self.best_x))

    @property
    def generic_fitness(self) -> float:
        return float(self.generic["fitness"])

    def task_score(self, score: dict, task: str) -> dict | None:
        """The part of ``score`` (a Score dict) that belongs to ``task``."""
        for part in score.get("tasks", []):
            if part.get("task") == task:
                return part
        return None

    @property
    def group_key(self) -> tuple[str, str, str]:
        return (self.engine, self.tasks, self.space)


@dataclass
class Skipped:
    """A run folder left out of the report, and why."""

    path: Path
    label: str
    reason: str


@dataclass
class Group:
    """The repeats (different seeds) of one configuration: engine x tasks x space."""

    engine: str
    tasks: str
    space: str
    runs: list[ReportedRun]

    @property
    def key(self) -> tuple[str, str, str]:
        return (self.engine, self.tasks, self.space)

    @property
    def task_names(self) -> list[str]:
        return self.runs[0].task_names

    @property
    def best_run(self) -> ReportedRun:
        return min(self.runs, key=lambda r: (r.best_fitness, r.config.seed))

    @property
    def searched(self) -> list[str]:
        """Union of the parameter names in the repeats' search vectors, in first-seen order (D)."""
        names: list[str] = []
        for run in self.runs:
            names.extend(n for n in run.parameters if n not in names)
        return names

    @property
    def inactive(self) -> dict[str, str]:
        """Parameters that change no rollout of the group's tasks in some repeat, and why."""
        found: dict[str, str] = {}
        for run in self.runs:
            found.update({n: why for n, why in run.record.inactive.items() if n not in found})
        return found

    @property
    def parameters(self) -> list[str]:
        """The searched parameters that can act: those whose values importance and ranges may pool."""
        inactive = self.inactive
        return [n for n in self.searched if n not in inactive]

    def bounds(self, name: str) -> tuple[float, float]:
        for run in self.runs:
            if name in run.parameters:
                low, high = run.bounds[run.parameters.index(name)]
                return float(low), float(high)
        raise KeyError(name)

    def values(self, name: str) -> list[float]:
        """Tuned value of ``name`` in each repeat that tuned it (best evaluation)."""
        return [r.best_params[name] for r in self.runs if name in r.parameters]

    @property
    def label(self) -> str:
        return f"{self.engine} / {self.tasks} / {self.space}"


def find_run_dirs(paths: list[Path]) -> list[Path]:
    """Run folders named by ``paths``: each is a run folder, or a folder searched recursively for them."""
    found: list[Path] = []
    for path in paths:
        path = Path(path)
        if not path.exists():
            raise SimtuneError(f"{path}: no such run or grid folder")
        if path.is_file():
            raise SimtuneError(f"{path}: not a folder (give a run folder or a folder of runs)")
        if (path / STORE_FILE).exists():
            candidates = [path]
        else:
            candidates = sorted(p.parent for p in path.rglob(STORE_FILE))
            if not candidates:
                raise SimtuneError(f"{path}: no run folders ({STORE_FILE}) in it or below it")
        for c in candidates:
            if c.resolve() not in {f.resolve() for f in found}:
                found.append(c)
    return found


def load_run(run_dir: Path, label: str | None = None, project: str | None = None) -> ReportedRun | Skipped:
    """A finished run as a :class:`ReportedRun`, or a :class:`Skipped` saying why it cannot be used.

    ``project``: read its tasks from this project folder instead of the one the run names (moved since).
    """
    run_dir = Path(run_dir)
    try:
        record = read_run_record(run_dir)
    except SimtuneError as exc:
        return Skipped(run_dir, label or str(run_dir), f"unusable run store: {exc}")
    except (json.JSONDecodeError, KeyError, TypeError, ValueError) as exc:
        return Skipped(run_dir, label or str(run_dir), f"unusable run store: {type(exc).__name__}: {exc}")
    return reported_run(record, label, project)


def reported_run(
    record: RunRecord[RunConfig], label: str | None = None, project: str | None = None
) -> ReportedRun | Skipped:
    """The report's view of ``record``, its values checked, or a :class:`Skipped` saying why it cannot be used.

    ``label``: the run as the report names it (default: its folder); ``project``: as :func:`load_run`'s.
    """
    run_dir = record.path
    label = label or str(run_dir)
    try:
        config = record.settings
        unfinished = record.unfinished()
        if unfinished is not None:
            return Skipped(run_dir, label, unfinished)
        record.check_result()
        project = project or config.project
        tasks = record.resolve_tasks(project)
        random_members, random_fitness = untuned_sample(record)
        return ReportedRun(record, label, tasks, project, random_members, random_fitness)
    except sqlite3.Error as exc:
        return Skipped(run_dir, label, f"corrupt run store ({exc})")
    except SimtuneError as exc:
        return Skipped(run_dir, label, f"unusable run store: {exc}")
    except (json.JSONDecodeError, KeyError, TypeError, ValueError) as exc:
        return Skipped(run_dir, label, f"unusable run store: {type(exc).__name__}: {exc}")


#: how close a stored evaluation must be to a drawn member of ``auto``'s random start, as a share of each range, to be
#: its score: SciPy's DE maps its population through its own scaling (last-bit differences) and a lean store keeps
#: float32 copies of most vectors (7 digits)
MATCH_TOLERANCE = 1e-5


def untuned_sample(stored: RunRecord[RunConfig]) -> tuple[list[list[float]], list[float]]:
    """The parameter sets ``stored`` drew at random over its whole box before any search step, and the fitness of
    those it scored: the report's untuned baseline (the spread test of the parameter importance table, the untuned
    sample of the Mann-Whitney table).

    - ``auto``: the latin-hypercube half of its first global phase, drawn again from the run's seed
      (:func:`simtune.optimize.pipeline.random_start`; its generation 0 is the opening's start and Jacobian, all
      within a few per cent of the generic point); the fitness of those found among its evaluations (a run that
      reached its target, or the noise floor, in the opening scored none of them);
    - a run that ``resume --rescore`` started from an earlier run's population: none (it started from that);
    - any other optimiser: its generation 0 (differential evolution: a latin hypercube; random search: uniform
      draws; CMA-ES: its first population, spread 0.3 of each range around the centre; Bayes: its first trials).
    """
    if stored.rescored_from:
        return [], []
    if stored.optimizer != "auto":
        return stored.initial_population, stored.initial_fitness
    bounds = np.array(stored.bounds, dtype=float).reshape(-1, 2)
    lows, highs = bounds[:, 0], bounds[:, 1]
    widths = np.where(highs > lows, highs - lows, 1.0)  # a fixed parameter: compared as it is
    unit = random_start(len(bounds), stored.settings.seed)
    drawn = np.clip(lows + unit * (highs - lows), lows, highs)  # as the search mapped them (BatchSearch.from_unit)
    store = RunStore.open_read_only(stored.path)
    try:
        scored = [e for e in store.evaluations() if e["x"] is not None and e["generation"] > 0]
    finally:
        store.close()
    fitness: list[float] = []
    if scored:
        stored_unit = (np.array([e["x"] for e in scored], dtype=float) - lows) / widths
        for member in unit:
            hits = np.flatnonzero(np.abs(stored_unit - member).max(axis=1) <= MATCH_TOLERANCE)
            if hits.size:
                fitness.append(float(scored[hits[0]]["fitness"]))
    return drawn.tolist(), fitness


def group_runs(runs: list[ReportedRun]) -> tuple[list[Group], list[Skipped]]:
    """Group runs by (engine, tasks, space); a second run with the same seed is left out (not a new repeat)."""
    by_key: dict[tuple[str, str, str], list[ReportedRun]] = defaultdict(list)
    duplicates: list[Skipped] = []
    for run in runs:
        seed = run.config.seed
        same = [r for r in by_key[run.group_key] if r.config.seed == seed]
        if same:
            duplicates.append(
                Skipped(
                    run.path,
                    run.label,
                    f"same engine, tasks, space and seed {seed} as {same[0].label}: not a new repeat, left out",
                )
            )
            continue
        by_key[run.group_key].append(run)
    groups = [Group(*key, runs=sorted(rs, key=lambda r: r.config.seed)) for key, rs in by_key.items()]
    groups.sort(key=lambda g: (g.tasks, g.space, g.engine))
    return groups, duplicates
