"""`--optimizer auto`: differential evolution, then least squares on the residuals, in rounds; resumable."""

import shutil
import sqlite3

import numpy as np
import pytest

from simtune.optimize import pipeline
from simtune.reference import REFERENCE_DIR
from simtune.runs import RunConfig, resume_run, start_run
from simtune.store import RunStore

ONLY = ["command_delay", "max_velocity_joint_2", "marker_offset_z"]


@pytest.fixture(autouse=True)
def short_rounds(monkeypatch):
    monkeypatch.setattr(pipeline, "GLOBAL_GENERATIONS", 2)  # rounds of 15 DE evaluations (population 5)
    monkeypatch.setattr(pipeline, "LOCAL_NFEV", 4)


def config(**kw) -> RunConfig:
    base = dict(
        engine="mujoco",
        tasks="cube",
        space="extended",
        data=str(REFERENCE_DIR),
        seed=1,
        only=ONLY,
        optimizer="auto",
        max_evaluations=60,
    )
    return RunConfig(**{**base, **kw})


@pytest.mark.slow  # three short runs: about 40 s
def test_auto_alternates_global_and_local_phases_and_replays_from_the_store(tmp_path):
    first = start_run(config(), tmp_path / "run", show_progress=False)
    store = RunStore.open_read_only(tmp_path / "run")
    generic = store.get("generic")["fitness"]
    with_residuals = store.db.execute("SELECT COUNT(*) FROM residuals").fetchone()[0]
    held = store.db.execute("SELECT COUNT(*) FROM generations WHERE population IS NOT NULL").fetchone()[0]
    sizes = list(np.diff([0] + [g["evaluations"] for g in store.generations()]))
    store.close()
    assert first.fitness < generic
    assert with_residuals >= 1 + len(ONLY)  # a local phase ran: a point and its Jacobian
    # DE generations (5 members; the latest population alone kept), least-squares points and Jacobians (3)
    assert 5 in sizes and len(ONLY) in sizes and held == 1
    # the budget is checked after each checkpoint: a global phase's first one holds its starting population (served
    # from the store where scored before) and its first generation, 2 x 5 evaluations asked for
    assert "least-squares steps" in first.message and 60 <= first.used_evaluations < 60 + 2 * 5

    again = start_run(config(), tmp_path / "again", show_progress=False)
    assert again.fitness == first.fitness
    np.testing.assert_array_equal(again.x, first.x)
    replay = resume_run(tmp_path / "run", show_progress=False)
    assert replay.new_evaluations == 0 and replay.evaluations == first.evaluations
    np.testing.assert_array_equal(replay.x, first.x)


@pytest.mark.slow  # two short runs: about 30 s
def test_auto_resumed_after_a_crash_in_a_local_phase_loses_and_redoes_nothing(tmp_path):
    reference = start_run(config(), tmp_path / "whole", show_progress=False)
    run_dir = tmp_path / "crashed"
    shutil.copytree(tmp_path / "whole", run_dir)
    (run_dir / "best_params.json").unlink()
    with sqlite3.connect(run_dir / "run.sqlite") as db:  # what a kill in the middle of a Jacobian leaves
        local = db.execute("SELECT MIN(id) FROM evaluations WHERE key IN (SELECT key FROM residuals)").fetchone()[0]
        kept = local + 2
        lost = db.execute("DELETE FROM evaluations WHERE id > ?", (kept,)).rowcount
        db.execute("DELETE FROM residuals WHERE key NOT IN (SELECT key FROM evaluations)")
        first_lost = db.execute("SELECT MAX(generation) FROM evaluations").fetchone()[0]
        db.execute("DELETE FROM generations WHERE generation >= ?", (first_lost,))
        db.execute("UPDATE meta SET value = ? WHERE key = 'status'", ('"running"',))
    assert lost > 0
    resumed = resume_run(run_dir, show_progress=False)
    assert resumed.new_evaluations == lost
    assert resumed.evaluations == reference.evaluations
    assert resumed.fitness == reference.fitness
    np.testing.assert_array_equal(resumed.x, reference.x)


