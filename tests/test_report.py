"""`simtune report` on a small real grid: 2 engines x 2 tasks x 3 seeds, plus broken run folders.

The grid is tuned once per session (short runs, a few parameters); every test
then checks the report's files against the run stores themselves.  Tuning the grid
takes about 20 s, so those tests are in the slow tier; the default tier reports on
one short run.
"""

import base64
import csv
import math
import re
import shutil
import warnings
from pathlib import Path

import numpy as np
import pytest
import yaml

from simtune.data import write_qualisys_tsv
from simtune.engines import make_engine
from simtune.errors import SimtuneError
from simtune.reference import REFERENCE_DIR
from simtune.reference.make import synthesize
from simtune.report import make_report
from simtune.report.builder import ReportWarning
from simtune.report.figures import aggregate_curves
from simtune.report.published import PublishedSim, published_rollout, quaternion_matrices
from simtune.runs import RunConfig, start_run
from simtune.store import RunStore
from simtune.tasks import get_task

ENGINES = ("mujoco", "pybullet")
TASKS = ("single", "cube")
SEEDS = (0, 1, 2)
ONLY = ["command_delay", "max_velocity_joint_2", "lateral_friction_plastic"]
FIGURES = (
    {
        "fitness_overview",
        "convergence_generation",
        "convergence_evaluations",
        "convergence_time",
        "parameters_cube_extended",
        "parameters_single_extended",
    }
    | {f"trajectory_{e}_{t}_extended_{t}" for e in ENGINES for t in TASKS}
    | {f"contact_{e}" for e in ENGINES}
)
TABLES = {
    "headline",
    "tuned_parameters",
    "paper_table_ii",
    "paper_table_iii",
    "summary_counts",
    "contact",
    "generic_fitness",
    "best_tuned",
    "floor",
    "tuned_by_group",
    "parameter_importance",
    "parameter_importance_top",
    "mann_whitney",
    "object_final",
    "phase_errors",
    "compute",
    "dr_ranges",
    "runs",
}


def _make_data(root: Path) -> Path:
    data = root / "data"
    (data / "cube").mkdir(parents=True)
    (data / "single").mkdir(parents=True)
    for f in sorted((REFERENCE_DIR / "cube").iterdir()):
        shutil.copy(f, data / "cube" / f.name)
    for rec in synthesize(
        "mujoco", get_task("single"), {"command_delay": 1.2}, repeats=2, noise_m=0.002, jitter_s=0.05, seed=1
    ):
        write_qualisys_tsv(data / "single" / rec.source.name, rec, header=True)
    return data


