"""Assemble the report: read runs, score published simulations, re-simulate, draw, write files."""

from __future__ import annotations

import datetime as _dt
import html
import re
import warnings
from collections.abc import Iterable
from pathlib import Path

import numpy as np
from rich.console import Console
from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn

import simtune
from simtune.engines import Rollout
from simtune.errors import SimtuneError
from simtune.report import figures as F
from simtune.report import tables as T
from simtune.report.collect import RunRecord, Skipped, find_run_dirs, group_runs, load_run
from simtune.report.dr import dr_ranges, write_dr_yaml
from simtune.report.html import FigureRef, Section, render
from simtune.report.published import PublishedSim, find_published, score_published
from simtune.report.simulate import GroupSimulation, References, nominal_values, simulate_group

INDEX = "index.html"
DR_FILE = "dr_ranges.yaml"


class ReportWarning(UserWarning):
    """A run folder or file left out of the report, or a doubt about what it shows."""


def slug(*parts: str) -> str:
    return "_".join(re.sub(r"[^A-Za-z0-9.-]+", "-", p).strip("-") for p in parts if p)


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
        self._task = None

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
) -> Path:
    """Write the report for the runs under ``paths`` into ``out``; return the path of its ``index.html``.

    Run folders that are unfinished or unreadable are left out with a
    :class:`ReportWarning` naming them.  Raises :class:`SimtuneError` when no
    usable run is found.
    """
    if isinstance(paths, (str, Path)):
        paths = [paths]
    paths = [Path(p) for p in paths]
    run_dirs = find_run_dirs(paths)
    if published_sims is not None and not Path(published_sims).is_dir():
        raise SimtuneError(f"--published-sims {published_sims}: no such folder")
    out = Path(out)
    _prepare(out)

    problems: list[str] = []  # shown as warnings and at the top of the report

    def warn(message: str) -> None:
        problems.append(message)
        warnings.warn(message, ReportWarning, stacklevel=3)

    with _Progress(show_progress) as progress:
        # --- read ----------------------------------------------------------------------------------
        progress.stage("reading runs", len(run_dirs))
        runs: list[RunRecord] = []
        for d in run_dirs:
            loaded = load_run(d)
            if isinstance(loaded, Skipped):
                warn(f"{loaded.label}: skipped: {loaded.reason}")
            else:
                runs.append(loaded)
            progress.step()
        groups, duplicates = group_runs(runs)
        for dup in duplicates:
            warn(f"{dup.label}: skipped: {dup.reason}")
        if not groups:
            raise SimtuneError(
                f"no finished runs to report in {', '.join(map(str, paths))} "
                f"({len(run_dirs)} run folder(s), none usable: see the warnings)"
            )
        kept = [r for g in groups for r in g.runs]
        task_names: list[str] = []
        for g in groups:
            task_names.extend(t for t in g.task_names if t not in task_names)
        parameter_keys = sorted({(g.tasks, g.space) for g in groups})
        engines = sorted({g.engine for g in groups})

        n_traj = sum(len(g.task_names) for g in groups)
        total = 1 + len(engines) + len(groups) + 4 + len(parameter_keys) + n_traj + 1
        progress.stage("scoring published simulations", total)

        # --- 1. generic fitness, published simulations ------------------------------------------------
        references = References()
        entries, notes = T.generic_entries(groups)
        for note in notes:
            warn(note)
        published: list[PublishedSim] = []
        published_scores: dict[tuple[str, str], Rollout] = {}
        if published_sims is not None:
            for item in find_published(Path(published_sims), task_names):
                if not isinstance(item, PublishedSim):
                    warn(f"{item[0]}: skipped: {item[1]}")
                    continue
                run = next(r for g in groups if item.task in g.task_names for r in g.runs)
                try:
                    reference = references.get(run.data, item.task)
                except SimtuneError as exc:
                    warn(f"{item.path}: not scored: recordings of {item.task!r} unavailable ({exc})")
                    continue
                score, rollout = score_published(item, reference)
                published.append(item)
                published_scores[(item.engine, item.task)] = rollout
                entries.append(
                    T.GenericEntry(
                        item.engine,
                        "published",
                        "",
                        item.task,
                        score.fitness,
                        score.wrist_error,
                        score.object_error,
                        score.stable,
                    )
                )
            if not published:
                warn(
                    f"--published-sims {published_sims}: no files <task>_<Engine>.csv for the tasks "
                    f"{', '.join(task_names)}"
                )
        progress.step()

        # --- nominal (generic) parameter values per engine ----------------------------------------------
        nominal: dict[str, dict[str, float]] = {}
        tasks_by_engine: dict[str, list[str]] = {}
        progress.describe("nominal parameter values")
        for engine in engines:
            names: list[str] = []
            for g in groups:
                if g.engine == engine:
                    names.extend(t for t in g.task_names if t not in names)
            tasks_by_engine[engine] = names
            try:
                nominal[engine] = nominal_values(engine, names)
            except SimtuneError as exc:
                warn(f"engine {engine}: no nominal values ({exc})")
                nominal[engine] = {}
            progress.step()

        # --- 6. re-simulation ------------------------------------------------------------------------------
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
            stored = g.best_run.best_fitness
            if abs(sim.tuned_fitness - stored) > 1e-6 * max(1.0, abs(stored)):
                warn(
                    f"{g.best_run.label}: re-simulating its best parameters gives fitness {sim.tuned_fitness:.6f}, "
                    f"the store has {stored:.6f} (different engine version or recordings?)"
                )
            sims.append(sim)

        # --- figures ---------------------------------------------------------------------------------------
        fig_dir = out / "figures"
        figs: dict[str, list[FigureRef]] = {"overview": [], "convergence": [], "parameters": [], "trajectories": []}

        def draw(kind: str, stem: str, fig, caption: str) -> None:
            figs[kind].append(FigureRef(stem, F.save(fig, fig_dir, stem), caption))
            progress.step()

        progress.describe("drawing figures")
        draw(
            "overview",
            "fitness_overview",
            F.fitness_overview_figure(groups, entries),
            "Generic fitness (grey bars; hatched: published simulations) and tuned fitness of each repeat (dots) "
            "and their mean (line), per task and parameter space.",
        )
        for axis, what in (
            ("generation", "generation"),
            ("evaluations", "number of evaluations"),
            ("time", "wall time"),
        ):
            draw(
                "convergence",
                f"convergence_{axis}",
                F.convergence_figure(groups, axis),
                f"Best fitness so far against {what}: mean over repeats (line) and min-max band, one panel per "
                "task, one line per engine. A repeat that stopped early holds its final value."
                + (" Generation 0 is the best of the initial population." if axis != "time" else ""),
            )
        for tasks, space in parameter_keys:
            mine = [g for g in groups if (g.tasks, g.space) == (tasks, space)]
            draw(
                "parameters",
                slug("parameters", tasks, space),
                F.parameters_figure(mine, nominal),
                f"Tuned parameter values across repeats for task {tasks}, space {space}: box (quartiles, whiskers "
                "to the extremes) and one dot per repeat, each parameter normalised to its tuning range [0, 1]; "
                "diamond: the generic value.",
            )
        for sim in sims:
            for task in sim.group.task_names:
                g = sim.group
                draw(
                    "trajectories",
                    slug("trajectory", g.engine, g.tasks, g.space, task),
                    F.trajectory_figure(sim, task),
                    f"{g.engine} on {task} (space {g.space}): the recorded wrist marker (mean of "
                    f"{len(sim.tasks[task].reference.wrist_repeats)} repeats, and each repeat / min-max band) "
                    f"against the untuned simulation (generic parameters) and the tuned one (best repeat, "
                    f"{sim.run.label}), in 3-D and as x, y, z against time"
                    + (
                        "; right: final object positions."
                        if sim.tasks[task].tuned_object is not None
                        and sim.tasks[task].reference.object_final is not None
                        else "."
                    ),
                )

        # --- tables ---------------------------------------------------------------------------------------
        progress.describe("writing tables")
        finals: list[T.FinalPosition] = []
        for task in task_names:
            task_sims = [s for s in sims if task in s.tasks and s.tasks[task].reference.object_final is not None]
            if not task_sims:
                continue
            ref = task_sims[0].tasks[task].reference
            mean = ref.object_final.mean(axis=0)
            spread = float(np.linalg.norm(ref.object_final - mean, axis=1).mean())
            finals.append(T.FinalPosition(task, f"recorded (mean of {len(ref.object_final)})", "", "", mean, spread))
            for s in task_sims:
                traj = s.tasks[task]
                n = len(ref.times)
                if traj.untuned_object is not None:
                    finals.append(
                        T.FinalPosition(task, "untuned", s.group.engine, s.group.space, traj.untuned_object[n - 1])
                    )
                    finals.append(
                        T.FinalPosition(task, "tuned", s.group.engine, s.group.space, traj.tuned_object[n - 1])
                    )
            for p in published:
                if p.task == task:
                    finals.append(
                        T.FinalPosition(
                            task, "published", p.engine, "", published_scores[(p.engine, task)].object_pos[-1]
                        )
                    )

        ranges = dr_ranges(groups, nominal)
        write_dr_yaml(out / DR_FILE, ranges, tasks_by_engine)
        importance = T.importance_table(groups)
        tables = {
            "generic": T.generic_table(entries, task_names),
            "best": T.best_tuned_table(groups, entries),
            "by_group": T.tuned_by_group_table(groups),
            "importance": importance,
            "importance_top": T.importance_top_table(importance),
            "mann_whitney": T.mann_whitney_table(groups),
            "object_final": T.object_final_table(finals),
            "compute": T.compute_table(groups),
            "dr": T.dr_table(ranges),
            "runs": T.runs_table(kept),
        }
        for table in tables.values():
            (out / "tables" / f"{table.name}.csv").write_text(table.to_csv())
            (out / "tables" / f"{table.name}.md").write_text(table.to_markdown())
        progress.step()

        sensitivity = _sensitivity_items(paths, out, warn)

        # --- html -----------------------------------------------------------------------------------------------
        progress.describe("writing index.html")
        sections = _sections(tables, figs, published_sims is not None)
        if sensitivity:
            sections.insert(
                -1,
                Section(
                    "sensitivity",
                    "9. Global sensitivity",
                    "Results of <code>simtune sensitivity</code> found in or next to the "
                    "input folders: how much the fitness changes with each parameter over the "
                    "whole space, to compare with the importance of section 5.",
                    sensitivity,
                ),
            )
        meta = [
            f"simtune {simtune.__version__}, {_dt.datetime.now().astimezone().strftime('%Y-%m-%d %H:%M %Z')}. "
            f"Inputs: {', '.join(str(p) for p in paths)}"
            + (f"; published simulations: {published_sims}" if published_sims is not None else "")
            + ".",
            f"{len(kept)} runs in {len(groups)} groups (engine x tasks x space; repeats = seeds): engines "
            f"{', '.join(engines)}; tasks {', '.join(sorted({g.tasks for g in groups}))}; spaces "
            f"{', '.join(sorted({g.space for g in groups}))}. Fitness is in metres (lower is better).",
        ]
        index = out / INDEX
        index.write_text(render("simtune report: simulator tuning results", meta, problems, sections))
        progress.finish()
    return index


