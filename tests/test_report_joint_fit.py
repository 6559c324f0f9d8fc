"""`simtune report` of multi-task runs and `simtune generalise` studies (issue 67, item 1).

The report of a run tuned on several tasks shows each task's part beside its floor and its alone-best (a one-task run
among the report's runs, beside it in a study's folder, or in the study's generalise.json), with the joint-fit
penalty, or says how to get the alone-best; given a study's folder it shows the study's table as generalise.json has
it.  The end-to-end test runs a small real study (MuJoCo, synthetic recordings of one truth, 12 evaluations a run).
"""

from __future__ import annotations

import csv
import json
import shutil
import warnings
from pathlib import Path

import pytest

from simtune import api
from simtune.report import make_report
from simtune.report.builder import ReportWarning
from simtune.report.joint_fit import NOT_FOUND, Study, find_studies, load_study, read_studies, study_table
from simtune.studies.synth import make_synthetic

#: a study's generalise.json as `simtune generalise` writes it, two tasks (numbers made up)
STUDY = {
    "engine": "mujoco",
    "tasks": ["single", "cube"],
    "space": "calibrated",
    "optimizer": "auto",
    "seed": 0,
    "data": "/data",
    "reference": "aligned",
    "runs": {"alone/single": "S/alone/single", "alone/cube": "S/alone/cube", "joint": "S/joint"},
    "evaluations": {"alone/single": 100, "alone/cube": 120, "joint": 300},
    "rows": [
        {
            "task": "single",
            "floor": 0.0015,
            "alone": {"fitness": 0.0033, "wrist": 0.0033, "delay_s": None},
            "joint": {"fitness": 0.0060, "wrist": 0.0060, "delay_s": None},
            "held_out": {"fitness": 0.0180, "wrist": 0.0180, "delay_s": 0.412},
            "held_out_from": ["cube"],
            "penalty": 0.0060 / 0.0033,
            "transfer": 0.0180 / 0.0033,
            "alone_over_floor": 0.0033 / 0.0015,
            "joint_over_floor": 0.0060 / 0.0015,
            "held_out_over_floor": 0.0180 / 0.0015,
        },
        {
            "task": "cube",
            "floor": None,
            "alone": {"fitness": 0.0060, "wrist": 0.004, "delay_s": None},
            "joint": {"fitness": 0.0129, "wrist": 0.009, "delay_s": None},
            "held_out": {"fitness": 0.0200, "wrist": 0.015, "delay_s": 1.25},
            "held_out_from": ["single"],
            "penalty": 0.0129 / 0.0060,
            "transfer": 0.0200 / 0.0060,
            "alone_over_floor": None,
            "joint_over_floor": None,
            "held_out_over_floor": None,
        },
    ],
    "joint_penalty": 2.0,
    "transfer": 4.0,
}


def _rows(report: Path, name: str) -> list[dict]:
    return list(csv.DictReader((report / "tables" / f"{name}.csv").read_text().splitlines()))


def test_the_study_table_shows_each_task_as_generalise_json_has_it(tmp_path):
    table = study_table(Study(tmp_path / "generalise.json", STUDY), "generalise_1")
    assert table.name == "generalise_1"
    assert table.headers[:3] == ["task", "floor", "alone"]
    named = [dict(zip(table.headers, row)) for row in table.rows]
    assert [r["task"] for r in named] == ["single", "cube"]
    single, cube = named
    assert single["floor"] == 0.0015 and single["alone"] == 0.0033 and single["joint"] == 0.0060
    assert single["joint / alone"] == pytest.approx(0.0060 / 0.0033)
    assert single["held out"] == 0.0180 and single["held / alone"] == pytest.approx(0.0180 / 0.0033)
    assert single["held-out delay [s]"] == 0.412 and single["held out: tuned on"] == "cube"
    assert cube["floor"] is None and cube["joint / floor"] is None  # one repeat: no floor, no ratio to it
    markdown = table.to_markdown()
    assert "| cube | - | 0.006 |" in markdown
    assert "joint / alone 2.00, held / alone 4.00" in table.note and str(tmp_path) in table.note


def test_a_study_is_found_under_an_input_next_to_its_joint_run_and_two_up_from_an_alone_run(tmp_path):
    study = tmp_path / "study"
    for folder in ("joint", "alone/single", "alone/cube"):
        (study / folder).mkdir(parents=True)
    (study / "generalise.json").write_text(json.dumps(STUDY))
    result = study / "generalise.json"
    assert find_studies([study]) == [result]
    assert find_studies([study / "joint"]) == [result]
    assert find_studies([study / "alone" / "cube"]) == [result]
    assert find_studies([study / "alone" / "cube", study / "joint"]) == [result]  # each file once
    assert find_studies([tmp_path / "elsewhere"]) == []
    assert load_study(result).result == STUDY