def _write_published(folder: Path, data: Path) -> None:
    """A "published" file made from simtune's own generic MuJoCo rollout, one truncated file, one broken."""
    from simtune.objective import load_references

    folder.mkdir()
    task = get_task("cube")
    n = len(load_references(data, [task])["cube"].times)
    sim = make_engine("mujoco", task)
    r = sim.rollout({}, n)
    sim.close()
    quat = np.tile([0.0, 0.0, 0.0, 1.0], (n, 1))
    rows = np.hstack([r.wrist_pos, quat, r.object_pos, quat])
    np.savetxt(folder / "cube_Simtune.csv", rows, fmt="%.17g")
    np.savetxt(folder / "cube_Short.csv", rows[: n // 2], fmt="%.17g")
    (folder / "cube_Broken.csv").write_text("1 2 3\n4 5 6\n")
    (folder / "README.txt").write_text("not a simulation")


@pytest.fixture(scope="session")
def grid(tmp_path_factory):
    root = tmp_path_factory.mktemp("report")
    data = _make_data(root)
    runs = root / "grid"
    for engine in ENGINES:
        for task in TASKS:
            for seed in SEEDS:
                config = RunConfig(
                    optimizer="de",
                    engine=engine,
                    tasks=task,
                    space="extended",
                    data=str(data),
                    seed=seed,
                    max_generations=2,
                    only=ONLY,
                )
                start_run(config, runs / f"{engine}-{task}" / f"seed{seed}", show_progress=False)
    # broken run folders, each must be named in a warning and left out
    shutil.copytree(runs / "mujoco-cube" / "seed0", runs / "broken" / "incomplete")
    store = RunStore(runs / "broken" / "incomplete")
    store.set(status="running")
    store.close()
    (runs / "broken" / "corrupt").mkdir()
    (runs / "broken" / "corrupt" / "run.sqlite").write_bytes(b"this is not an sqlite file" * 100)
    RunStore(runs / "broken" / "noconfig", create=True).close()
    _write_published(root / "published", data)
    return root


@pytest.fixture(scope="session")
def report(grid):
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        index = make_report([grid / "grid"], grid / "out", published_sims=grid / "published", show_progress=False)
    messages = [str(w.message) for w in caught if issubclass(w.category, ReportWarning)]
    return index, messages


def _table(report, name: str) -> list[dict]:
    with open(report[0].parent / "tables" / f"{name}.csv", newline="") as f:
        return list(csv.DictReader(f))


def _num(text: str) -> float | None:
    return None if text == "" else float(text)


def _store(path) -> RunStore:
    return RunStore(Path(path))


def _good_runs(grid) -> list[Path]:
    return [grid / "grid" / f"{e}-{t}" / f"seed{s}" for e in ENGINES for t in TASKS for s in SEEDS]


@pytest.mark.slow
def test_html_embeds_and_links_every_figure(report):
    index, _ = report
    page = index.read_text()
    figures = index.parent / "figures"
    stems = {p.stem for p in figures.glob("*.png")}
    assert stems == FIGURES
    for stem in stems:
        assert (figures / f"{stem}.svg").read_text().lstrip().startswith(("<?xml", "<svg"))
        assert f'href="figures/{stem}.png"' in page and f'href="figures/{stem}.svg"' in page
        assert base64.b64encode((figures / f"{stem}.png").read_bytes()).decode() in page
    # self-contained: nothing is loaded from elsewhere
    assert not re.search(r'src="(?!data:)', page)
    assert "<link" not in page and "<script" not in page


@pytest.mark.slow
def test_every_table_is_written_as_csv_and_markdown_and_shown(report):
    index, _ = report
    page = index.read_text()
    tables = index.parent / "tables"
    assert {p.stem for p in tables.glob("*.csv")} == TABLES == {p.stem for p in tables.glob("*.md")}
    for name in TABLES:
        assert f'href="tables/{name}.csv"' in page and f'href="tables/{name}.md"' in page
        header = (tables / f"{name}.csv").read_text().splitlines()[0].split(",")
        md = (tables / f"{name}.md").read_text().splitlines()
        assert md[0].startswith("## ") and any(line.startswith("| " + header[0]) for line in md)
        assert len([r for r in md if r.startswith("| ")]) == len(_table(report, name)) + 1


@pytest.mark.slow
def test_runs_table_matches_every_store(report, grid):
    rows = {Path(r["run"]).resolve(): r for r in _table(report, "runs")}
    assert set(rows) == {p.resolve() for p in _good_runs(grid)}
    for run in _good_runs(grid):
        row, store = rows[run.resolve()], _store(run)
        best = store.best_evaluation()
        assert float(row["best fitness"]) == best["score"]["fitness"]
        assert float(row["generic fitness"]) == store.get("generic")["fitness"]
        assert int(row["evaluations"]) == store.count_evaluations()
        assert int(row["generations"]) == len(store.generations()) == 2
        assert float(row["wall time [s]"]) == store.get("elapsed_s")
        store.close()


@pytest.mark.slow
def test_tuned_tables_match_stores(report, grid):
    best = {}
    for run in _good_runs(grid):
        store = _store(run)
        cfg = store.get("config")
        best.setdefault((cfg["engine"], cfg["tasks"]), []).append(store.best_evaluation()["score"]["fitness"])
        store.close()
    for row in _table(report, "tuned_by_group"):
        values = best[(row["engine"], row["tasks"])]
        assert int(row["repeats"]) == 3 and row["seeds"] == "0 1 2"
        assert float(row["tuned best"]) == min(values) and float(row["tuned worst"]) == max(values)
        assert float(row["tuned mean"]) == pytest.approx(np.mean(values))
    generic = {
        (r["engine"], t): float(r[f"{t} fitness"])
        for r in _table(report, "generic_fitness")
        for t in TASKS
        if r["source"] == "simtune"
    }
    for row in _table(report, "best_tuned"):
        task = row["tasks"]
        tuned = min(v for (e, t), vs in best.items() if t == task for v in vs)
        assert float(row["best tuned fitness"]) == tuned
        assert tuned in best[(row["engine"], task)]
        g = min(generic[(e, task)] for e in ENGINES)
        assert float(row["best generic fitness"]) == g
        assert float(row["improvement [%]"]) == pytest.approx(100 * (g - tuned) / g)


@pytest.mark.slow
def test_generic_table_and_published_sims_use_the_same_fitness(report, grid):
    rows = {(r["engine"], r["source"]): r for r in _table(report, "generic_fitness")}
    for engine in ENGINES:
        for task in TASKS:
            store = _store(grid / "grid" / f"{engine}-{task}" / "seed0")
            assert float(rows[(engine, "simtune")][f"{task} fitness"]) == store.get("generic")["fitness"]
            store.close()
    # the "published" file is simtune's own generic MuJoCo rollout: same fitness as the MuJoCo row
    ours, published = rows[("mujoco", "simtune")], rows[("Simtune", "published")]
    for column in ("cube fitness", "cube wrist error [m]", "cube object error [m]"):
        assert float(published[column]) == pytest.approx(float(ours[column]), abs=1e-9)
    assert published["single fitness"] == ""  # no file for single
    short = rows[("Short", "published")]  # half the samples: the rest hold the last row
    assert math.isfinite(float(short["cube fitness"])) and float(short["cube fitness"]) > float(ours["cube fitness"])
    assert ("Broken", "published") not in rows


@pytest.mark.slow
def test_dr_ranges_span_the_tuned_values(report, grid):
    ranges = yaml.safe_load((report[0].parent / "dr_ranges.yaml").read_text())
    assert set(ranges) == set(ENGINES)
    for engine in ENGINES:
        # a run's value is pooled only where the parameter can act in its task (the run's inactive list)
        tuned: dict[str, list[float]] = {name: [] for name in ONLY}
        for task in TASKS:
            for seed in SEEDS:
                store = _store(grid / "grid" / f"{engine}-{task}" / f"seed{seed}")
                inactive = store.get("inactive_parameters") or {}
                for name, value in zip(store.get("parameters"), store.best_evaluation()["x"]):
                    if name not in inactive:
                        tuned[name].append(value)
                store.close()
        assert set(ranges[engine]) == {name for name, values in tuned.items() if values}
        for name, values in tuned.items():
            if values:
                entry = ranges[engine][name]
                assert entry["min"] == min(values) and entry["max"] == max(values) and entry["runs"] == len(values)
        assert ranges[engine]["command_delay"]["nominal"] == 0.0
        assert ranges[engine]["max_velocity_joint_2"]["nominal"] == 30.0
        defaults = make_engine(engine, get_task("cube")).defaults()
        assert ranges[engine]["lateral_friction_plastic"]["nominal"] == defaults["lateral_friction_plastic"]
    csv_rows = _table(report, "dr_ranges")
    assert {(r["engine"], r["parameter"]) for r in csv_rows} == {(e, n) for e in ENGINES for n in ranges[e]}


@pytest.mark.slow
def test_importance_and_mann_whitney_follow_the_stores(report, grid):
    from scipy.stats import mannwhitneyu

    importance = _table(report, "parameter_importance")
    mw = {(r["engine"], r["tasks"]): r for r in _table(report, "mann_whitney")}
    for engine in ENGINES:
        for task in TASKS:
            values, bests, initial = {n: [] for n in ONLY}, [], []
            for seed in SEEDS:
                store = _store(grid / "grid" / f"{engine}-{task}" / f"seed{seed}")
                best = store.best_evaluation()
                bests.append(best["score"]["fitness"])
                bounds = dict(zip(store.get("parameters"), store.get("bounds")))
                for name, value in zip(store.get("parameters"), best["x"]):
                    values[name].append(value)
                initial += [e["fitness"] for e in store.evaluations() if e["generation"] == 0]
                store.close()
            listed = [r for r in importance if (r["engine"], r["tasks"]) == (engine, task)]
            # parameters that cannot act in the task are listed, unranked, after the ranked ones
            rows = [r for r in listed if r["rank"]]
            assert [int(r["rank"]) for r in rows] == list(range(1, len(rows) + 1)) and len(rows) >= 2
            assert {r["parameter"] for r in listed} == set(ONLY)
            spreads = [float(r["std / range"]) for r in rows]
            assert spreads == sorted(spreads)
            for r in rows:
                low, high = bounds[r["parameter"]]
                v = np.asarray(values[r["parameter"]])
                assert float(r["std / range"]) == pytest.approx(v.std(ddof=1) / (high - low))
                assert float(r["(max - min) / range"]) == pytest.approx(np.ptp(v) / (high - low))
            row = mw[(engine, task)]
            assert int(row["tuned n"]) == 3 and int(row["untuned n"]) == len(initial) >= 15
            assert float(row["p two-sided"]) == pytest.approx(
                mannwhitneyu(bests, initial, alternative="two-sided").pvalue
            )
            assert 0 < float(row["p tuned < untuned"]) <= 1


@pytest.mark.slow
def test_trajectories_resimulate_the_stored_best(report, grid):
    rows = _table(report, "object_final")
    recorded = [r for r in rows if r["source"].startswith("recorded")]
    assert len(recorded) == 1 and recorded[0]["task"] == "cube"  # single has no object
    for engine in ENGINES:
        best = min(
            (_store(grid / "grid" / f"{engine}-cube" / f"seed{s}").best_evaluation() for s in SEEDS),
            key=lambda b: b["score"]["fitness"],
        )
        tuned = next(r for r in rows if (r["source"], r["engine"]) == ("tuned", engine))
        assert float(tuned["distance to recorded mean [m]"]) == pytest.approx(best["score"]["object_error"], abs=1e-9)
        # Table 6a: the stretches cover the task, and their errors weighted by samples are the fitness's wrist term
        stretches = [r for r in _table(report, "phase_errors") if (r["engine"], r["task"]) == (engine, "cube")]
        samples = [int(r["samples"]) for r in stretches]
        weighted = sum(float(r["tuned [mm]"]) * k for r, k in zip(stretches, samples)) / sum(samples)
        assert weighted == pytest.approx(1000 * best["score"]["wrist_error"], rel=1e-6)
        assert [r["stretch"] for r in stretches][-3:] == ["phase 1", "phase 2", "phase 3"]
    assert {r["engine"] for r in rows if r["source"] == "published"} == {"Simtune", "Short"}


@pytest.mark.slow
def test_broken_run_folders_are_named_and_left_out(report, grid):
    index, messages = report
    page = index.read_text()
    for name, why in (
        ("incomplete", "status 'running'"),
        ("corrupt", "corrupt run store"),
        ("noconfig", "no 'config'"),
    ):
        hits = [m for m in messages if str(grid / "grid" / "broken" / name) in m]
        assert len(hits) == 1 and why in hits[0] and "skipped" in hits[0], messages
        assert f"broken/{name}: skipped" in page
    assert any("cube_Broken.csv" in m for m in messages)
    assert not any("broken" in r["run"] for r in _table(report, "runs"))


@pytest.mark.slow
def test_report_leaves_run_folders_untouched(report, grid):
    for run in _good_runs(grid)[:2] + [grid / "grid" / "broken" / "corrupt"]:
        assert sorted(p.name for p in run.iterdir()) in (["best_params.json", "run.sqlite"], ["run.sqlite"])


@pytest.mark.slow
def test_single_run_folder_and_no_usable_run(grid, tmp_path):
    run = grid / "grid" / "mujoco-cube" / "seed1"
    # a folder of a user's files is refused, untouched; an earlier report there is replaced, the user's files stay
    (tmp_path / "one" / "figures").mkdir(parents=True)
    (tmp_path / "one" / "index.html").write_text("old report")
    (tmp_path / "one" / "figures" / "trajectory_old.png").write_bytes(b"old")
    with pytest.raises(SimtuneError, match="did not write"):
        make_report(run, tmp_path / "one", show_progress=False)
    assert (tmp_path / "one" / "index.html").read_text() == "old report"
    shutil.rmtree(tmp_path / "one")
    make_report(run, tmp_path / "one", show_progress=False)
    (tmp_path / "one" / "figures" / "notes.txt").write_text("mine")
    (tmp_path / "one" / "figures" / "trajectory_old.png").write_bytes(b"old")
    index = make_report(run, tmp_path / "one", show_progress=False)
    assert (tmp_path / "one" / "figures" / "trajectory_old.png").read_bytes() == b"old"
    assert (tmp_path / "one" / "figures" / "notes.txt").exists() and "old report" not in index.read_text()
    rows = list(csv.DictReader((tmp_path / "one" / "tables" / "runs.csv").read_text().splitlines()))
    assert len(rows) == 1 and Path(rows[0]["run"]) == run
    assert "published" not in (tmp_path / "one" / "tables" / "generic_fitness.csv").read_text()
    assert index.exists()
    with pytest.warns(ReportWarning, match="corrupt"), pytest.raises(SimtuneError, match="no finished runs"):
        make_report(grid / "grid" / "broken" / "corrupt", tmp_path / "none", show_progress=False)
    with pytest.raises(SimtuneError, match="no run folders"):
        make_report(tmp_path / "one", tmp_path / "none", show_progress=False)
    with pytest.raises(SimtuneError, match="no such run or grid folder"):
        make_report(tmp_path / "missing", tmp_path / "none", show_progress=False)


@pytest.mark.slow
def test_command_line(grid, tmp_path):
    import typer
    from typer.testing import CliRunner

    from simtune.cli.report_command import report as report_command

    app = typer.Typer()
    app.command()(report_command)
    runner = CliRunner()
    assert "--published-sims" in runner.invoke(app, ["--help"]).output
    run = grid / "grid" / "pybullet-single" / "seed0"
    result = runner.invoke(app, [str(run), "--out", str(tmp_path / "r"), "--quiet"])
    assert result.exit_code == 0, result.output
    assert (tmp_path / "r" / "index.html").exists() and "index.html" in result.output
    result = runner.invoke(app, [str(tmp_path / "nothing"), "--out", str(tmp_path / "r2")])
    assert isinstance(result.exception, SimtuneError)


@pytest.mark.slow  # end to end, 11 s: a run and its report (the default tier reports fixtures' runs)
def test_report_of_one_short_run(tmp_path):
    run = tmp_path / "run"
    config = RunConfig(
        optimizer="de",
        engine="mujoco",
        tasks="cube",
        space="extended",
        data=str(REFERENCE_DIR),
        max_generations=1,
        only=ONLY,
    )
    result = start_run(config, run, show_progress=False)
    index = make_report(run, tmp_path / "out", show_progress=False)
    html = index.read_text()
    assert "trajectory_mujoco_cube_extended_cube.png" in html
    rows = list(csv.DictReader((tmp_path / "out" / "tables" / "runs.csv").read_text().splitlines()))
    assert len(rows) == 1 and Path(rows[0]["run"]) == run
    best = list(csv.DictReader((tmp_path / "out" / "tables" / "best_tuned.csv").read_text().splitlines()))
    assert float(best[0]["best tuned fitness"]) == result.fitness
    # the floor: the recorded repeats against their aligned mean, beside the tuned fitness
    (floor,) = csv.DictReader((tmp_path / "out" / "tables" / "floor.csv").read_text().splitlines())
    assert floor["task"] == "cube" and floor["repeats"] == "3"
    assert 0 < float(floor["spread aligned [mm]"]) <= float(floor["spread as recorded [mm]"])
    assert 0 < float(floor["floor (aligned mean vs repeats)"]) < result.fitness
    assert "The floor: the real arm against itself" in html and "scored against: aligned" in html


def _titles_inside(fig) -> list[str]:
    """The titles of ``fig`` (its own and its panels') that reach past the figure's edges once drawn."""
    fig.canvas.draw()
    box = fig.bbox
    texts = [fig._suptitle] if fig._suptitle is not None else []
    texts += [ax.title for ax in fig.axes if ax.get_visible() and ax.get_title()]
    return [
        t.get_text()
        for t in texts
        if (e := t.get_window_extent()).x0 < box.x0 - 0.5 or e.x1 > box.x1 + 0.5 or e.y1 > box.y1 + 0.5
    ]


@pytest.mark.slow  # about 8 s: a run and a report with the paper's tables and figure 4
def test_paper_tables_figure4_and_titles_of_a_short_run(tmp_path):
    """Tables II and III in the paper's layout, Figure 4 for a chosen parameter, and no title past its figure."""
    from simtune.engines.contact import probe_contact
    from simtune.report import figures as F
    from simtune.report.collect import group_runs, load_run
    from simtune.report.contact import contact_figure

    runs = []
    for seed in (0, 1):
        config = RunConfig(optimizer="de",
            engine="mujoco", tasks="cube", space="extended", data=str(REFERENCE_DIR), max_generations=1,
            only=ONLY, seed=seed, max_seconds=600,
        )  # fmt: skip
        start_run(config, tmp_path / f"run{seed}", show_progress=False)
        runs.append(load_run(tmp_path / f"run{seed}"))
    index = make_report(tmp_path, tmp_path / "out", show_progress=False, figure4_parameter="command_delay")
    out = index.parent
    assert (out / "figures" / "figure4_command_delay.png").exists()
    table_ii = list(csv.DictReader((out / "tables" / "paper_table_ii.csv").read_text().splitlines()))
    assert [r["experiment"] for r in table_ii] == ["cube"] and r"unstable (blew up)" in table_ii[0]
    assert float(table_ii[0]["mujoco"]) == pytest.approx(runs[0].generic_fitness)
    table_iii = list(csv.DictReader((out / "tables" / "paper_table_iii.csv").read_text().splitlines()))
    assert len(table_iii) == 1
    assert int(table_iii[0]["D"]) == len(ONLY) and int(table_iii[0]["population"]) == max(5, len(ONLY))
    assert float(table_iii[0]["best tuned fitness"]) == min(r.best_fitness for r in runs)
    counts = {r["count"]: (int(r["N"]), int(r["of M"])) for r in csv.DictReader(
        (out / "tables" / "summary_counts.csv").read_text().splitlines())}  # fmt: skip
    assert counts["runs stopped by the time cap (--max-seconds)"] == (0, 2)
    importance = list(csv.DictReader((out / "tables" / "parameter_importance.csv").read_text().splitlines()))
    assert {r["parameter"] for r in importance} == set(ONLY)
    assert all(0.0 <= float(r["p (Brown-Forsythe)"]) <= 1.0 for r in importance)
    with pytest.raises(SimtuneError, match="--figure4-parameter"):
        make_report(tmp_path / "run0", tmp_path / "out2", show_progress=False, figure4_parameter="no_such")

    groups, _ = group_runs(runs)
    drawn = [
        F.figure4(groups, "command_delay"),
        contact_figure([probe_contact(make_engine("mujoco", get_task("cube")))]),
    ]
    drawn += [F.convergence_figure(groups, axis) for axis in ("generation", "evaluations", "time")]
    drawn += [F.parameters_figure(groups, {}), F.fitness_overview_figure(groups, [])]
    for fig in drawn:
        assert _titles_inside(fig) == []


def test_long_titles_are_wrapped_to_their_figure():
    from simtune.report.figures import new_figure, suptitle

    long = "Convergence: best fitness vs generation (line: mean over repeats, band: min-max)"
    fig = new_figure(4.0, 3.0)
    fig.subplots()
    fig.suptitle(long)
    assert _titles_inside(fig) == [long]  # as matplotlib draws it: cut at both sides
    suptitle(fig, long)
    assert "\n" in fig._suptitle.get_text()
    assert _titles_inside(fig) == []


def test_spread_test_tells_a_narrowed_parameter_from_a_wandering_one():
    from simtune.report.tables import spread_test

    rng = np.random.default_rng(0)
    initial = rng.uniform(0.0, 1.0, 200)
    assert spread_test(np.array([0.41, 0.42, 0.40, 0.43, 0.41]), initial) < 0.001
    assert spread_test(rng.uniform(0.0, 1.0, 5), initial) > 0.05
    assert spread_test(np.array([0.4]), initial) is None  # one repeat: no spread


def test_convergence_aggregation_holds_and_starts_together():
    a = (np.array([0.0, 1.0, 2.0]), np.array([3.0, 2.0, 1.0]))
    b = (np.array([0.5, 1.5]), np.array([4.0, 0.5]))  # starts later, stops earlier
    x, mean, lo, hi = aggregate_curves([a, b])
    np.testing.assert_array_equal(x, [0.5, 1.0, 1.5, 2.0])
    np.testing.assert_allclose(mean, [3.5, 3.0, 1.25, 0.75])
    np.testing.assert_array_equal(lo, [3.0, 2.0, 0.5, 0.5])
    np.testing.assert_array_equal(hi, [4.0, 4.0, 2.0, 1.0])


def test_published_rollout_holds_cuts_and_reads_quaternions():
    turn = np.array([[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])  # 90 deg about z
    s = math.sqrt(0.5)
    np.testing.assert_allclose(quaternion_matrices(np.array([[0, 0, s, s]]))[0], turn, atol=1e-12)
    np.testing.assert_allclose(quaternion_matrices(np.array([[s, 0, 0, s]]), "wxyz")[0], turn, atol=1e-12)
    rows = np.zeros((4, 14))
    rows[:, 0] = np.arange(4)
    rows[:, 6] = rows[:, 13] = 1.0  # identity in x y z w
    rows[:, 7] = 10 + np.arange(4)
    long = published_rollout(PublishedSim("cube", "Mujoco", Path("x"), rows), 6)
    np.testing.assert_array_equal(long.wrist_pos[:, 0], [0, 1, 2, 3, 3, 3])
    np.testing.assert_array_equal(long.object_pos[:, 0], [10, 11, 12, 13, 13, 13])
    np.testing.assert_allclose(long.times, np.arange(6) * 0.05)
    short = published_rollout(PublishedSim("cube", "Mujoco", Path("x"), rows), 2)
    np.testing.assert_array_equal(short.wrist_pos[:, 0], [0, 1])
    # PyBullet files put w first: the same numbers mean another rotation
    pyb = published_rollout(PublishedSim("cube", "PyBullet", Path("x"), rows), 1)
    np.testing.assert_allclose(pyb.wrist_rot[0], np.diag([-1.0, -1.0, 1.0]), atol=1e-12)  # w=0, axis z: half turn


@pytest.mark.slow
def test_compute_table_shows_blow_ups_and_pruning_from_the_stores(report, grid):
    for row in _table(report, "compute"):
        runs = [p for p in _good_runs(grid) if p.parent.name == f"{row['engine']}-{row['tasks']}"]
        counts = [_store(p).count_outcomes() for p in runs]
        assert int(row["unstable or failed"]) == sum(c["unstable"] for c in counts)
        assert int(row["pruned"]) == sum(c["pruned"] for c in counts)


def test_sections_are_numbered_in_order_and_skipped_ones_take_no_number(monkeypatch, tmp_path):
    from simtune.report import sections

    def entry(anchor: str, shown: bool = True):
        return sections.ReportSection(anchor, anchor.title(), lambda data, out: ("", []) if shown else None)

    monkeypatch.setattr(sections, "SECTIONS", (entry("first"), entry("absent", shown=False), entry("second")))
    monkeypatch.setattr(sections, "APPENDICES", (entry("appendix"),))
    out = sections.ReportOutput(tmp_path, warn=lambda message: None)
    made = sections.make_sections(None, out)  # these makers read no data
    assert [s.title for s in made] == ["1. First", "2. Second", "Appendix"]
    assert [s.anchor for s in made] == ["first", "second", "appendix"]
    assert out.numbers == {"first": 1, "second": 2}
