"""The report's sections, one function each, in the order they appear.

Each section function takes the :class:`ReportData` (the runs and what was computed
from them once) and the :class:`ReportOutput` (which writes its tables and figures
into the report folder) and returns its :data:`Body` (introduction and items), or
None to leave it out.  :data:`SECTIONS` names each with its anchor and title; the
builder numbers them in order and appends those of :data:`APPENDICES` unnumbered:
adding, removing or moving a section is one line there, and :func:`write_docs` writes
docs/report.md's list of the sections from the same lines.  The tables are numbered as
they are written, in the order the page shows them (:meth:`ReportOutput.table`).
"""

from __future__ import annotations

import html
import json
import re
import textwrap
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np
from matplotlib.figure import Figure

from simtune.common.table import Table
from simtune.engines import Rollout
from simtune.engines.contact import ContactProbe
from simtune.fitness import RepeatFloor
from simtune.report import figures as F
from simtune.report import tables as T
from simtune.report.collect import Group, ReportedRun
from simtune.report.dr import dr_ranges, write_dr_yaml
from simtune.report.folder import DR_FILE
from simtune.report.headline import headline_table, moved_parameters_table
from simtune.report.html import FigureRef, Section
from simtune.report.joint_fit import alone_bests, joint_fit_table, read_studies, study_table
from simtune.report.published import PublishedSim
from simtune.report.simulate import GroupSimulation
from simtune.tasks import TaskSpec


@dataclass
class ReportData:
    """The report's runs, grouped into repeats, and what the sections share, computed once."""

    paths: list[Path]  # the folders given
    groups: list[Group]
    entries: list[T.GenericEntry]  # generic fitness per engine and task, published simulations included
    published: list[tuple[PublishedSim, Rollout]]  # the published simulations scored, and their rollouts
    published_folder: Path | None  # --published-sims, if given
    nominal: dict[str, dict[str, float]]  # engine -> generic parameter values
    tasks_by_engine: dict[str, list[str]]
    sims: list[GroupSimulation]  # the best run of each group, re-simulated
    figure4_parameter: str = "timestep"  # the parameter of the paper's Figure 4
    contacts: list[ContactProbe] = field(default_factory=list)  # each engine's generic contact with each object
    floors: list[RepeatFloor] = field(default_factory=list)  # each task's repeats against their aligned mean
    #: task -> mean absolute angle difference of an aligned repeat's logged joints from the aligned mean [deg]
    joint_spreads: dict[str, float] = field(default_factory=dict)
    references: list[str] = field(default_factory=list)  # what the runs were re-scored against

    @property
    def runs(self) -> list[ReportedRun]:
        return [r for g in self.groups for r in g.runs]

    def task(self, name: str) -> TaskSpec:
        """The definition of task ``name``, from the project of the first run that has it."""
        return next(g.best_run.task(name) for g in self.groups if name in g.task_names)

    @property
    def task_names(self) -> list[str]:
        names: list[str] = []
        for g in self.groups:
            names.extend(t for t in g.task_names if t not in names)
        return names

    @property
    def engines(self) -> list[str]:
        return sorted({g.engine for g in self.groups})

    @property
    def experiments(self) -> list[tuple[str, str]]:
        """(tasks, space) of every group, sorted: the panels of the figures per experiment."""
        return sorted({(g.tasks, g.space) for g in self.groups})