def test_a_broken_generalise_json_is_named_in_a_warning_and_left_out(tmp_path):
    (tmp_path / "generalise.json").write_text('{"rows": [{"task": "single"}]}')
    said: list[str] = []
    assert read_studies([tmp_path], said.append) == []
    assert len(said) == 1 and "generalise.json: skipped: not a readable `simtune generalise` result" in said[0]
    (tmp_path / "generalise.json").write_text(json.dumps({**STUDY, "data": 5}))
    assert read_studies([tmp_path], said.append) == [] and "data: expected a folder or null, got 5" in said[1]


@pytest.fixture(scope="module")
def study(tmp_path_factory) -> Path:
    """A small real study: single and double, made by one truth, each tuned alone and together."""
    root = tmp_path_factory.mktemp("joint-fit")
    data = root / "data"
    make_synthetic(
        "mujoco", "single,double", data, truth={"command_delay": 0.4, "max_velocity_joint_2": 27.0}, repeats=2
    )
    api.generalise(
        "mujoco",
        "single,double",
        out=root / "study",
        data=data,
        space="extended",
        only="command_delay,max_velocity_joint_2",
        optimizer="cmaes",
        max_evaluations=12,
        workers=1,
    )
    return root / "study"


def _report(runs: Path, out: Path) -> tuple[str, list[str]]:
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        index = make_report(runs, out, show_progress=False)
    return index.read_text(), [str(w.message) for w in caught if issubclass(w.category, ReportWarning)]


def _assert_joint_fit_matches(report: Path, result: dict, source: str) -> None:
    rows = {r["task"]: r for r in _rows(report, "joint_fit")}
    assert set(rows) == {"single", "double"}
    for expected in result["rows"]:
        row = rows[expected["task"]]
        assert row["tuned on"] == "single,double"
        assert float(row["floor"]) == pytest.approx(expected["floor"], rel=1e-9)
        assert float(row["part"]) == pytest.approx(expected["joint"]["fitness"], rel=1e-6)
        assert float(row["alone-best"]) == pytest.approx(expected["alone"]["fitness"], rel=1e-6)
        assert float(row["joint / alone"]) == pytest.approx(expected["penalty"], rel=1e-6)
        assert float(row["part / floor"]) == pytest.approx(expected["joint_over_floor"], rel=1e-6)
        assert row["alone-best from"].endswith(f"{source}/{expected['task']}")


@pytest.mark.slow  # about 50 s: three short tuning runs, the held-out alignment and three reports
def test_the_report_of_a_study_and_of_its_joint_run_show_each_task_beside_its_floor_and_alone_best(study, tmp_path):
    result = json.loads((study / "generalise.json").read_text())

    # the study's folder: its runs found as in any folder, and its table as a section
    page, said = _report(study, tmp_path / "all")
    assert not [w for w in said if "generalise" in w or "alone-best" in w], said
    assert '<section id="joint_fit">' in page and "Joint fit and generalisation" in page
    _assert_joint_fit_matches(tmp_path / "all", result, "alone")
    table = _rows(tmp_path / "all", "generalise_1")
    assert [r["task"] for r in table] == result["tasks"]
    for row, expected in zip(table, result["rows"]):
        for column, value in (
            ("floor", expected["floor"]),
            ("alone", expected["alone"]["fitness"]),
            ("joint", expected["joint"]["fitness"]),
            ("joint / alone", expected["penalty"]),
            ("held out", expected["held_out"]["fitness"]),
            ("held / alone", expected["transfer"]),
            ("held-out delay [s]", expected["held_out"]["delay_s"]),
        ):
            assert float(row[column]) == float(value), column  # as generalise.json has it, to the last digit
        assert row["held out: tuned on"] == ", ".join(expected["held_out_from"])

    # the joint run alone: its alone-bests from the study's runs beside it, the study's table from next to it
    page, said = _report(study / "joint", tmp_path / "joint")
    _assert_joint_fit_matches(tmp_path / "joint", result, "alone")
    assert (tmp_path / "joint" / "tables" / "generalise_1.csv").is_file()

    # a copy of the joint run with nothing beside it: no alone-best, and the command that gets one
    lonely = tmp_path / "lonely" / "joint"
    shutil.copytree(study / "joint", lonely)
    page, said = _report(lonely, tmp_path / "lonely-report")
    rows = _rows(tmp_path / "lonely-report", "joint_fit")
    assert [r["alone-best"] for r in rows] == ["", ""] and [r["joint / alone"] for r in rows] == ["", ""]
    hint = rows[0]["alone-best from"]
    assert hint.startswith(f"{NOT_FOUND}: simtune generalise --engine mujoco --task single,double --space extended")
    assert not (tmp_path / "lonely-report" / "tables" / "generalise_1.csv").exists()
