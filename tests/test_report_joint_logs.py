"""`simtune report` of runs whose recordings are joint logs (joint angles, no motion capture) (issue 71, probe 5).

A joint-log run's report draws each joint's recorded, generic and tuned angle against time, fills the trajectory
tables with per-joint errors in degrees, says what its fitness is measured in, gives the joint logs' floor (or says
that one repeat has none), and shows held-out scores (or how to get them).  Each report is of short real runs (MuJoCo,
12 evaluations, one worker) on synthetic joint logs.
"""

from __future__ import annotations

import csv
import html
import math
import re
import warnings
from pathlib import Path

import numpy as np
import pytest

from simtune.objective import load_references
from simtune.report import make_report
from simtune.report.builder import ReportWarning
from simtune.runs import RunConfig, start_run
from simtune.store import RunStore
from simtune.studies.synth import make_synthetic
from simtune.tasks import get_task

#: a run and its report are built once for the file (about 5 s): the slow tier, for the default tier's 4 minutes
pytestmark = pytest.mark.slow

ONLY = ["command_delay", "max_velocity_joint_2"]
TRUTH = {"command_delay": 1.2}
JOINTS = [f"joint_{k}" for k in range(1, 7)]  # the MICO's six, each logged


def _data(root: Path, repeats: int) -> Path:
    make_synthetic("mujoco", "single", root, truth=TRUTH, repeats=repeats, fmt="joints-csv")
    return root


def _tune(data: Path, out: Path, **settings) -> Path:
    config = RunConfig(
        engine="mujoco", tasks="single", data=str(data), max_evaluations=12, workers=1, only=ONLY, **settings
    )
    start_run(config, out, show_progress=False)
    return out


def _report(runs: Path, out: Path) -> tuple[str, list[str]]:
    """The page's HTML and the report's warnings."""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        index = make_report(runs, out, show_progress=False)
    return index.read_text(), [str(w.message) for w in caught if issubclass(w.category, ReportWarning)]


def _rows(out: Path, name: str) -> list[dict]:
    return list(csv.DictReader((out / "tables" / f"{name}.csv").read_text().splitlines()))


def _section(page: str, anchor: str) -> str:
    start = page.index(f'<section id="{anchor}">')
    return page[start : page.index("</section>", start)]


def _text(fragment: str) -> str:
    """The words of an HTML fragment, tags dropped."""
    return html.unescape(re.sub(r"\s+", " ", re.sub(r"<[^>]+>", " ", fragment)))


@pytest.fixture(scope="module")
def joint_run(tmp_path_factory) -> dict:
    """A run on three repeats of joint logs and its report."""
    root = tmp_path_factory.mktemp("joint_report")
    data = _data(root / "data", repeats=3)
    run = _tune(data, root / "run")
    page, messages = _report(run, root / "out")
    return {"root": root, "data": data, "run": run, "out": root / "out", "page": page, "warnings": messages}


def _best(run: Path) -> dict:
    store = RunStore(run)
    try:
        return store.best_evaluation()
    finally:
        store.close()


def test_each_joints_angle_is_drawn_against_time(joint_run):
    page, out = joint_run["page"], joint_run["out"]
    stem = "joints_mujoco_single_calibrated_single"
    assert (out / "figures" / f"{stem}.png").stat().st_size > 10_000 and (out / "figures" / f"{stem}.svg").exists()
    # on the first screen (no wrist to draw there) and in the trajectories section, drawn once
    assert f"figures/{stem}.png" in _section(page, "headline")
    assert f"figures/{stem}.png" in _section(page, "trajectories")
    assert not list((out / "figures").glob("trajectory_*"))  # no marker: no wrist figure
    svg = (out / "figures" / f"{stem}.svg").read_text()
    for joint in JOINTS:
        assert joint in svg  # a panel per logged joint
    assert "mean joint error [deg]" in svg and "angle [deg]" in svg
    assert joint_run["warnings"] == []  # the re-simulation gives the stored fitness


def test_trajectory_tables_hold_per_joint_errors_in_degrees(joint_run):
    out, page = joint_run["out"], joint_run["page"]
    rows = _rows(out, "joint_errors")
    assert {r["joint"] for r in rows} == set(JOINTS)
    whole = {r["joint"]: r for r in rows if r["stretch"] == "whole task"}
    assert len(whole) == len(JOINTS) and len(rows) > len(JOINTS)  # and each stretch of the schedule
    # the whole task's tuned error, averaged over the joints, is the stored best run's joint error, in degrees
    best = _best(joint_run["run"])["score"]
    mean_tuned = np.mean([float(r["tuned [deg]"]) for r in whole.values()])
    assert mean_tuned == pytest.approx(math.degrees(best["joint_error"]), rel=1e-6)
    # the commanded joint_2 moves 100 deg: untuned it lags by degrees, tuned (delay found) by far less
    assert float(whole["joint_2"]["untuned [deg]"]) > 5.0 > 10 * float(whole["joint_2"]["tuned [deg]"])
    assert all(float(r["repeat spread [deg]"]) > 0 for r in rows)
    shown = _text(_section(page, "trajectories"))
    assert "untuned [deg]" in shown and re.search(r"Table \d+\. Where the joint error sits", shown)
    # the motion-capture tables with nothing to show are left out, and said to be (by title: they take no number)
    assert not (out / "tables" / "phase_errors.csv").exists() and not (out / "tables" / "object_final.csv").exists()
    assert "Left out: Final object position: recorded vs simulated (no task has an object" in shown
    assert "Where the wrist error sits: per stretch of each task's schedule (no recording tracks the wrist" in shown
    (run,) = _rows(out, "runs")
    assert float(run["joint error [deg]"]) == pytest.approx(math.degrees(best["joint_error"]), rel=1e-12)
    generic = _rows(out, "generic_fitness")[0]
    assert float(generic["single joint error [deg]"]) == pytest.approx(
        math.degrees(RunStore(joint_run["run"]).get("generic")["joint_error"])
    )