@dataclass
class ReportOutput:
    """Writes a section's tables and figures into the report folder as the section makes them."""

    folder: Path
    warn: Callable[[str], None]  # a ReportWarning, also listed at the top of the report
    on_figure: Callable[[], None] = lambda: None  # progress: one more figure drawn
    numbers: dict[str, int] = field(default_factory=dict)  # anchor -> number of the sections made so far
    drawn: dict[str, FigureRef] = field(default_factory=dict)  # stem -> a figure already drawn (figure_once)
    tables: int = 0  # how many tables were written so far: the last one's number

    def table(self, table: Table) -> Table:
        """Number ``table`` ("Table N. title": the next number, so the tables count up in the order the sections
        write them, which is the order the page shows them), write ``tables/<name>.csv`` and ``.md``; return the
        numbered table for the page."""
        self.tables += 1
        table = replace(table, title=f"Table {self.tables}. {table.title}")
        (self.folder / "tables" / f"{table.name}.csv").write_text(table.to_csv())
        (self.folder / "tables" / f"{table.name}.md").write_text(table.to_markdown())
        return table

    def figure(self, stem: str, fig: Figure, caption: str) -> FigureRef:
        """Write ``figures/<stem>.png`` and ``.svg``; return the figure for the page."""
        ref = FigureRef(stem, F.save(fig, self.folder / "figures", stem), caption)
        self.on_figure()
        return ref

    def figure_once(self, stem: str, draw: Callable[[], Figure], caption: str) -> FigureRef:
        """:meth:`figure` of ``draw()``, drawn only the first time ``stem`` is asked for (a figure two sections show:
        the first screen's trajectory and the trajectories section's)."""
        if stem not in self.drawn:
            self.drawn[stem] = self.figure(stem, draw(), caption)
        return self.drawn[stem]


#: what a section's function returns: the section's introduction (HTML) and its tables, figures and notes in order
Body = tuple[str, Sequence[Table | FigureRef | str]]


def slug(*parts: str) -> str:
    return "_".join(re.sub(r"[^A-Za-z0-9.-]+", "-", p).strip("-") for p in parts if p)


# --- the sections ----------------------------------------------------------------------------------------
def headline_section(data: ReportData, out: ReportOutput) -> Body:
    """The first screen: the fitness against the untuned simulation and the floor, the best run's trajectory with
    its error against time, and what tuning changed."""
    items: list[Table | FigureRef] = [out.table(headline_table(data.groups, data.floors))]
    drawable = [
        (sim, task)
        for sim in data.sims
        for task in sim.group.task_names
        if sim.tasks[task].reference.wrist_mean is not None
    ]
    joint_drawable = [(sim, task) for sim in data.sims for task in sim.group.task_names if _has_joints(sim, task)]
    if drawable:
        sim, task = min(drawable, key=lambda pair: pair[0].group.best_run.best_fitness)
        items.append(_trajectory_figure(sim, task, out))
    elif joint_drawable:  # joint logs alone: the joint angles are the trajectory
        sim, task = min(joint_drawable, key=lambda pair: pair[0].group.best_run.best_fitness)
        items.append(_joint_figure(sim, task, out))
    items.append(out.table(moved_parameters_table(data.groups, data.nominal)))
    return (
        "How close tuning brought each simulation to the recordings, against the untuned simulation and the data's "
        "own floor; the best run's trajectory (recorded, untuned, tuned) with its error against time; and the "
        "parameters tuning moved, with how tightly the recordings pin them. The paper's tables follow.",
        items,
    )


def _trajectory_figure(sim: GroupSimulation, task: str, out: ReportOutput) -> FigureRef:
    return out.figure_once(
        slug("trajectory", sim.group.engine, sim.group.tasks, sim.group.space, task),
        lambda: F.trajectory_figure(sim, task),
        _trajectory_caption(sim, task),
    )


def _has_joints(sim: GroupSimulation, task: str) -> bool:
    """Whether the recordings of ``task`` log joint angles, and the re-simulation has the angles to draw."""
    traj = sim.tasks[task]
    return traj.reference.joint_mean is not None and traj.tuned_joints is not None


def _joint_figure(sim: GroupSimulation, task: str, out: ReportOutput) -> FigureRef:
    g, traj = sim.group, sim.tasks[task]
    repeats = len(traj.reference.sources)
    return out.figure_once(
        slug("joints", g.engine, g.tasks, g.space, task),
        lambda: F.joint_figure(sim, task),
        f"{g.engine} on {task} (space {g.space}), joint logs: each logged joint's recorded angle (mean of "
        f"{repeats} repeat{'s' * (repeats != 1)}, and their min-max band) against the untuned simulation (generic "
        f"parameters) and the tuned one (best repeat, {sim.run.label}) over time, in degrees; under them the mean "
        "absolute joint error of each against time (grey: the repeats' own spread about their mean; dotted: the "
        "schedule's phases).",
    )


