"""The report's untuned baseline (Tables 4 and 5) for `auto` runs: the random half of the first global phase,
not generation 0 (the opening's start point and its Jacobian, all close to the generic point)."""

import shutil
import sqlite3

import numpy as np
import pytest

from simtune.optimize import pipeline
from simtune.reference import REFERENCE_DIR
from simtune.report.collect import Group, group_runs, load_run
from simtune.report.tables import _initial_values, importance_table, mann_whitney_table
from simtune.runs import RunConfig, start_run
from simtune.store import RunStore

ONLY = ["command_delay", "max_velocity_joint_2", "marker_offset_z", "mass_link_2", "mass_link_3"]


@pytest.fixture(scope="module")
def auto_run(tmp_path_factory):
    run_dir = tmp_path_factory.mktemp("untuned") / "run"
    with pytest.MonkeyPatch.context() as patch:  # short rounds: the opening, then one DE generation
        patch.setattr(pipeline, "GLOBAL_GENERATIONS", 1)
        patch.setattr(pipeline, "LOCAL_NFEV", 2)
        config = RunConfig(
            engine="mujoco",
            tasks="cube",
            space="extended",
            data=str(REFERENCE_DIR),
            seed=4,
            only=ONLY,
            optimizer="auto",
            max_evaluations=28,
            threads=True,
        )
        start_run(config, run_dir, show_progress=False)
    return run_dir


def _stored(run_dir) -> tuple[list[dict], list[tuple[float, float]]]:
    store = RunStore.open_read_only(run_dir)
    try:
        return store.evaluations(), store.get("bounds")
    finally:
        store.close()


def test_an_auto_runs_untuned_sample_is_its_random_start_and_its_scores(auto_run):
    run = load_run(auto_run)
    evaluations, bounds = _stored(auto_run)
    lows, highs = np.array(bounds).T
    drawn = np.array(run.random_start)
    size = pipeline.global_population_size(len(ONLY))
    assert drawn.shape == (size - 1 - int(pipeline.NEAR_SHARE * size), len(ONLY))
    np.testing.assert_allclose(drawn, lows + pipeline.random_start(len(ONLY), 4) * (highs - lows))
    # generation 0 is the opening: the aligned start and its Jacobian, within a few per cent of each range
    opening = np.array([e["x"] for e in evaluations if e["generation"] == 0])
    opening_spread = np.ptp((opening - lows) / (highs - lows), axis=0)
    drawn_spread = np.ptp((drawn - lows) / (highs - lows), axis=0)
    assert opening_spread.max() < 0.1 and drawn_spread.mean() > 0.25  # the random start spans the box
    # each drawn member was scored in the first global phase: its fitness is the stored one (the lean store keeps
    # a float32 copy of most vectors)
    assert len(run.random_start_fitness) == len(drawn)
    for member, fitness in zip(drawn, run.random_start_fitness):
        match = [e for e in evaluations if np.allclose((e["x"] - member) / (highs - lows), 0.0, rtol=0, atol=1e-6)]
        assert len(match) == 1 and match[0]["generation"] > 0 and match[0]["fitness"] == fitness
    assert run.population_size == size  # Table III's population: the global phase's, not the opening's batch


def test_the_importance_and_mann_whitney_tables_use_it(auto_run):
    run = load_run(auto_run)
    group = Group(run.engine, run.tasks, run.space, [run])
    for i, name in enumerate(run.parameters):
        np.testing.assert_array_equal(_initial_values(group, name), np.array(run.random_start)[:, i])
    row = mann_whitney_table([group]).rows[0]
    assert row[4] == len(run.random_start_fitness)  # untuned n
    assert row[6] == pytest.approx(float(np.median(run.random_start_fitness)))
    groups, _ = group_runs([run])
    assert importance_table(groups).rows  # builds on the random start without error


def test_a_run_that_stopped_in_its_opening_has_a_random_start_but_no_scores(auto_run, tmp_path):
    stopped = tmp_path / "stopped"
    shutil.copytree(auto_run, stopped)
    with sqlite3.connect(stopped / "run.sqlite") as db:  # what a run that met its target in the opening holds
        opening = db.execute("SELECT MIN(generation) FROM evaluations WHERE generation > 0").fetchone()[0]
        db.execute("DELETE FROM evaluations WHERE generation > ?", (opening,))
    run = load_run(stopped)
    assert len(run.random_start) > 0 and run.random_start_fitness == []
    row = mann_whitney_table([Group(run.engine, run.tasks, run.space, [run])]).rows[0]
    assert row[4] == 0 and row[6] is None
