"""Assemble the report: read the runs, compute what the sections share, make the sections, write index.html.

The sections themselves are in :mod:`simtune.report.sections`, one function each.
"""

from __future__ import annotations

import datetime as _dt
import tempfile
import warnings
from collections.abc import Callable, Iterable
from pathlib import Path

import numpy as np
from rich.console import Console
from rich.progress import BarColumn, MofNCompleteColumn, Progress, TaskID, TextColumn, TimeElapsedColumn

import simtune
from simtune.data import check_repeats
from simtune.data.clock import check_reference
from simtune.engines.contact import ContactProbe, probe_contact
from simtune.errors import RecordingWarning, SimtuneError
from simtune.fitness import RepeatFloor, reference_floor
from simtune.report import tables as T
from simtune.report.collect import Group, ReportedRun, Skipped, find_run_dirs, group_runs, load_run
from simtune.report.folder import INDEX, SUBFOLDERS, install, owned_files
from simtune.report.html import render
from simtune.report.published import PublishedSim, find_published, score_published
from simtune.report.sections import ReportData, ReportOutput, make_sections
from simtune.report.simulate import GroupSimulation, References, nominal_values, run_weights, simulate_group
from simtune.tasks import TaskSpec

Warn = Callable[[str], None]


class ReportWarning(UserWarning):
    """A run folder or file left out of the report, or a doubt about what it shows."""


class _Progress:
    """A Rich progress bar on stderr for the report's steps (silent when disabled)."""

    def __init__(self, enabled: bool):
        self._bar = Progress(
            TextColumn("[bold]report[/]"),
            BarColumn(),
            MofNCompleteColumn(),
            TextColumn("{task.description}"),
            TimeElapsedColumn(),
            console=Console(stderr=True),
            disable=not enabled,
        )
        self._task = TaskID(0)

    def __enter__(self) -> _Progress:
        self._bar.__enter__()
        self._task = self._bar.add_task("reading runs", total=None)
        return self

    def __exit__(self, *exc) -> None:
        self._bar.__exit__(*exc)

    def stage(self, description: str, total: int) -> None:
        self._bar.update(self._task, description=description, total=total, completed=0)

    def describe(self, description: str) -> None:
        self._bar.update(self._task, description=description)

    def step(self) -> None:
        self._bar.advance(self._task)

    def finish(self) -> None:
        task = self._bar.tasks[0]
        self._bar.update(self._task, description="done", completed=task.total)


def make_report(
    paths: Iterable[Path | str] | Path | str,
    out: Path | str,
    published_sims: Path | str | None = None,
    *,
    show_progress: bool = True,
    figure4_parameter: str = "timestep",
    project: Path | str | None = None,
    reference: str | None = None,
    repeats: str | None = None,
) -> Path:
    """Write the report for the runs under ``paths`` into ``out``; return the path of its ``index.html``.

    Run folders that are unfinished or unreadable are left out with a
    :class:`ReportWarning` naming them.  Raises :class:`SimtuneError` when no
    usable run is found, or for an unknown ``figure4_parameter`` (the parameter
    of the paper's Figure 4), or when ``out`` holds files that no simtune report wrote
    (:mod:`simtune.report.folder`).  The report is drawn in a scratch folder and moved into ``out``
    only once complete: an error leaves ``out`` as it was, and only the files of an earlier report
    there are ever replaced or removed.  ``project``: read the runs' tasks from this project folder instead of
    the one each run names (for a project moved since the runs).  ``reference``: re-score every run against
    ``aligned`` or ``mean``; None: each against its own (a run stored before the choice: the mean).  ``repeats``:
    re-score every run against the ``all``, ``even`` or ``odd`` repeats of each task; None: each against its own.
    """
    from simtune.params.space import PARAMETERS

    if figure4_parameter not in PARAMETERS:
        raise SimtuneError(f"--figure4-parameter {figure4_parameter!r}: unknown parameter (see `simtune params`)")
    inputs = [Path(p) for p in ([paths] if isinstance(paths, (str, Path)) else paths)]
    run_dirs = find_run_dirs(inputs)
    published_folder = None if published_sims is None else Path(published_sims)
    if published_folder is not None and not published_folder.is_dir():
        raise SimtuneError(f"--published-sims {published_sims}: no such folder")
    references = References(
        None if reference is None else check_reference(reference, "--reference"),
        None if repeats is None else check_repeats(repeats, "--repeats"),
    )
    folder = Path(out)
    owned_files(folder)  # a folder of someone else's files is refused now, not after minutes of drawing
    with tempfile.TemporaryDirectory(prefix="simtune-report-") as scratch:
        _draw(inputs, run_dirs, published_folder, references, Path(scratch), show_progress, figure4_parameter, project)
        install(Path(scratch), folder)
    return folder / INDEX


