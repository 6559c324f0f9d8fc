"""Uncertainty at the optimum: Gauss-Newton intervals, identifiability, the command and what a run stores."""

import json
import shutil
import subprocess
import sys

import numpy as np
import pytest
from scipy.signal import lfilter

from simtune.params import get_space
from simtune.reference import REFERENCE_DIR
from simtune.runs import RunConfig, start_run
from simtune.store import RunStore
from simtune.uncertainty import RCOND, Z95, Jacobian, analyse, correlation_time

CONTRACT = {"name", "value", "low", "high", "active", "identifiable"}


def test_gauss_newton_interval_matches_the_linear_model():
    """On a linear model the interval is the textbook one: s^2 (J^T J)^-1, in each parameter's units."""
    space = get_space("extended", only=["command_delay", "marker_offset_x", "marker_offset_y"])
    width = np.array([p.high - p.low for p in space.parameters])
    rng = np.random.default_rng(1)
    m = 200
    J = rng.normal(size=(m, 3))
    J[:, 2] = 0.0  # the third parameter moves nothing: unidentifiable
    r = rng.normal(scale=0.01, size=m)
    x = np.array([1.0, 0.01, -0.02])
    result = analyse(space, x, Jacobian(r, J, True))
    entries = {e["name"]: e for e in result["parameters"]}
    assert result["rank"] == 2 and result["residuals"] == m
    variance = r @ r / (m - 2)
    cov_unit = variance * np.linalg.inv(J[:, :2].T @ J[:, :2])
    for i, name in enumerate(["command_delay", "marker_offset_x"]):
        sd = np.sqrt(cov_unit[i, i]) * width[i]
        assert entries[name]["identifiable"] is True
        assert entries[name]["low"] == pytest.approx(x[i] - Z95 * sd)
        assert entries[name]["high"] == pytest.approx(x[i] + Z95 * sd)
    assert entries["marker_offset_y"]["identifiable"] is False
    assert entries["marker_offset_y"]["low"] is None and entries["marker_offset_y"]["high"] is None
    assert result["condition_number"] == pytest.approx(np.linalg.cond(J[:, :2]))
    assert set(entries["command_delay"]) == CONTRACT


def test_an_interval_past_a_range_is_cut_there_and_says_so():
    """Probe 5 #3, #26: a time step's interval reached below 0, dampings' below zero; a value no arm can have."""
    space = get_space("extended", only=["timestep", "command_delay"])
    rng = np.random.default_rng(3)
    m = 200
    J = rng.normal(size=(m, 2))
    J[:, 0] *= 0.05  # the time step barely moves the residuals: a wide interval about a value near its lower bound
    r = rng.normal(scale=0.01, size=m)
    result = analyse(space, np.array([0.0015, 1.0]), Jacobian(r, J, True))
    step = {e["name"]: e for e in result["parameters"]}["timestep"]
    assert step["identifiable"] and step["low"] == 0.001 and step["cut"] == ["low"] and step["high"] < 0.05
    delay = {e["name"]: e for e in result["parameters"]}["command_delay"]
    assert "cut" not in delay and set(delay) == CONTRACT  # the contract's fields, and `cut` only where cut
    from simtune.cli.output import _cut

    assert _cut(step) == " (cut at its range's lower end)" and _cut(delay) == ""


def test_fewer_than_ten_bootstrap_draws_are_refused(short_run):
    from simtune import api
    from simtune.errors import SimtuneError

    with pytest.raises(SimtuneError, match="a 95 % interval needs 10 draws or more"):
        api.uncertainty(short_run, bootstrap=2)


def test_a_barely_moving_direction_is_cut_off_and_correlation_is_reported():
    space = get_space("extended", only=["command_delay", "marker_offset_x"])
    rng = np.random.default_rng(2)
    a = rng.normal(size=300)
    J = np.stack([a, a + RCOND * 1e-3 * rng.normal(size=300)], axis=1)  # two columns that are one direction
    result = analyse(space, np.array([1.0, 0.0]), Jacobian(rng.normal(scale=1e-3, size=300), J, True))
    assert result["rank"] == 1
    assert not any(e["identifiable"] for e in result["parameters"])
    # nearly collinear but resolvable: identifiable and strongly correlated
    J2 = np.stack([a, a + 0.3 * rng.normal(size=300)], axis=1)
    result2 = analyse(space, np.array([1.0, 0.0]), Jacobian(rng.normal(scale=1e-4, size=300), J2, True))
    assert result2["rank"] == 2
    assert result2["correlated_pairs"][0]["correlation"] < -0.9