def _single_runs(data: ReportData) -> bool:
    """Whether every engine, tasks and space has one run: nothing spreads across repeats."""
    return all(len(g.runs) == 1 for g in data.groups)


#: what the sections built on repeats say when there is one run of each
ONE_RUN = (
    "One run of each engine, tasks and space: a spread across repeats needs several (`simtune tune --seed N` "
    "for more runs, or `simtune grid`)."
)


def generic_section(data: ReportData, out: ReportOutput) -> Body:
    hint = (
        ""
        if data.published_folder is not None
        else " Run with <code>--published-sims DIR</code> to add the published simulations of the data set."
    )
    return (
        "How far each engine with its own default parameters is from the recordings (the paper's Table II)." + hint,
        [
            out.table(T.paper_generic_table(data.entries, data.task_names)),
            out.table(T.generic_table(data.entries, data.task_names, T.fitness_definition(data.runs))),
        ],
    )


def tuned_section(data: ReportData, out: ReportOutput) -> Body:
    overview = out.figure(
        "fitness_overview",
        F.fitness_overview_figure(data.groups, data.entries),
        "Generic fitness (grey bars; hatched: published simulations) and tuned fitness of each repeat (dots) "
        "and their mean (line), per task and parameter space.",
    )
    return (
        "The best fitness tuning reached per task and parameter space, with the engine that reached it "
        "(the paper's Table III), every engine's tuned fitness over repeats, and the floor a tuned fitness "
        "compares with: the real arm's repeats against their own (aligned) mean.",
        [
            out.table(T.paper_tuned_table(data.groups, data.entries)),
            out.table(T.summary_counts_table(data.groups)),
            out.table(T.best_tuned_table(data.groups, data.entries)),
            overview,
            out.table(T.tuned_by_group_table(data.groups)),
            *([out.table(T.floor_table(data.floors, data.references, data.joint_spreads))] if data.floors else []),
            _held_out_item(data, out),
        ],
    )


def _held_out_item(data: ReportData, out: ReportOutput) -> Table | str:
    """The held-out table where a run was tuned on some repeats (``--repeats even``/``odd``), else a line saying how
    to score the tuned parameters on recordings the runs did not see."""
    held = [s for s in data.sims if s.held_out is not None]
    for sim in held:
        if sim.held_out is not None and sim.held_out.score is None:
            what = f"its held-out {sim.held_out.selection} repeats"
            out.warn(f"{sim.run.label}: not scored on {what} ({sim.held_out.message})")
    table = T.held_out_table(held)
    if table.rows:
        return out.table(table)
    run = min(data.runs, key=lambda r: r.best_fitness)
    command = (
        f"simtune evaluate --engine {run.engine} --task {run.tasks} --data OTHER "
        f"--params-file {run.path / 'best_params.json'}"
    )
    return (
        '<p class="note"><strong>Held-out results:</strong> none: every run here was tuned on all the repeats of '
        "its tasks, so its tuned fitness is measured on the recordings it was fitted to. To score the tuned "
        f"parameters on recordings they were not fitted to, run <code>{html.escape(command)}</code> on other "
        "recordings (OTHER: a folder of them, one sub-folder per task), or tune with <code>--repeats even</code>: "
        "the report then scores each such run on the held-out odd repeats here.</p>"
    )