def _draw(
    inputs: list[Path],
    run_dirs: list[Path],
    published_folder: Path | None,
    references: References,
    folder: Path,
    show_progress: bool,
    figure4_parameter: str,
    project: Path | str | None,
) -> None:
    """Write the whole report into ``folder`` (an empty scratch folder); the arguments as
    :func:`make_report` checked them."""
    for sub in SUBFOLDERS:
        (folder / sub).mkdir()

    problems: list[str] = []  # shown as warnings and at the top of the report

    def warn(message: str) -> None:
        problems.append(message)
        warnings.warn(message, ReportWarning, stacklevel=3)

    with _Progress(show_progress) as progress:
        progress.stage("reading runs", len(run_dirs))
        groups = _read_runs(run_dirs, warn, progress.step, None if project is None else str(project))
        if not groups:
            raise SimtuneError(
                f"no finished runs to report in {', '.join(map(str, inputs))} "
                f"({len(run_dirs)} run folder(s), none usable: see the warnings)"
            )
        engines = sorted({g.engine for g in groups})
        experiments = {(g.tasks, g.space) for g in groups}
        # overview, convergence x 3, Figure 4, contact per engine, parameters per experiment, trajectories
        figures = 5 + len(engines) + len(experiments) + sum(len(g.task_names) for g in groups)
        progress.stage("scoring published simulations", 1 + len(engines) + len(groups) + figures + 1)
        entries, published = _generic_entries(groups, published_folder, references, warn)
        progress.step()
        progress.describe("nominal parameter values")
        nominal, tasks_by_engine = _nominal_values(groups, warn, progress.step)
        floors, joint_spreads = _floors(groups, references, warn)
        data = ReportData(
            paths=inputs,
            groups=groups,
            entries=entries,
            published=[(sim, rollout) for sim, _, rollout in published],
            published_folder=published_folder,
            nominal=nominal,
            tasks_by_engine=tasks_by_engine,
            sims=_resimulate(groups, references, warn, progress),
            figure4_parameter=figure4_parameter,
            contacts=_probe_contacts(groups, warn, progress),
            floors=floors,
            joint_spreads=joint_spreads,
            references=sorted({references.label(r) for g in groups for r in g.runs}),
        )

        progress.describe("drawing figures and writing tables")
        sections = make_sections(data, ReportOutput(folder, warn, progress.step))
        progress.describe("writing index.html")
        (folder / INDEX).write_text(render("simtune report: simulator tuning results", _meta(data), problems, sections))
        progress.finish()


def _generic_entries(
    groups: list[Group], published_folder: Path | None, references: References, warn: Warn
) -> tuple[list[T.GenericEntry], list[tuple]]:
    """The generic fitness of each engine and task, with the published simulations' (scored here, as
    :func:`_score_published` returns them) as entries of their own."""
    entries, notes = T.generic_entries(groups)
    for note in notes:
        warn(note)
    published = _score_published(published_folder, groups, references, warn) if published_folder else []
    entries += [
        T.GenericEntry(
            sim.engine, "published", "", sim.task, score.fitness, score.wrist_error, score.object_error, score.stable
        )
        for sim, score, _ in published
    ]
    return entries, published


def _floors(groups: list[Group], references: References, warn: Warn) -> tuple[list[RepeatFloor], dict[str, float]]:
    """Each task's repeats against their aligned mean (:func:`simtune.fitness.reference_floor`, with the fitness
    weights of the first run that has it, from its data), as ReportData's ``floors``; and, as its
    ``joint_spreads``, each joint-log task's mean absolute angle difference of an aligned repeat from the aligned
    mean [deg].  A task whose recordings cannot be read is named in a warning and left out."""
    floors: list[RepeatFloor] = []
    joint_spreads: dict[str, float] = {}
    for name in dict.fromkeys(t for g in groups for t in g.task_names):
        run = next(r for g in groups if name in g.task_names for r in g.runs)
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore", RecordingWarning)  # said when the runs were tuned
                aligned = references.get(
                    run.config.data, run.task(name), "aligned", references.selection(run), run.config.keep_repeats
                )
        except SimtuneError as exc:
            warn(f"task {name}: no floor: its recordings are unavailable ({exc})")
            continue
        floors.append(reference_floor(aligned, run_weights(run)))
        if aligned.joint_mean is not None and aligned.joint_repeats is not None:
            joint_spreads[name] = float(np.degrees(np.abs(aligned.joint_repeats - aligned.joint_mean[None]).mean()))
    return floors, joint_spreads


def _read_runs(run_dirs: list[Path], warn: Warn, step: Callable[[], None], project: str | None) -> list[Group]:
    """The finished runs, grouped into repeats; every folder left out is named in a warning."""
    runs: list[ReportedRun] = []
    for d in run_dirs:
        loaded = load_run(d, project=project)
        if isinstance(loaded, Skipped):
            warn(f"{loaded.label}: skipped: {loaded.reason}")
        else:
            runs.append(loaded)
        step()
    groups, duplicates = group_runs(runs)
    for dup in duplicates:
        warn(f"{dup.label}: skipped: {dup.reason}")
    return groups