def _sensitivity_items(paths: list[Path], out: Path, warn) -> list:
    """Table and figure of each ``sensitivity.json`` under or next to the inputs (written into the report)."""
    import json

    from simtune.sensitivity import find_results, sensitivity_figure, sensitivity_table

    items: list = []
    for k, path in enumerate(find_results(paths), start=1):
        try:
            result = json.loads(path.read_text())
            table = sensitivity_table(result, name=f"sensitivity_{k}")
            fig = sensitivity_figure(result)
        except (OSError, ValueError, KeyError, TypeError) as exc:
            warn(f"{path}: skipped: not a readable sensitivity result ({type(exc).__name__}: {exc})")
            continue
        table.note = f"From {path}. " + table.note
        (out / "tables" / f"{table.name}.csv").write_text(table.to_csv())
        (out / "tables" / f"{table.name}.md").write_text(table.to_markdown())
        items += [table, FigureRef(table.name, F.save(fig, out / "figures", table.name), table.title + ".")]
    return items


def _prepare(out: Path) -> None:
    """Create the report folder; in one that holds an earlier report, remove that report's figures and tables
    (so every file there belongs to the new report)."""
    try:
        if (out / INDEX).is_file():
            for sub, suffixes in (("figures", (".png", ".svg")), ("tables", (".csv", ".md"))):
                if (out / sub).is_dir():
                    for old in (out / sub).iterdir():
                        if old.is_file() and old.suffix in suffixes:
                            old.unlink()
        (out / "figures").mkdir(parents=True, exist_ok=True)
        (out / "tables").mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise SimtuneError(f"--out {out}: cannot write the report folder ({exc.strerror})") from None