def joint_fit_section(data: ReportData, out: ReportOutput) -> Body | None:
    """Each task of a multi-task run against its floor and its alone-best, and the table of each ``simtune
    generalise`` study found with the runs; None where there is neither."""
    studies = read_studies(data.paths, out.warn)
    joint = joint_fit_table(data.groups, data.floors, alone_bests(data.groups, studies, out.warn))
    items: list[Table | FigureRef] = [out.table(joint)] if joint.rows else []
    items += [out.table(study_table(study, f"generalise_{k}")) for k, study in enumerate(studies, start=1)]
    if not items:
        return None
    return (
        "One simulator for every task: each task's part of a fit tuned on several tasks together beside its floor "
        "and the best it reaches tuned alone (joint / alone, the joint-fit penalty: 1 where one parameter set is "
        "right for every task)"
        + (
            ", and each <code>simtune generalise</code> study found with the runs, with each task held out"
            if studies
            else ""
        )
        + ".",
        items,
    )


def convergence_section(data: ReportData, out: ReportOutput) -> Body:
    figures = [
        out.figure(
            f"convergence_{axis}",
            F.convergence_figure(data.groups, axis),
            f"Best fitness so far against {what}: mean over repeats (line) and min-max band, one panel per "
            "task, one line per engine. A repeat that stopped early holds its final value."
            + (" Generation 0 is the best of the initial population." if axis != "time" else ""),
        )
        for axis, what in (
            ("generation", "generation"),
            ("evaluations", "number of evaluations"),
            ("time", "wall time"),
        )
    ]
    return "", figures


def parameters_section(data: ReportData, out: ReportOutput) -> Body:
    parameter = data.figure4_parameter
    figure4: list[FigureRef] = []
    if any(parameter in g.parameters for g in data.groups):
        figure4.append(
            out.figure(
                f"figure4_{parameter}",  # a known parameter name: safe as a file name
                F.figure4(data.groups, parameter),
                f"The paper's Figure 4 for {parameter}: its tuned value in each repeat (dots) and their spread "
                "(box: quartiles, whiskers to the extremes), raw, per experiment and engine, one panel per "
                "space. `simtune report --figure4-parameter NAME` draws it for another parameter.",
            )
        )
    if _single_runs(data):  # one dot per box: the values are in the first screen's table
        return (
            f"{ONE_RUN} The tuned values are in section {out.numbers['headline']}."
            + ("" if figure4 else f" No run tuned {parameter}."),
            figure4,
        )
    figures = figure4 + [
        out.figure(
            slug("parameters", tasks, space),
            F.parameters_figure([g for g in data.groups if (g.tasks, g.space) == (tasks, space)], data.nominal),
            f"Tuned parameter values across repeats for task {tasks}, space {space}: box (quartiles, whiskers "
            "to the extremes) and one dot per repeat, each parameter normalised to its tuning range [0, 1]; "
            "diamond: the generic value.",
        )
        for tasks, space in data.experiments
    ]
    missing = "" if figure4 else f" No run tuned {parameter}: the paper's Figure 4 (--figure4-parameter) is left out."
    return (
        "Where the tuned values of each parameter fall in their range, across repeats." + missing,
        figures,
    )


def importance_section(data: ReportData, out: ReportOutput) -> Body:
    if _single_runs(data):
        return ONE_RUN, []
    importance = T.importance_table(data.groups)
    return (
        "",
        [
            out.table(T.importance_top_table(importance)),
            out.table(importance),
            out.table(T.mann_whitney_table(data.groups)),
        ],
    )


def _trajectory_caption(sim: GroupSimulation, task: str) -> str:
    g, traj = sim.group, sim.tasks[task]
    with_object = traj.tuned_object is not None and traj.reference.object_final is not None
    return (
        f"{g.engine} on {task} (space {g.space}): the recorded wrist marker (mean of "
        f"{len(traj.reference.sources)} repeats, and each repeat / min-max band) "
        f"against the untuned simulation (generic parameters) and the tuned one (best repeat, "
        f"{sim.run.label}), in 3-D and as x, y, z against time, with the distance of each from the recorded "
        "mean under them (grey: the repeats' own spread about it; dotted: the schedule's phases)"
        + ("; right: final object positions." if with_object else ".")
    )