def _scored(run_dir) -> set[tuple]:
    """Every point the run store holds (the store keeps some as float32 copies: compared as such)."""
    store = RunStore.open_read_only(run_dir)
    scored = {tuple(np.float32(e["x"])) for e in store.evaluations()}
    store.close()
    return scored


@pytest.mark.slow  # two whole `auto` runs (about 25 s): the slow tier
def test_auto_takes_the_same_path_on_any_number_of_workers(tmp_path):
    alone = start_run(config(max_evaluations=45, threads=True), tmp_path / "one", show_progress=False)
    shared = start_run(config(max_evaluations=45, threads=True, workers=3), tmp_path / "three", show_progress=False)
    # every point the one-worker search scored, the three-worker one scored too, and it stopped at the same
    # count of points asked for; what it scored besides (columns of rejected trials) can only improve the best
    assert _scored(tmp_path / "one") <= _scored(tmp_path / "three")
    assert shared.used_evaluations == alone.used_evaluations
    assert shared.fitness <= alone.fitness


def test_the_first_global_population_holds_the_openings_best_and_half_its_members_close_to_it():
    best = np.array([0.999, 0.5, 0.0])  # in the unit cube, one coordinate at each edge
    population = pipeline.opening_population(best, seed=3)
    again = pipeline.opening_population(best, seed=3)
    assert population.shape == (max(5, pipeline.POPSIZE * 3), 3)
    np.testing.assert_array_equal(population, again)  # a resumed run draws the same
    np.testing.assert_array_equal(population[0], best)
    assert ((population >= 0.0) & (population <= 1.0)).all()
    close = np.abs(population - best).max(axis=1) <= 5 * pipeline.NEAR_SCALE
    near = int(pipeline.NEAR_SHARE * len(population))
    assert close[: 1 + near].all()
    assert close[1 + near :].sum() < len(population) - 1 - near  # the others spread over the box


def test_rounds_converge_when_the_last_rounds_together_gain_less_than_the_tolerance():
    patience, rtol = pipeline.PATIENCE, pipeline.ROUND_RTOL
    flat = [1.0] + [1.0 - 0.4 * rtol * k / patience for k in range(1, patience + 1)]
    assert pipeline.converged(flat)
    assert not pipeline.converged(flat[:-1])  # not enough rounds yet
    assert not pipeline.converged([1.0] + [1.0 - 2 * rtol * k for k in range(1, patience + 1)])  # still gaining
    assert not pipeline.converged([float("inf")] * (patience + 1))  # nothing scored yet: no basin to judge
    # a long run is judged on the last half of its rounds: twelve rounds gaining 3 % each, then two flat ones, go on
    # (real `cube`'s finds come in bursts after such plateaus); flat for half of the rounds, it has converged
    gaining = [0.97**k for k in range(13)]
    assert pipeline.patience(gaining + [gaining[-1]] * 2) == 7
    assert not pipeline.converged(gaining + [gaining[-1]] * patience)
    assert pipeline.converged(gaining + [gaining[-1]] * 11)  # 23 rounds, the last 11 flat
    assert not pipeline.converged(gaining + [gaining[-1]] * 10)  # 22 rounds, the last 11 gained 3 %


def test_the_noise_floor_is_what_the_mean_of_the_repeats_leaves_a_fit_of_the_truth():
    rng = np.random.default_rng(0)
    noise, repeats, size = 0.5, 5, 20000
    truth = np.zeros(size)
    recorded = truth + rng.normal(0.0, noise, (repeats, size))
    mean = recorded.mean(axis=0)
    floor = pipeline.noise_floor_cost([recorded - mean])
    assert floor == pytest.approx(size * noise**2 / repeats, rel=0.03)
    # the truth's residuals against the mean sit at the floor; a fit a little off it does not
    assert pipeline.at_noise_floor(truth - mean, floor)
    assert not pipeline.at_noise_floor(truth + 0.2 * noise - mean, floor)
    # two tasks: their floors add up; a task of one repeat, or repeats that agree exactly, leave no floor
    assert pipeline.noise_floor_cost([recorded - mean] * 2) == pytest.approx(2 * floor)
    assert pipeline.noise_floor_cost([recorded - mean, None]) is None
    assert pipeline.noise_floor_cost([np.zeros((3, 4))]) is None
    assert not pipeline.at_noise_floor(np.zeros(4), None)  # no floor: the old rule alone
    assert not pipeline.at_noise_floor(np.full(4, np.nan), floor)


