"""`simtune transfer`: tune on single + cube, test on double, with every recording made by `simtune synth`."""

import json
import subprocess
import sys

import pytest


def simtune(*args):
    return subprocess.run([sys.executable, "-m", "simtune.cli", *args], capture_output=True, text=True, timeout=300)


@pytest.fixture(scope="module")
def synthetic_root(tmp_path_factory):
    root = tmp_path_factory.mktemp("synthetic")
    truth = root.parent / "truth-in.json"
    truth.write_text(json.dumps({"command_delay": 1.3, "max_velocity_joint_2": 27.0}))
    proc = simtune(
        "synth",
        "--engine",
        "mujoco",
        "--task",
        "single,cube,double",
        "--truth",
        str(truth),
        "--repeats",
        "2",
        "--seed",
        "4",
        "--out",
        str(root),
    )
    assert proc.returncode == 0, proc.stderr
    return root


@pytest.mark.slow  # about 15 s: a tuning run and its transfer
def test_transfer_runs_end_to_end_and_its_params_evaluate_on_the_test_task(synthetic_root, tmp_path):
    out = tmp_path / "transfer"
    args = [
        "transfer",
        "--engine",
        "mujoco",
        "--train",
        "single,cube",
        "--test",
        "double",
        "--data",
        str(synthetic_root),
        "--space",
        "extended",
        "--only",
        "command_delay,max_velocity_joint_2",
        "--optimizer",
        "cmaes",
        "--max-evaluations",
        "14",
        "--out",
        str(out),
    ]
    proc = simtune(*args, "--json", "--quiet")
    assert proc.returncode == 0, proc.stderr
    result = json.loads(proc.stdout)
    rows = {r["task"]: r for r in result["tasks"]}
    assert [(r["task"], r["role"]) for r in result["tasks"]] == [
        ("single", "train"),
        ("cube", "train"),
        ("double", "test"),
    ]
    # each train task tunes its own clock's delay; the unseen task's clock is aligned from its recordings
    tuned = json.loads((out / "transfer.json").read_text())["params"]
    assert set(tuned) == {"command_delay_single", "command_delay_cube", "max_velocity_joint_2"}
    for row in rows.values():
        assert row["tuned" if row["role"] == "train" else "tuned_aligned"] < 0.5 * row["generic"]
    # (the 14-evaluation search leaves the velocity clamp off its truth: the delay found compensates a little)
    assert rows["double"]["delay_s"] == pytest.approx(1.3, abs=0.4) and rows["single"]["delay_s"] is None
    assert rows["double"]["tuned_aligned"] < rows["double"]["tuned"]
    assert result["totals"]["test"]["tuned"] == pytest.approx(rows["double"]["tuned"])
    assert result["totals"]["test"]["tuned_aligned"] == pytest.approx(rows["double"]["tuned_aligned"])
    assert result["evaluations"] == 14
    # the tuned parameters, from a run on other tasks, are accepted by `evaluate --params-file`
    ev = simtune(
        "evaluate",
        "--engine",
        "mujoco",
        "--task",
        "double",
        "--data",
        str(synthetic_root),
        "--params-file",
        result["best_params_file"],
        "--json",
    )
    assert ev.returncode == 0, ev.stderr
    # evaluate aligns the unseen task's clock the same way, and reports the unaligned fitness beside it
    evaluated = json.loads(ev.stdout)
    assert evaluated["fitness"] == pytest.approx(rows["double"]["tuned_aligned"], abs=1e-12)
    assert evaluated["fitness_unaligned"] == pytest.approx(rows["double"]["tuned"], abs=1e-12)
    # the table; running again reuses the finished tuning run
    table = simtune(*args, "--quiet")
    assert table.returncode == 0, table.stderr
    for text in ("double", "test", "train", "generic", "tuned", "all test", "clock aligned"):
        assert text in table.stdout
    assert json.loads((out / "transfer.json").read_text())["tasks"] == result["tasks"]


def test_transfer_refuses_a_test_task_it_trains_on_and_missing_test_data(synthetic_root, tmp_path):
    proc = simtune(
        "transfer",
        "--train",
        "single,cube",
        "--test",
        "cube",
        "--data",
        str(synthetic_root),
        "--out",
        str(tmp_path / "t"),
    )
    assert proc.returncode == 2 and "also in --train" in proc.stderr and proc.stderr.count("\n") == 1
    proc = simtune(
        "transfer", "--train", "single", "--test", "seed-1", "--data", str(synthetic_root), "--out", str(tmp_path / "t")
    )
    assert proc.returncode == 2 and "no recordings for task 'seed-1'" in proc.stderr
    assert not (tmp_path / "t").exists()  # refused before tuning