def _score_published(folder: Path, groups: list[Group], references: References, warn: Warn) -> list[tuple]:
    """(simulation, score, rollout) of each readable published simulation of a task the runs have."""
    task_names = list(dict.fromkeys(t for g in groups for t in g.task_names))
    scored = []
    for item in find_published(folder, task_names):
        if not isinstance(item, PublishedSim):
            warn(f"{item[0]}: skipped: {item[1]}")
            continue
        run = next(r for g in groups if item.task in g.task_names for r in g.runs)
        try:
            reference = references.get(
                run.config.data,
                run.task(item.task),
                references.kind(run),
                references.selection(run),
                run.config.keep_repeats,
            )
        except SimtuneError as exc:
            warn(f"{item.path}: not scored: recordings of {item.task!r} unavailable ({exc})")
            continue
        score, rollout = score_published(item, reference)
        scored.append((item, score, rollout))
    if not scored:
        warn(f"--published-sims {folder}: no files <task>_<Engine>.csv for the tasks {', '.join(task_names)}")
    return scored


def _nominal_values(
    groups: list[Group], warn: Warn, step: Callable[[], None]
) -> tuple[dict[str, dict[str, float]], dict[str, list[str]]]:
    """Each engine's generic parameter values, and the tasks its runs cover."""
    nominal: dict[str, dict[str, float]] = {}
    tasks_by_engine: dict[str, list[str]] = {}
    for engine in sorted({g.engine for g in groups}):
        tasks = _engine_tasks(groups, engine)
        tasks_by_engine[engine] = [t.name for t in tasks]
        try:
            nominal[engine] = nominal_values(engine, tasks)
        except SimtuneError as exc:
            warn(f"engine {engine}: no nominal values ({exc})")
            nominal[engine] = {}
        step()
    return nominal, tasks_by_engine


def _engine_tasks(groups: list[Group], engine: str) -> list[TaskSpec]:
    """The tasks of ``engine``'s runs, each once, as their runs' projects define them."""
    tasks: dict[str, TaskSpec] = {}
    for g in groups:
        if g.engine == engine:
            for name in g.task_names:
                tasks.setdefault(name, g.best_run.task(name))
    return list(tasks.values())


def _resimulate(groups: list[Group], references: References, warn: Warn, progress: _Progress) -> list[GroupSimulation]:
    """The best run of each group simulated again; a fitness other than the stored one is warned about."""
    sims: list[GroupSimulation] = []
    for g in groups:
        progress.describe(f"re-simulating {g.label}")
        try:
            sim = simulate_group(g, references)
        except SimtuneError as exc:
            warn(f"{g.label}: trajectories not drawn ({exc})")
            continue
        finally:
            progress.step()
        stored, run = g.best_run.best_fitness, g.best_run
        # re-scored against another reference or other repeats than its own, the fitness differs by design
        own = references.kind(run) == run.config.reference and references.selection(run) == run.config.repeats
        if own and abs(sim.tuned_fitness - stored) > 1e-6 * max(1.0, abs(stored)):
            warn(
                f"{g.best_run.label}: re-simulating its best parameters gives fitness {sim.tuned_fitness:.6f}, "
                f"the store has {stored:.6f} (different engine version or recordings?)"
            )
        sims.append(sim)
    return sims


def _probe_contacts(groups: list[Group], warn: Warn, progress: _Progress) -> list[ContactProbe]:
    """Each engine's generic simulation of each of its tasks with an object, watched for arm-object contact."""
    from simtune.engines import make_engine

    probes: list[ContactProbe] = []
    for engine in sorted({g.engine for g in groups}):
        for task in _engine_tasks(groups, engine):
            name = task.name
            if task.object is None:
                continue
            progress.describe(f"contact: {engine} on {name}")
            try:
                sim = make_engine(engine, task)
            except SimtuneError as exc:
                warn(f"engine {engine}: no contact probe of {name} ({exc})")
                break
            try:
                probes.append(probe_contact(sim))
            finally:
                sim.close()
    return probes


def _meta(data: ReportData) -> list[str]:
    """The lines under the report's title: version, date, inputs, and what the runs cover."""
    published = f"; published simulations: {data.published_folder}" if data.published_folder is not None else ""
    exact = [r for r in data.runs if r.config.paper_exact]
    search = (
        f"Search: {len(exact)} of {len(data.runs)} runs searched exactly as the paper ran SciPy (--paper-exact: "
        "immediate updating, SciPy's polish, one worker, no pruning, the paper's whole parameter list); "
        "the others with simtune's differential evolution (deferred updating, pruning, no polish) or another "
        "optimiser, as Table III's search column says."
    )
    return [
        f"simtune {simtune.__version__}, {_dt.datetime.now().astimezone().strftime('%Y-%m-%d %H:%M %Z')}. "
        f"Inputs: {', '.join(str(p) for p in data.paths)}{published}.",
        f"{len(data.runs)} run{'s' * (len(data.runs) != 1)} in {len(data.groups)} group{'s' * (len(data.groups) != 1)} "
        "(engine x tasks x space; repeats = seeds): engines "
        f"{', '.join(data.engines)}; tasks {', '.join(sorted({g.tasks for g in data.groups}))}; spaces "
        f"{', '.join(sorted({g.space for g in data.groups}))}. {T.fitness_unit(data.runs)}",
        search,
    ]
