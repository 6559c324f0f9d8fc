"""Tuning end to end on the shipped reference recording: improvement, store, kill and resume."""

import json
import sys

import numpy as np
import pytest
from conftest import kill_when

from simtune.reference import REFERENCE_DIR
from simtune.reference.demo import DEMO_PARAMETERS
from simtune.runs import RunConfig, resume_run, start_run
from simtune.store import RunStore

ONLY = list(DEMO_PARAMETERS)


def config(**kw):
    base = dict(
        engine="mujoco",
        tasks="cube",
        space="extended",
        data=str(REFERENCE_DIR),
        seed=3,
        workers=1,
        max_generations=4,
        only=ONLY,
        optimizer="de",
    )
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


def test_a_time_cap_reached_inside_a_batch_says_how_long_the_search_ran(tmp_path):
    """Probe 5 #6: `--max-seconds 120` ran 323 s and said "stopped after 120 s". The cap cuts the first batch after
    its first evaluation (which always runs): the reason gives the search's own seconds beside its cap, and how much
    of the batch was done (tests/test_time_cap.py times the cut)."""
    result = start_run(config(max_seconds=0.01, max_generations=50), tmp_path / "run", show_progress=False)
    assert result.stop_reason == "max-seconds"
    assert result.message.startswith("stopped after ") and "its cap 0.01 s reached inside a batch" in result.message
    assert f"(1 of its {len(ONLY)} evaluations done and stored)" in result.message and result.new_evaluations == 1
    ran = float(result.message.split()[2])
    assert ran == pytest.approx(result.wall_s, abs=1.0)


def test_an_evaluation_budget_reached_inside_a_generation_says_what_it_used(tmp_path):
    """Probe 5 #20: `--max-evaluations 4` ran a whole generation (DE's population) and said only "max-evaluations"."""
    result = start_run(config(max_evaluations=4), tmp_path / "run", show_progress=False)
    assert result.stop_reason == "max-evaluations" and result.evaluations > 4
    assert result.message.startswith(f"used {result.evaluations} evaluations, its budget of 4 reached inside a batch")


@pytest.mark.slow  # a process pool of two workers: about 10 s
def test_same_seed_same_result_with_one_or_two_workers(tmp_path):
    one = start_run(config(max_generations=2), tmp_path / "one", show_progress=False)
    two = start_run(config(max_generations=2, workers=2), tmp_path / "two", show_progress=False)
    assert one.fitness == two.fitness
    np.testing.assert_array_equal(one.x, two.x)


@pytest.mark.slow  # two runs and a resume (8 s); the kill -9 test below is its end-to-end form
def test_resume_after_a_crash_redoes_nothing_and_ends_where_an_uninterrupted_run_ends(tmp_path):
    """The fast form of the kill -9 test below: the store is cut back to what a crash in the last
    generation leaves (evaluations are committed one by one, the checkpoint once per generation)."""
    import shutil
    import sqlite3

    reference = start_run(config(max_generations=2), tmp_path / "uninterrupted", show_progress=False)
    run_dir = tmp_path / "crashed"
    shutil.copytree(tmp_path / "uninterrupted", run_dir)
    (run_dir / "best_params.json").unlink()
    with sqlite3.connect(run_dir / "run.sqlite") as db:
        last = db.execute("SELECT MAX(generation) FROM evaluations").fetchone()[0]
        kept = db.execute("SELECT MIN(id) + 2 FROM evaluations WHERE generation = ?", (last,)).fetchone()[0]
        lost = db.execute("DELETE FROM evaluations WHERE id > ?", (kept,)).rowcount
        db.execute("DELETE FROM generations WHERE generation >= ?", (last,))
        db.execute("UPDATE meta SET value = ? WHERE key = 'status'", ('"running"',))
    assert lost > 0
    resumed = resume_run(run_dir, show_progress=False)
    assert resumed.new_evaluations == lost  # nothing simulated twice
    assert resumed.evaluations == reference.evaluations  # nothing lost
    assert resumed.fitness == reference.fitness
    np.testing.assert_array_equal(resumed.x, reference.x)
    assert RunStore(run_dir).get("status") == "finished" and (run_dir / "best_params.json").exists()


@pytest.mark.slow
def test_repeated_kill_minus_9_then_resume_loses_and_repeats_nothing(tmp_path):
    import random

    reference = start_run(config(), tmp_path / "uninterrupted", show_progress=False)
    run_dir = tmp_path / "killed"
    tune = [
        sys.executable,
        "-m",
        "simtune.cli",
        "tune",
        "--engine",
        "mujoco",
        "--task",
        "cube",
        "--data",
        str(REFERENCE_DIR),
        "--space",
        "extended",
        "--seed",
        "3",
        "--max-generations",
        "4",
        "--only",
        ",".join(ONLY),
        "--out",
        str(run_dir),
        "--quiet",
        "--optimizer",
        "de",  # the reference run is config()'s: differential evolution
    ]
    resume = [sys.executable, "-m", "simtune.cli", "resume", str(run_dir), "--quiet"]
    points = sorted(random.Random(7).sample(range(5, reference.evaluations - 5), 3))
    kept = kill_when(tune, run_dir, points[0])
    for point in points[1:]:
        assert kept < reference.evaluations, "each kill must land mid-run"
        kept = kill_when(resume, run_dir, point)
    assert kept < reference.evaluations
    resumed = resume_run(run_dir, show_progress=False)
    assert resumed.new_evaluations == reference.evaluations - kept  # nothing simulated twice
    assert resumed.evaluations == reference.evaluations  # nothing lost
    assert resumed.fitness == reference.fitness
    np.testing.assert_array_equal(resumed.x, reference.x)
    store = RunStore(run_dir)
    assert len({tuple(r["x"]) for r in store.evaluations()}) == reference.evaluations
    assert store.get("status") == "finished"