def _final_positions(data: ReportData) -> list[T.FinalPosition]:
    """Per task with an object: the recorded final position, each group's untuned and tuned one, the published ones."""
    finals: list[T.FinalPosition] = []
    for task in data.task_names:
        task_sims = [s for s in data.sims if task in s.tasks and s.tasks[task].reference.object_final is not None]
        if not task_sims:
            continue
        ref = task_sims[0].tasks[task].reference
        assert ref.object_final is not None  # the filter above
        mean = ref.object_final.mean(axis=0)
        spread = float(np.linalg.norm(ref.object_final - mean, axis=1).mean())
        finals.append(T.FinalPosition(task, f"recorded (mean of {len(ref.object_final)})", "", "", mean, spread))
        n = len(ref.times)
        for s in task_sims:
            traj = s.tasks[task]
            if traj.untuned_object is not None and traj.tuned_object is not None:
                finals.append(
                    T.FinalPosition(task, "untuned", s.group.engine, s.group.space, traj.untuned_object[n - 1])
                )
                finals.append(T.FinalPosition(task, "tuned", s.group.engine, s.group.space, traj.tuned_object[n - 1]))
        for sim, rollout in data.published:
            if sim.task == task and rollout.object_pos is not None:
                finals.append(T.FinalPosition(task, "published", sim.engine, "", rollout.object_pos[-1]))
    return finals


def _phase_errors(data: ReportData) -> list[T.PhaseError]:
    """Per group and task whose recordings track the wrist: the wrist error per stretch of the task."""
    entries: list[T.PhaseError] = []
    for sim in data.sims:
        for task, traj in sim.tasks.items():
            ref = traj.reference
            if ref.wrist_mean is None or ref.wrist_repeats is None:
                continue
            entries += T.phase_errors(
                sim.group,
                task,
                traj.spans,
                ref.times,
                (ref.wrist_mean, ref.wrist_repeats),
                (traj.untuned_marker, traj.tuned_marker),
            )
    return entries


def _joint_errors(data: ReportData) -> list[T.JointError]:
    """Per group and task whose recordings log joint angles: each joint's angle error per stretch of the task."""
    entries: list[T.JointError] = []
    for sim in data.sims:
        for task, traj in sim.tasks.items():
            ref = traj.reference
            if ref.joint_mean is None or ref.joint_repeats is None:
                continue
            if traj.untuned_joints is None or traj.tuned_joints is None:
                continue
            entries += T.joint_errors(
                sim.group,
                task,
                traj.spans,
                ref.times,
                (ref.joint_names, ref.joint_mean, ref.joint_repeats),
                (traj.untuned_joints, traj.tuned_joints),
            )
    return entries


def trajectories_section(data: ReportData, out: ReportOutput) -> Body:
    figures: list[FigureRef] = []
    for sim in data.sims:
        for task in sim.group.task_names:
            if sim.tasks[task].reference.wrist_mean is not None:
                figures.append(_trajectory_figure(sim, task, out))
            if _has_joints(sim, task):
                figures.append(_joint_figure(sim, task, out))
    # a table with nothing to show (no task with an object; joint logs alone: no wrist) is left out and said so
    tables = [
        T.object_final_table(_final_positions(data)),
        T.phase_error_table(_phase_errors(data)),
        T.joint_error_table(_joint_errors(data)),
    ]
    shown = [t for t in tables if t.rows]
    left_out = {  # joint_errors is left out silently: motion capture alone logs no joint angles
        "object_final": "no task has an object whose final position was recorded",
        "phase_errors": "no recording tracks the wrist marker",
    }
    missing = [f"{t.title} ({left_out[t.name]})" for t in tables if not t.rows and t.name in left_out]
    joints = any(t.name == "joint_errors" for t in shown)
    return (
        "The recorded end-effector path against the untuned and the tuned simulation (the paper's "
        "Figure 1), re-simulated for the best repeat of each engine, tasks and space"
        + ("; for joint logs, each joint's recorded and simulated angle against time" if joints else "")
        + "."
        + (f" Left out: {'; '.join(missing)}." if missing else ""),
        [*figures, *(out.table(t) for t in shown)],
    )


