"""Tuning end to end on the shipped reference recording: improvement, store, kill and resume."""

import json
import os
import signal
import subprocess
import sys
import time

import numpy as np
import pytest

from simtune.reference import REFERENCE_DIR
from simtune.reference.demo import DEMO_PARAMETERS
from simtune.runs import RunConfig, resume_run, start_run
from simtune.store import RunStore

ONLY = list(DEMO_PARAMETERS)


def config(**kw):
    base = dict(engine="mujoco", tasks="cube", space="extended", data=str(REFERENCE_DIR), seed=3,
                workers=1, max_generations=4, only=ONLY)
    base.update(kw)
    return RunConfig(**base)


def test_short_tune_improves_on_generic_and_stores_every_evaluation(tmp_path):
    result = start_run(config(), tmp_path / "run", show_progress=False)
    store = RunStore(tmp_path / "run")
    generic = store.get("generic")["fitness"]
    assert result.fitness < generic
    rows = store.evaluations()
    assert len(rows) == result.evaluations == result.new_evaluations
    assert min(r["fitness"] for r in rows) == pytest.approx(result.fitness)
    assert len(store.generations()) == result.generations == 4
    best = json.loads((tmp_path / "run" / "best_params.json").read_text())
    assert best["fitness"] == pytest.approx(result.fitness) and set(best["params"]) == set(ONLY)
    assert store.get("versions")["mujoco"] and store.get("config")["seed"] == 3


def test_same_seed_same_result_with_one_or_two_workers(tmp_path):
    one = start_run(config(max_generations=2), tmp_path / "one", show_progress=False)
    two = start_run(config(max_generations=2, workers=2), tmp_path / "two", show_progress=False)
    assert one.fitness == two.fitness
    np.testing.assert_array_equal(one.x, two.x)


def test_kill_minus_9_then_resume_loses_and_repeats_nothing(tmp_path):
    reference = start_run(config(), tmp_path / "uninterrupted", show_progress=False)
    run_dir = tmp_path / "killed"
    cmd = [sys.executable, "-m", "simtune.cli", "tune", "--engine", "mujoco", "--task", "cube",
           "--data", str(REFERENCE_DIR), "--space", "extended", "--seed", "3", "--max-generations", "4",
           "--only", ",".join(ONLY), "--out", str(run_dir), "--quiet"]
    proc = subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    deadline = time.time() + 120
    done_before_kill = 0
    while time.time() < deadline:
        if (run_dir / "run.sqlite").exists():
            try:
                done_before_kill = RunStore(run_dir).count_evaluations()
            except Exception:
                done_before_kill = 0
            if done_before_kill >= 15:
                break
        time.sleep(0.05)
    os.kill(proc.pid, signal.SIGKILL)
    proc.wait()
    assert 15 <= done_before_kill < reference.evaluations, "the kill must land mid-run"
    kept = RunStore(run_dir).count_evaluations()
    resumed = resume_run(run_dir, show_progress=False)
    assert resumed.new_evaluations == reference.evaluations - kept  # nothing simulated twice
    assert resumed.evaluations == reference.evaluations  # nothing lost
    assert resumed.fitness == reference.fitness
    np.testing.assert_array_equal(resumed.x, reference.x)


def test_a_folder_with_a_run_is_not_overwritten(tmp_path):
    start_run(config(max_generations=1), tmp_path / "r", show_progress=False)
    from simtune.errors import SimtuneError

    with pytest.raises(SimtuneError, match="already holds a run"):
        start_run(config(max_generations=1), tmp_path / "r", show_progress=False)


def test_short_tune_on_real_recordings_improves_on_generic(mocap_root, tmp_path):
    """A few generations on the real `single` repeats already find the command delay."""
    cfg = RunConfig(engine="mujoco", tasks="single", space="extended", data=str(mocap_root), seed=0,
                    max_generations=5, only=["command_delay", "max_velocity_joint_2", "marker_offset_z"])
    result = start_run(cfg, tmp_path / "real", show_progress=False)
    generic = RunStore(tmp_path / "real").get("generic")["fitness"]
    assert generic > 0.1
    assert result.fitness < 0.5 * generic
    assert 0.8 < result.params["command_delay"] < 2.0