def test_auto_stops_at_the_noise_floor_only_against_an_aligned_reference():
    """The bundled cube's three noisy repeats: against the plain mean there is no floor; against the aligned one
    the floor is the repeats' scatter over three, far below the generic point's residuals."""
    from simtune.run_plan import plan_run

    objectives = {reference: plan_run(config(reference=reference)).objective({}) for reference in ("mean", "aligned")}
    assert pipeline.recordings_floor(objectives["mean"]) is None
    floor = pipeline.recordings_floor(objectives["aligned"])
    assert floor is not None and floor > 0
    space = objectives["aligned"].vector_space()
    generic = space.vector_within_bounds(pipeline.generic_values(objectives["aligned"], space.names))
    residuals = objectives["aligned"].residuals(space.to_dict(generic))
    assert not pipeline.at_noise_floor(residuals, floor)  # the generic cube: some 2e4 times its floor


def test_auto_stops_in_the_opening_where_synthetic_recordings_are_fitted_to_their_noise(tmp_path):
    """Synthetic `single` recordings (three repeats, 2 mm noise, no start jitter): the opening's least squares
    fits the true delay to the noise, and the run stops there, without a global round."""
    from simtune.studies.synth import make_synthetic

    make_synthetic("mujoco", "single", tmp_path / "data", truth={"command_delay": 0.4}, repeats=3, jitter_s=0.0)
    run = config(tasks="single", data=str(tmp_path / "data"), only=["command_delay"], max_evaluations=None)
    result = start_run(run, tmp_path / "run", show_progress=False)
    assert result.stop_reason == "converged" and result.converged
    assert result.message.startswith("converged: at the recordings' noise floor") and "in the opening" in result.message
    assert abs(result.params["command_delay"] - 0.4) < 0.005


def test_auto_without_a_budget_stops_when_converged_and_says_so(tmp_path):
    """No budget but the default generations: the rounds stop on their own, long before them; the stop reason is
    in the result, the store and the record."""
    from simtune.runs import read_run_record

    result = start_run(config(only=["command_delay"], max_evaluations=None), tmp_path / "run", show_progress=False)
    assert result.stop_reason == "converged" and result.message.startswith("converged")
    assert result.converged and result.generations < 1000
    record = read_run_record(tmp_path / "run")
    assert record.stop_reason == "converged" and record.converged
    # the verdict after it: the reference's floor (3 noisy repeats) and the delay, far from its generic 0 s
    verdict = record.verdict
    assert verdict is not None and 0 < verdict["floor"] < result.fitness
    assert verdict["over_floor"] == pytest.approx(result.fitness / verdict["floor"])
    assert [m["name"] for m in verdict["moved"]] == ["command_delay"] and verdict["moved"][0]["generic"] == 0.0
    # the seconds inside its batches, kept for the coordinator's share (benchmarks/auto_workers.py): some, not more
    # than the search's elapsed time
    store = RunStore.open_read_only(tmp_path / "run")
    simulating, elapsed = store.get("session_simulating_s"), store.get("elapsed_s")
    store.close()
    assert 0 < simulating <= elapsed