@pytest.mark.slow  # 5 s: two tunes through the CLI
def test_a_folder_with_a_run_is_not_overwritten(tmp_path):
    start_run(config(max_generations=1), tmp_path / "r", show_progress=False)
    from simtune.errors import SimtuneError

    with pytest.raises(SimtuneError, match="already holds a run"):
        start_run(config(max_generations=1), tmp_path / "r", show_progress=False)


@pytest.mark.slow
def test_short_tune_on_real_recordings_improves_on_generic(mocap_root, tmp_path):
    """A few generations on the real `single` repeats already find the command delay."""
    cfg = RunConfig(
        optimizer="de",
        engine="mujoco",
        tasks="single",
        space="extended",
        data=str(mocap_root),
        seed=0,
        max_generations=5,
        only=["command_delay", "max_velocity_joint_2", "marker_offset_z"],
    )
    result = start_run(cfg, tmp_path / "real", show_progress=False)
    generic = RunStore(tmp_path / "real").get("generic")["fitness"]
    assert generic > 0.1
    assert result.fitness < 0.5 * generic
    assert 0.8 < result.params["command_delay"] < 2.0


@pytest.mark.slow  # 8 s
def test_params_file_reproduces_the_stored_best_fitness_exactly(tmp_path):
    import subprocess

    start_run(config(max_generations=2), tmp_path / "run", show_progress=False)
    best = json.loads((tmp_path / "run" / "best_params.json").read_text())
    proc = subprocess.run(
        [
            sys.executable,
            "-m",
            "simtune.cli",
            "evaluate",
            "--engine",
            "mujoco",
            "--task",
            "cube",
            "--params-file",
            str(tmp_path / "run" / "best_params.json"),
            "--json",
        ],
        capture_output=True,
        text=True,
        check=True,
    )
    assert abs(json.loads(proc.stdout)["fitness"] - best["fitness"]) < 1e-9


def test_params_file_with_a_missing_or_extra_value_is_refused(tmp_path):
    from simtune.errors import ConfigError
    from simtune.params import read_params_file

    path = tmp_path / "p.json"
    path.write_text(json.dumps({"parameters": ["timestep", "command_delay"], "params": {"timestep": 0.01}}))
    with pytest.raises(ConfigError, match="no value for parameter 'command_delay'"):
        read_params_file(path)
    path.write_text(json.dumps({"parameters": ["timestep"], "params": {"timestep": 0.01, "command_delay": 1}}))
    with pytest.raises(ConfigError, match="'command_delay' is not among"):
        read_params_file(path)


def test_run_store_from_another_version_is_refused(tmp_path):
    from simtune.errors import SimtuneError

    store = RunStore(tmp_path / "r", create=True)
    store.set(schema_version=99)
    store.close()
    with pytest.raises(SimtuneError, match="run store version 99"):
        RunStore(tmp_path / "r")


@pytest.mark.slow
def test_pruning_saves_simulation_without_changing_the_search(tmp_path):
    pruned = start_run(config(max_generations=6), tmp_path / "pruned", show_progress=False)
    full = start_run(config(max_generations=6, prune=False), tmp_path / "full", show_progress=False)
    assert pruned.fitness == full.fitness
    np.testing.assert_array_equal(pruned.x, full.x)
    assert pruned.evaluations == full.evaluations and pruned.generations == full.generations
    assert full.pruned_evaluations == 0 < pruned.pruned_evaluations
    assert pruned.steps < full.steps
    # every pruned trial really was worse than what the full run measured for it
    exact = {tuple(r["x"]): r["fitness"] for r in RunStore(tmp_path / "full").evaluations()}
    for row in RunStore(tmp_path / "pruned").evaluations():
        if row["pruned"]:
            assert row["fitness"] <= exact[tuple(row["x"])] + 1e-12


def test_a_store_that_cannot_be_written_is_one_clear_error(tmp_path):
    from simtune.errors import SimtuneError
    from simtune.fitness import Score

    store = RunStore(tmp_path / "r", create=True)
    store.db.execute("PRAGMA query_only = 1")  # every write now fails, as on a full or read-only disk
    with pytest.raises(SimtuneError, match="cannot write run store .*simtune resume"):
        store.record_evaluation(np.zeros(2), Score(0.1, 0.1, None), 0, 0.1)
