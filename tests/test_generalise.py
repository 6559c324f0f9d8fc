"""`simtune generalise`: each task tuned alone, all together and left out, one table against the floors."""

import json
import subprocess
import sys

import pytest

from simtune.errors import ConfigError
from simtune.run_config import RunConfig
from simtune.studies.generalise import study_runs


def simtune(*args):
    return subprocess.run([sys.executable, "-m", "simtune.cli", *args], capture_output=True, text=True, timeout=600)


def test_two_tasks_take_three_runs_their_leave_one_out_the_other_task_alone(tmp_path):
    runs = study_runs(RunConfig(tasks="single,cube"), tmp_path)
    assert list(runs) == ["alone/single", "alone/cube", "joint"]
    assert [config.tasks for config, _ in runs.values()] == ["single", "cube", "single,cube"]
    assert runs["joint"][1] == tmp_path / "joint"


def test_three_tasks_add_a_run_leaving_each_out(tmp_path):
    runs = study_runs(RunConfig(tasks="single,cube,double", seed=3), tmp_path)
    assert list(runs)[4:] == ["without/single", "without/cube", "without/double"]
    assert runs["without/cube"][0].tasks == "single,double"
    assert {config.seed for config, _ in runs.values()} == {3}  # every run with the study's settings


def test_one_task_is_refused_as_nothing_to_leave_out(tmp_path):
    with pytest.raises(ConfigError, match="two tasks or more"):
        study_runs(RunConfig(tasks="single"), tmp_path)


@pytest.fixture(scope="module")
def one_truth(tmp_path_factory):
    """single and double, both made by one truth: one simulator fits both."""
    root = tmp_path_factory.mktemp("one-truth")
    truth = root.parent / "truth-in.json"
    truth.write_text(json.dumps({"command_delay": 0.4, "max_velocity_joint_2": 27.0}))
    proc = simtune(
        "synth", "--task", "single,double", "--truth", str(truth), "--repeats", "2", "--seed", "1", "--out", str(root)
    )
    assert proc.returncode == 0, proc.stderr
    return root


@pytest.mark.slow  # about 40 s: three short tuning runs and the held-out alignment
def test_the_study_scores_each_task_alone_joint_and_held_out_and_reuses_its_runs(one_truth, tmp_path):
    out = tmp_path / "study"
    args = [
        "generalise",
        "--task",
        "single,double",
        "--data",
        str(one_truth),
        "--space",
        "extended",
        "--only",
        "command_delay,max_velocity_joint_2",
        "--optimizer",
        "cmaes",
        "--max-evaluations",
        "40",
        "--workers",
        "1",
        "--out",
        str(out),
    ]
    proc = simtune(*args, "--json")
    assert proc.returncode == 0, proc.stderr
    result = json.loads(proc.stdout)
    assert result == json.loads((out / "generalise.json").read_text())
    rows = {r["task"]: r for r in result["rows"]}
    assert set(rows) == {"single", "double"}
    for name, other in (("single", "double"), ("double", "single")):
        row = rows[name]
        assert row["held_out_from"] == [other]
        assert row["floor"] is not None and row["floor"] > 0
        assert row["penalty"] == pytest.approx(row["joint"]["fitness"] / row["alone"]["fitness"])
        # held out: the task's clock aligned by the study (the recordings' delay is 0.4 s; these short runs leave
        # the velocity limit rough, which the delay partly makes up for)
        assert 0.2 < row["held_out"]["delay_s"] < 0.7
        assert row["held_out"]["fitness"] < 0.05  # a blown-up or unaligned rollout scores far above
        assert row["alone"]["delay_s"] is None
    assert result["joint_penalty"] == pytest.approx(
        sorted(r["penalty"] for r in rows.values())[0] / 2 + sorted(r["penalty"] for r in rows.values())[1] / 2
    )
    assert set(result["evaluations"]) == {"alone/single", "alone/double", "joint"}
    # run again: every run is reused, nothing is tuned anew
    again = simtune(*args)
    assert again.returncode == 0, again.stderr
    assert "joint/alone" in again.stdout and "held out" in again.stdout
    assert json.loads((out / "generalise.json").read_text())["evaluations"] == result["evaluations"]


@pytest.mark.slow  # a synthetic data set and a short run
def test_a_folder_of_runs_with_other_settings_is_refused(one_truth, tmp_path):
    out = tmp_path / "study"
    (out / "alone").mkdir(parents=True)
    base = ["generalise", "--task", "single,double", "--data", str(one_truth), "--workers", "1", "--out", str(out)]
    proc = simtune(
        "tune",
        "--task",
        "single",
        "--data",
        str(one_truth),
        "--max-evaluations",
        "4",
        "--space",
        "extended",
        "--only",
        "command_delay",
        "--out",
        str(out / "alone" / "single"),
    )
    assert proc.returncode == 0, proc.stderr
    refused = simtune(*base, "--max-evaluations", "4")
    assert refused.returncode == 2
    assert "other settings" in refused.stderr and "Traceback" not in refused.stderr