def contact_section(data: ReportData, out: ReportOutput) -> Body | None:
    """Whether each engine's generic simulation touches each task's object (``simtune tasks --contact``)."""
    if not data.contacts:
        return None
    from simtune.report.contact import contact_figure

    engines = list(dict.fromkeys(p.engine for p in data.contacts))
    figures = [
        out.figure(
            slug("contact", engine),
            contact_figure(
                [p for p in data.contacts if p.engine == engine], {p.task: data.task(p.task) for p in data.contacts}
            ),
            f"{engine}, generic parameters: the arm at its first contact with each task's object, from the side "
            "(the whole arm) and from above (near the object); a task without contact shows the final pose.",
        )
        for engine in engines
    ]
    return (
        "Whether the hand reaches each object in the engine's generic simulation, when, and how far the object "
        "moves: a task whose object is never touched is a kinematic task (see docs/seed-tasks.md).",
        [out.table(T.contact_table(data.contacts)), *figures],
    )


def compute_section(data: ReportData, out: ReportOutput) -> Body:
    return "", [out.table(T.compute_table(data.groups))]


def dr_section(data: ReportData, out: ReportOutput) -> Body:
    ranges = dr_ranges(data.groups, data.nominal)
    write_dr_yaml(out.folder / DR_FILE, ranges, data.tasks_by_engine)
    return (
        f'Written as <a href="{DR_FILE}">{html.escape(DR_FILE)}</a>.',
        [out.table(T.dr_table(ranges))],
    )


def sensitivity_section(data: ReportData, out: ReportOutput) -> Body | None:
    """Table and figure of each ``sensitivity.json`` under or next to the inputs; None when there is none."""
    from simtune.studies.sensitivity import find_results, sensitivity_figure, sensitivity_table

    items: list[Table | FigureRef] = []
    for k, path in enumerate(find_results(data.paths), start=1):
        try:
            result = json.loads(path.read_text())
            table = sensitivity_table(result, name=f"sensitivity_{k}")
            fig = sensitivity_figure(result)
        except (OSError, ValueError, KeyError, TypeError) as exc:
            out.warn(f"{path}: skipped: not a readable sensitivity result ({type(exc).__name__}: {exc})")
            continue
        table.note = f"From {path}. " + table.note
        caption = table.title + "."  # the figure's, without the table's number
        items += [out.table(table), out.figure(table.name, fig, caption)]
    if not items:
        return None
    importance = out.numbers.get("importance")
    compare = f", to compare with the importance of section {importance}" if importance else ""
    return (
        "Results of <code>simtune sensitivity</code> found in or next to the input folders: how much the "
        f"fitness changes with each parameter over the whole space{compare}.",
        items,
    )


def runs_appendix(data: ReportData, out: ReportOutput) -> Body:
    return "", [out.table(T.runs_table(data.runs))]


SectionMaker = Callable[[ReportData, ReportOutput], Body | None]


@dataclass(frozen=True)
class ReportSection:
    """One section of the report: its anchor in index.html (``#anchor``), its title, and the function that makes
    its body (None: the section is left out). The one home of its title: the page and docs/report.md's list of
    the sections (:func:`write_docs`) take it from here."""

    anchor: str
    title: str
    make: SectionMaker


#: The numbered sections, in order (numbers are given as they come: a section left out takes none).
SECTIONS: tuple[ReportSection, ...] = (
    ReportSection("headline", "At a glance", headline_section),
    ReportSection("generic", "Generic (untuned) fitness", generic_section),
    ReportSection("tuned", "Tuned fitness", tuned_section),
    ReportSection("joint_fit", "Joint fit and generalisation", joint_fit_section),
    ReportSection("convergence", "Convergence", convergence_section),
    ReportSection("parameters", "Parameter distributions", parameters_section),
    ReportSection("importance", "Parameter importance and significance", importance_section),
    ReportSection("trajectories", "Trajectories", trajectories_section),
    ReportSection("contact", "Contact with the objects", contact_section),
    ReportSection("compute", "Compute", compute_section),
    ReportSection("dr", "Domain-randomisation ranges", dr_section),
    ReportSection("sensitivity", "Global sensitivity", sensitivity_section),
)
#: Unnumbered sections after them.
APPENDICES: tuple[ReportSection, ...] = (ReportSection("runs", "Appendix: runs", runs_appendix),)