def _sections(tables: dict[str, T.Table], figs: dict[str, list[FigureRef]], with_published: bool) -> list[Section]:
    published = (
        ""
        if with_published
        else " Run with <code>--published-sims DIR</code> to add the published simulations of the data set."
    )
    return [
        Section(
            "generic",
            "1. Generic (untuned) fitness",
            "How far each engine with its own default parameters is from the recordings (the paper's "
            "Table II)." + published,
            [tables["generic"]],
        ),
        Section(
            "tuned",
            "2. Tuned fitness",
            "The best fitness tuning reached per task and parameter space, with the engine that reached it "
            "(the paper's Table III), and every engine's tuned fitness over repeats.",
            [tables["best"], *figs["overview"], tables["by_group"]],
        ),
        Section("convergence", "3. Convergence", "", figs["convergence"]),
        Section(
            "parameters",
            "4. Parameter distributions",
            "Where the tuned values of each parameter fall in their range, across repeats.",
            figs["parameters"],
        ),
        Section(
            "importance",
            "5. Parameter importance and significance",
            "",
            [tables["importance_top"], tables["importance"], tables["mann_whitney"]],
        ),
        Section(
            "trajectories",
            "6. Trajectories",
            "The recorded end-effector path against the untuned and the tuned simulation (the paper's "
            "Figure 1), re-simulated for the best repeat of each engine, tasks and space.",
            [*figs["trajectories"], tables["object_final"]],
        ),
        Section("compute", "7. Compute", "", [tables["compute"]]),
        Section(
            "dr",
            "8. Domain-randomisation ranges",
            f'Written as <a href="{DR_FILE}">{html.escape(DR_FILE)}</a>.',
            [tables["dr"]],
        ),
        Section("runs", "Appendix: runs", "", [tables["runs"]]),
    ]