def test_a_batch_that_would_run_past_max_seconds_is_not_started(tmp_path):
    """`--max-seconds` is checked before a batch as well, at the session's pace: the command ends near its cap,
    not a batch's length after it (issue 44). The first batch always runs (no pace yet); the one after it is
    refused once the cap cannot hold it, and the search says so with the max-seconds code."""
    from simtune.optimize.base import BatchSearch, BudgetSpent
    from simtune.optimize.evaluator import TuneSettings
    from simtune.run_plan import plan_run

    objective = plan_run(config()).objective()
    store = RunStore(tmp_path / "run", create=True)
    search = BatchSearch(objective, store, TuneSettings(max_seconds=3600.0), deadline=True)
    points = search.from_unit(np.array([[0.2, 0.5, 0.5], [0.3, 0.5, 0.5], [0.4, 0.5, 0.5]]))
    with search:
        search.evaluate(points[:2])  # the first batch: no pace yet, always simulated
        assert search.evaluator.simulated_jobs == 2 and search.evaluator.simulated_seconds > 0
        pace = search.evaluator.simulated_seconds / 2
        search.evaluate(points[:2])  # served by the store: nothing to simulate, nothing to judge
        search.settings.max_seconds = search.elapsed() + 0.5 * pace  # one more rollout would run past the cap
        with pytest.raises(BudgetSpent):
            search.evaluate(points[2:])
    store.close()
    assert search.stop_code == "max-seconds" and "would have run past" in (search.stop_reason or "")
    assert search.evaluator.simulated_jobs == 2  # the refused batch simulated nothing


def test_the_search_starts_a_joints_gain_at_the_tasks_kp():
    """The opening starts at the generic point (docs/tuning.md): each joint's gain at the task's kp (it started at
    the bottom of its range, 1 /s, before 2026-11-27), the clamp at the task's, delay and marker offset at 0."""
    from simtune.objective import Objective, generic_values, load_references
    from simtune.tasks import parse_tasks

    tasks = parse_tasks("cube")
    objective = Objective("mujoco", tasks, load_references(REFERENCE_DIR, tasks))
    try:
        names = ["kp_joint_2", "kp_joint_6", "max_velocity_joint_2", "marker_offset_x", "command_delay"]
        generic = generic_values(objective, names)
    finally:
        objective.close()
    assert generic["kp_joint_2"] == generic["kp_joint_6"] == tasks[0].kp
    assert generic["max_velocity_joint_2"] == tasks[0].max_velocity_deg
    assert generic["marker_offset_x"] == generic["command_delay"] == 0.0
    # the report's and the exporters' generic values (the domain-randomisation ranges' nominal) say the same
    from simtune.report.simulate import nominal_values

    nominal = nominal_values("mujoco", tasks)
    assert {name: nominal[name] for name in names} == generic


def test_a_global_phase_scores_the_population_it_starts_from_once(tmp_path):
    """SciPy's differential evolution scales an `init` population into its unit cube and back before scoring it,
    moving each coordinate by a rounding error: a round's starting population (scored already: the last round's,
    the opening's best) was simulated again, member by member, as new points (issue 44). Now its first batch is
    served by the store and the population the phase returns holds the points themselves, not their copies."""
    from simtune.optimize.base import BatchSearch
    from simtune.optimize.evaluator import TuneSettings
    from simtune.run_plan import plan_run

    objective = plan_run(config()).objective()
    store = RunStore(tmp_path / "run", create=True)
    search = BatchSearch(objective, store, TuneSettings(), prune=True)
    population = search.from_unit(pipeline.opening_population(np.array([0.3, 0.6, 0.7]), seed=4))
    middle, width = 0.5 * (search.lows + search.highs), search.highs - search.lows
    scipy_copy = middle + ((population - middle) / width + 0.5 - 0.5) * width  # SciPy's scaling, there and back
    assert not np.array_equal(scipy_copy, population)  # rounding moved some member: the case this guards
    with search:
        search.evaluate(population)
        simulated = search.evaluator.simulated_jobs
        last, _ = pipeline._global_phase(search, population, seed=7)
        trials = search.evaluator.simulated_jobs - simulated
    store.close()
    # 2 generations of 5 trials were simulated; the 5 members it started from were not, not even as copies
    assert trials <= pipeline.GLOBAL_GENERATIONS * len(population)
    kept = [row for row in last if any(np.array_equal(row, member) for member in population)]
    near = [row for row in last if (np.abs(population - row) <= 1e-9).all(axis=1).any()]
    assert len(kept) == len(near) >= 1  # every member it kept is the point given, bit for bit
    tolerance = np.full(3, 1e-12)
    np.testing.assert_array_equal(pipeline.as_originals(scipy_copy, population, tolerance), population)