def make_sections(data: ReportData, out: ReportOutput) -> list[Section]:
    """Every section that has something to show, the numbered ones titled "N. title"."""
    sections: list[Section] = []
    for entry in SECTIONS:
        body = entry.make(data, out)
        if body is not None:
            out.numbers[entry.anchor] = len(out.numbers) + 1
            intro, items = body
            sections.append(Section(entry.anchor, f"{out.numbers[entry.anchor]}. {entry.title}", intro, list(items)))
    for entry in APPENDICES:
        if (body := entry.make(data, out)) is not None:
            sections.append(Section(entry.anchor, entry.title, body[0], list(body[1])))
    return sections


# --- docs/report.md's list of the sections ----------------------------------------------------------------
_DOCS_BLOCK = re.compile(r"(<!-- sections: [^\n]*-->\n)(.*?)(?=<!-- end sections -->)", re.S)
_DOCS_ITEM = re.compile(r"^(?:\d+\.|-) \*\*(.+?)\*\*", re.M)


def docs_section_list(text: str) -> str:
    """docs/report.md's list of the sections as :data:`SECTIONS` and :data:`APPENDICES` have them.

    Each item is ``N. **title**`` (the numbered sections, numbered as when every one is shown) or ``- **title**``
    (an appendix) followed by its description, kept from ``text``'s item of the same title (re-indented to its
    number's width); a section the list lacks gets an item saying it is not described yet.

    Args:
        text: docs/report.md as it is, with its list between ``<!-- sections: ... -->`` and ``<!-- end sections -->``.

    Returns:
        The list, to stand between the two markers.

    Raises:
        ValueError: the markers are missing, or the list has an item whose title is no section's (renamed or
            removed in the code: rename or remove the item, so that no description is dropped unseen).
    """
    block = _DOCS_BLOCK.search(text)
    if block is None:
        raise ValueError("no <!-- sections: ... --> ... <!-- end sections --> block")
    starts = list(_DOCS_ITEM.finditer(block.group(2)))
    bodies: dict[str, list[str]] = {}
    for k, item in enumerate(starts):
        end = starts[k + 1].start() if k + 1 < len(starts) else len(block.group(2))
        first, _, rest = block.group(2)[item.end() : end].rstrip("\n").partition("\n")
        bodies[item.group(1)] = [first, *textwrap.dedent(rest).split("\n")] if rest else [first]
    titles = [entry.title for entry in (*SECTIONS, *APPENDICES)]
    if unknown := [title for title in bodies if title not in titles]:
        raise ValueError(f"docs/report.md lists sections the report has not: {', '.join(unknown)}")
    markers = [f"{n}. " for n in range(1, len(SECTIONS) + 1)] + ["- "] * len(APPENDICES)
    items = []
    for marker, title in zip(markers, titles, strict=True):
        first, *rest = bodies.get(title, [": not described yet."])
        rest = [f"{' ' * len(marker)}{line}" if line else line for line in rest]
        items.append("\n".join([f"{marker}**{title}**{first}", *rest]))
    return "\n".join(items) + "\n"


def write_docs(path: Path) -> bool:
    """Rewrite the list of the sections in docs/report.md from :data:`SECTIONS` and :data:`APPENDICES`.

    Args:
        path: a Markdown file (docs/report.md) with the list between its two markers.

    Returns:
        Whether the file changed.
    """
    text = Path(path).read_text(encoding="utf-8")
    new = _DOCS_BLOCK.sub(lambda m: m.group(1) + docs_section_list(text), text)
    if new != text:
        Path(path).write_text(new, encoding="utf-8")
    return new != text