def test_the_fitness_unit_of_joint_logs_is_stated(joint_run):
    text = _text(joint_run["page"])
    assert "Fitness is in metres" not in text
    unit = (
        "0.5 m/rad (the joint weight, --weights joint=W) x the mean absolute joint-angle error of the logged joints "
        "[rad] (a fitness of 0.01 is a mean joint error of 1.15 deg)"
    )
    assert f"Fitness = {unit} (lower is better)." in text  # under the title
    assert f"Fitness = {unit} (lower is better) of each task" in _text(_section(joint_run["page"], "headline"))
    assert "mean wrist error + final object error" not in text


def test_the_floor_of_joint_logs_is_their_joint_term(joint_run):
    out, page = joint_run["out"], joint_run["page"]
    (floor,) = _rows(out, "floor")
    aligned = load_references(joint_run["data"], [get_task("single")], reference="aligned")["single"]
    assert aligned.joint_repeats is not None and aligned.joint_mean is not None
    spread_rad = np.abs(aligned.joint_repeats - aligned.joint_mean[None]).mean()
    assert float(floor["joint spread aligned [deg]"]) == pytest.approx(math.degrees(spread_rad), rel=1e-9)
    assert float(floor["floor (aligned mean vs repeats)"]) == pytest.approx(0.5 * spread_rad, rel=1e-9)
    value = float(floor["floor (aligned mean vs repeats)"])
    assert 0 < value < 5e-4  # a fraction of a degree x 0.5 m/rad: four decimals would round it away
    (headline,) = _rows(out, "headline")
    assert float(headline["floor"]) == value
    assert f'<td class="num">{value:.3g}</td>' in _section(page, "headline")
    assert "0.0000" not in _text(_section(page, "headline")) and "0.0000" not in _text(_section(page, "tuned"))


def test_without_held_out_repeats_the_report_says_how_to_score_them(joint_run):
    text = _text(_section(joint_run["page"], "tuned"))
    command = f"simtune evaluate --engine mujoco --task single --data OTHER --params-file {joint_run['run']}"
    assert "Held-out results: none" in text and f"{command}/best_params.json" in text
    assert "--repeats even" in text
    assert not (joint_run["out"] / "tables" / "held_out.csv").exists()


@pytest.mark.slow  # a run and a report of their own: about 5 s of CPU
def test_a_run_tuned_on_the_even_repeats_is_scored_on_the_odd_ones(joint_run, tmp_path):
    import simtune.api as st

    run = _tune(joint_run["data"], tmp_path / "even", repeats="even")
    page, messages = _report(run, tmp_path / "out")
    assert messages == []
    (row,) = _rows(tmp_path / "out", "held_out")
    assert (row["tuned on"], row["scored on"], row["held-out repeats"]) == ("even", "odd", "1")
    assert float(row["tuned fitness"]) == pytest.approx(_best(run)["score"]["fitness"], rel=1e-9)
    # the same number `simtune evaluate --params-file RUN/best_params.json --repeats odd` gives
    held = st.evaluate("mujoco", "single", data=joint_run["data"], params=run / "best_params.json", repeats="odd")
    assert float(row["held-out fitness"]) == pytest.approx(held.fitness, rel=1e-9)
    assert float(row["held-out joint error [deg]"]) == pytest.approx(math.degrees(held.joint_error), rel=1e-9)
    assert "tables/held_out.csv" in _section(page, "tuned") and "Held-out results: none" not in _text(page)


@pytest.mark.slow  # a run and a report of their own: about 5 s of CPU
def test_one_repeat_has_no_floor_and_says_so(tmp_path):
    run = _tune(_data(tmp_path / "data", repeats=1), tmp_path / "run")
    page, _ = _report(run, tmp_path / "out")
    (floor,) = _rows(tmp_path / "out", "floor")
    assert floor["floor (aligned mean vs repeats)"] == "no floor: one repeat"
    assert floor["joint spread aligned [deg]"] == ""  # one repeat has no spread either
    (headline,) = _rows(tmp_path / "out", "headline")
    assert headline["floor"] == "no floor: one repeat" and headline["tuned / floor"] == ""
    text = _text(_section(page, "tuned"))
    assert "No floor: one repeat, which scores 0 against itself (record two or more" in text
    rows = _rows(tmp_path / "out", "joint_errors")
    assert rows and all(r["repeat spread [deg]"] == "" for r in rows)