def test_an_inactive_parameter_is_never_identifiable():
    space = get_space("extended", only=["command_delay"])
    J = np.ones((50, 1))
    result = analyse(space, np.array([1.0]), Jacobian(np.full(50, 1e-3), J, True), inactive={"command_delay": "x"})
    assert result["parameters"][0]["active"] is False and result["parameters"][0]["identifiable"] is False


@pytest.fixture(scope="module")
def short_run(tmp_path_factory):
    run = tmp_path_factory.mktemp("unc") / "run"
    only = ["command_delay", "marker_offset_x", "mass_cube_wood", "lateral_friction_plastic"]
    config = RunConfig(
        optimizer="de",
        engine="mujoco",
        tasks="cube",
        space="extended",
        data=str(REFERENCE_DIR),
        seed=1,
        max_generations=2,
        only=only,
    )
    start_run(config, run, show_progress=False)
    return run


def test_a_finished_run_stores_its_uncertainty_and_keeps_its_evaluations(short_run):
    store = RunStore(short_run)
    stored = store.get("uncertainty")
    evaluations = store.count_evaluations()
    store.close()
    names = [e["name"] for e in stored["parameters"]]
    assert names == ["mass_cube_wood", "lateral_friction_plastic", "command_delay", "marker_offset_x"]
    wood = stored["parameters"][0]
    assert wood["active"] is False  # named by --only: searched, yet it moves nothing on `cube`
    assert wood["identifiable"] is False and wood["low"] is None
    delay = next(e for e in stored["parameters"] if e["name"] == "command_delay")
    assert delay["identifiable"] is True and delay["low"] < delay["value"] < delay["high"]
    # the finite-difference rollouts went to a scratch store: the run's evaluations are as the search left them
    proc = subprocess.run(
        [sys.executable, "-m", "simtune.cli", "uncertainty", str(short_run), "--json"],
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert proc.returncode == 0, proc.stderr
    printed = json.loads(proc.stdout)
    assert [set(e) - {"cut"} for e in printed["parameters"]] == [CONTRACT] * 4
    assert [e["name"] for e in printed["parameters"]] == names
    store = RunStore(short_run)
    assert store.count_evaluations() == evaluations
    store.close()


@pytest.mark.slow
def test_the_bootstrap_refits_a_run_and_stores_what_it_says(short_run, tmp_path):
    """`simtune uncertainty RUN --bootstrap N` (end to end, on a copy of a run; 10, the fewest it takes): N refits,
    the same contract per parameter, the summary stored in the run, its evaluations untouched."""
    run = tmp_path / "run"
    shutil.copytree(short_run, run)
    evaluations = RunStore(run).count_evaluations()
    proc = subprocess.run(
        [sys.executable, "-m", "simtune.cli", "uncertainty", str(run), "--bootstrap", "10", "--workers", "2", "--json"],
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert proc.returncode == 0, proc.stderr
    printed = json.loads(proc.stdout)
    assert printed["bootstrap_draws"] == 10 and [set(e) - {"cut"} for e in printed["parameters"]] == [CONTRACT] * 4
    store = RunStore(run)
    assert store.get("uncertainty") == printed
    assert store.count_evaluations() == evaluations
    store.close()


def test_uncertainty_of_a_folder_without_a_run_is_one_clear_line(tmp_path):
    proc = subprocess.run(
        [sys.executable, "-m", "simtune.cli", "uncertainty", str(tmp_path)], capture_output=True, text=True, timeout=60
    )
    assert proc.returncode == 2 and proc.stderr.startswith("error:") and "not a run folder" in proc.stderr


def test_correlation_time_of_white_and_of_smooth_series():
    rng = np.random.default_rng(3)
    white = rng.normal(size=(4000, 3))
    assert correlation_time([white]) == pytest.approx(1.0, abs=0.3)
    # AR(1) with phi = 0.9, four series pooled: (1 + phi) / (1 - phi) = 19
    series = [lfilter([1.0], [1.0, -0.9], rng.normal(size=20000))[:, None] for _ in range(4)]
    assert correlation_time(series) == pytest.approx(19.0, rel=0.15)


def test_a_kinked_parameter_is_not_identifiable():
    """Forward and backward differences that disagree (a jump, as the time step makes) leave a parameter unpinned."""
    space = get_space("extended", only=["command_delay", "marker_offset_x"])
    rng = np.random.default_rng(4)
    J = rng.normal(size=(100, 2))
    jac = Jacobian(rng.normal(scale=1e-3, size=100), J, True, np.array([True, False]))
    result = analyse(space, np.array([1.0, 0.0]), jac)
    assert [e["identifiable"] for e in result["parameters"]] == [False, True]
    assert result["non_smooth"] == ["command_delay"]


def test_bootstrap_refits_give_a_kinked_parameter_its_interval_and_widen_a_smooth_one():
    """The refits' scatter is a kinked parameter's standard deviation (Gauss-Newton has none there) and the least a
    smooth one's; one that scatters over more than its range stays unbounded."""
    space = get_space("extended", only=["command_delay", "marker_offset_x", "marker_offset_y"])
    width = np.array([p.high - p.low for p in space.parameters])
    rng = np.random.default_rng(4)
    J = rng.normal(size=(100, 3))
    jac = Jacobian(rng.normal(scale=1e-3, size=100), J, True, np.array([True, False, False]))
    x = np.array([1.0, 0.0, 0.0])
    plain = {e["name"]: e for e in analyse(space, x, jac)["parameters"]}
    wide_sd = 0.3 * width[2]  # 2 x 1.96 x 0.3 ranges: wider than the range
    refits = x + rng.normal(size=(40, 3)) * np.array([0.01 * width[0], 0.02 * width[1], wide_sd])
    result = analyse(space, x, jac, refits=refits)
    entries = {e["name"]: e for e in result["parameters"]}
    drawn = np.std(refits, axis=0, ddof=1)
    assert plain["command_delay"]["identifiable"] is False
    assert entries["command_delay"]["identifiable"] is True
    assert entries["command_delay"]["high"] == pytest.approx(x[0] + Z95 * drawn[0])
    gauss_newton = (plain["marker_offset_x"]["high"] - x[1]) / Z95
    assert drawn[1] > gauss_newton  # the draws scatter more than Gauss-Newton allows: theirs
    assert entries["marker_offset_x"]["high"] == pytest.approx(x[1] + Z95 * drawn[1])
    assert entries["marker_offset_y"]["identifiable"] is False
    assert result["bootstrap_draws"] == 40 and "bootstrap draws" in result["method"]


def test_a_draw_of_repeats_is_the_reference_those_repeats_build_on_their_own_median_clock():
    """Every repeat drawn once is the reference itself; a draw's mean is its repeats' mean, read on the clock its
    own median shift puts it on (the aligned reference's origin)."""
    from simtune.data.clock import ClockAlignment
    from simtune.data.task import TaskData

    times = np.arange(101) / 20.0
    ramp = np.stack([times, 2 * times, np.zeros_like(times)], axis=1)
    wrists = np.stack([ramp + k for k in range(5)])  # repeat k: the ramp plus k metres
    shifts = np.array([-0.1, -0.05, 0.0, 0.05, 0.1])
    data = TaskData(
        task="t",
        rate=20.0,
        times=times,
        wrist_mean=wrists.mean(axis=0),
        wrist_repeats=wrists,
        object_final=np.arange(15.0).reshape(5, 3),
        object_start=None,
        sources=[f"r{k}" for k in range(5)],
        reference="aligned",
        alignment=ClockAlignment([1.0] * 5, shifts, 3),
    )
    same = data.resampled(np.arange(5))
    np.testing.assert_array_equal(same.wrist_mean, data.wrist_mean)
    np.testing.assert_array_equal(same.object_final_mean, data.object_final_mean)
    draw = data.resampled(np.array([3, 4, 4, 3, 4]))  # median shift 0.1 s: read 0.1 s later
    expected = ramp + (3 + 4 + 4 + 3 + 4) / 5
    later = np.stack([np.interp(times + 0.1, times, expected[:, a]) for a in range(3)], axis=1)
    np.testing.assert_allclose(draw.wrist_mean, later)
    np.testing.assert_allclose(draw.object_final_mean, np.arange(15.0).reshape(5, 3)[[3, 4, 4, 3, 4]].mean(axis=0))
    assert np.median(draw.alignment.shifts) == pytest.approx(0.0)
    assert draw.sources == ["r3", "r4", "r4", "r3", "r4"]


def test_refits_that_never_move_a_kinked_parameter_leave_it_unbounded():
    space = get_space("extended", only=["command_delay", "marker_offset_x"])
    rng = np.random.default_rng(5)
    jac = Jacobian(rng.normal(scale=1e-3, size=100), rng.normal(size=(100, 2)), True, np.array([True, False]))
    refits = np.tile([1.0, 0.0], (10, 1))  # stuck where they started
    entries = analyse(space, np.array([1.0, 0.0]), jac, refits=refits)["parameters"]
    assert [e["identifiable"] for e in entries] == [False, True]


def test_the_bootstrap_needs_two_repeats_of_every_task():
    from simtune.errors import ConfigError
    from simtune.objective import Objective, load_references
    from simtune.tasks import get_task
    from simtune.uncertainty import bootstrap_refits

    task = get_task("cube")
    reference = load_references(REFERENCE_DIR, [task], reference="aligned")["cube"]
    space = get_space("extended", only=["command_delay"])
    objective = Objective("mujoco", [task], {"cube": reference.resampled(np.array([0]))}, space)
    with pytest.raises(ConfigError, match="task 'cube' has 1"):
        bootstrap_refits(objective, np.array([1.0]), 3)


def test_a_bad_bootstrap_count_is_refused_in_one_line(short_run):
    from simtune import api
    from simtune.errors import ConfigError

    for bad in (-1, 2.5, True, 10**6):
        with pytest.raises(ConfigError, match="bootstrap"):
            api.uncertainty(short_run, bootstrap=bad)


def test_the_run_stores_points_give_the_summary_a_scratch_store_gives(short_run, tmp_path):
    # the best point, with residuals in the run's store (as a least-squares phase leaves it), is read there, not
    # simulated again: the summary stays the one of all 2D + 1 rollouts simulated anew, to the last digit
    # (rollouts are deterministic)
    from simtune.optimize.evaluator import Evaluator
    from simtune.run_plan import plan_run
    from simtune.uncertainty import _stored, uncertainty

    run = tmp_path / "run"
    shutil.copytree(short_run, run)
    store = RunStore(run)
    try:
        config = RunConfig.from_stored(store.get("config"), str(run / "run.sqlite"))
        plan = plan_run(config)
        inactive = store.get("inactive_parameters") or {}
        objective = plan.objective(inactive)
        best = np.asarray(store.best_evaluation()["x"])
        assert _stored(store, [best])[0] is None  # differential evolution keeps no residuals
        anew = uncertainty(objective, best, plan.full_space, inactive, known=store)
        with Evaluator(objective, store, prune=False) as evaluator:
            evaluator.residuals([best])
        assert _stored(store, [best])[0] is not None
        read = uncertainty(objective, best, plan.full_space, inactive, known=store)
    finally:
        store.close()
    assert read == anew


def test_student_quantile_is_scipy_stats_own_to_the_last_digit():
    # the intervals take Student's t from scipy.special (scipy.stats is slow to import): the very numbers
    from scipy.special import stdtrit
    from scipy.stats import t

    assert all(float(stdtrit(df, 0.975)) == float(t.ppf(0.975, df)) for df in range(1, 60))


def test_a_held_delay_carries_the_clock_origin_into_every_parameter():
    """With no command delay searched, an error of the aligned clock's origin moves the other parameters: each one's
    variance gains (its pull by the clock's column x its range)^2 x the origin's variance."""
    from simtune.uncertainty import RepeatSpread

    space = get_space("extended", only=["marker_offset_x", "marker_offset_y"])
    width = np.array([p.high - p.low for p in space.parameters])
    rng = np.random.default_rng(5)
    m = 300
    J = rng.normal(size=(m, 2))
    r = rng.normal(scale=1e-3, size=m)
    x = np.array([0.0, 0.01])
    plain = analyse(space, x, Jacobian(r, J, True), spread=RepeatSpread([None], [m], {}))
    column, variance = 3.0 * J[:, 0], 1e-4  # the clock moves the residuals as 3 units of the first parameter
    held = analyse(space, x, Jacobian(r, J, True), spread=RepeatSpread([None], [m], {}, [(column, variance)]))
    before = [(e["high"] - e["low"]) / (2 * Z95) for e in plain["parameters"]]
    after = [(e["high"] - e["low"]) / (2 * Z95) for e in held["parameters"]]
    assert after[0] == pytest.approx(np.sqrt(before[0] ** 2 + (3.0 * width[0]) ** 2 * variance))
    assert after[1] == pytest.approx(before[1])


def test_the_clock_column_is_the_references_velocity_in_residual_units():
    """A wrist recorded moving at 0.1 m/s along x: a reference read later by dt moves every residual of x by
    0.1 dt / sqrt(samples) (the wrist part's units), the held first sample by half of it, y and z not at all."""
    from simtune.data.task import TaskData
    from simtune.objective import Objective
    from simtune.tasks import get_task

    times = np.arange(60) / 20.0
    wrist = np.zeros((60, 3))
    wrist[:, 0] = 0.2 + 0.1 * times
    data = TaskData("single", 20.0, times, wrist, wrist[None], None, None, [])
    (column,) = Objective("mujoco", [get_task("single")], {"single": data}).clock_columns()
    per_sample = column.reshape(60, 3)
    np.testing.assert_allclose(per_sample[1:-1, 0], 0.1 / np.sqrt(60), rtol=1e-9)
    assert per_sample[0, 0] == pytest.approx(0.05 / np.sqrt(60)) and not per_sample[:, 1:].any()
