"""The cheap warnings before a long search: a start on a bound the fit pushes against, a Jacobian that cannot
tell parameters apart (issue 44, item 6)."""

import warnings

import numpy as np
import pytest

from simtune.optimize import pipeline
from simtune.optimize.start_check import SearchWarning, pushed_past_bounds, warn_about_start, weak_directions
from simtune.reference import REFERENCE_DIR
from simtune.runs import RunConfig, start_run

NAMES = ["a", "b", "c", "d"]


def test_a_parameter_on_a_bound_is_named_only_where_the_fit_pushes_outwards():
    x, lows, highs = np.array([0.0, 1.0, 0.5, 0.0]), np.zeros(4), np.ones(4)
    # per cost: a wants to go down (on its lower bound), b wants to go up (on its upper), d leans inwards
    gradient = np.array([1.0, -1.0, 5.0, -1.0])
    assert pushed_past_bounds(NAMES, x, lows, highs, gradient) == ["a (lower bound 0)", "b (upper bound 1)"]
    # a push too small to matter (a 1 % step gains less than PUSH of the cost) is no concern
    assert pushed_past_bounds(NAMES, x, lows, highs, gradient * 1e-3) == []
    # equal bounds: nothing to search
    assert pushed_past_bounds(NAMES, x, np.ones(4), np.ones(4), gradient) == []


def test_weak_directions_name_flat_columns_and_the_parameters_of_the_weakest_direction():
    rng = np.random.default_rng(0)
    base = rng.normal(size=(60, 2))
    # columns: a, b independent; c = a + b almost exactly (a near-collinear triple); d moves nothing
    jac = np.column_stack(
        [base[:, 0], base[:, 1], base[:, 0] + base[:, 1] + 1e-7 * rng.normal(size=60), 0 * base[:, 0]]
    )
    flat, groups, condition = weak_directions(NAMES, jac)
    assert flat == ["d"]
    assert len(groups) == 1 and sorted(groups[0]) == ["a", "b", "c"]
    assert condition > 1e6
    # a well-conditioned Jacobian: nothing to say
    flat, groups, condition = weak_directions(NAMES[:2], base)
    assert flat == [] and groups == [] and condition < 10


def test_warn_about_start_warns_once_per_finding_and_says_what_to_do():
    jac = np.column_stack([np.ones(10), np.ones(10) * (1 + 1e-9), np.zeros(10), np.arange(10.0)])
    residuals = np.ones(10)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        texts = warn_about_start(NAMES, np.array([0.0, 0.5, 0.5, 0.5]), np.zeros(4), np.ones(4), jac, residuals)
    assert [w.category for w in caught] == [SearchWarning] * 3
    assert "a (lower bound 0)" in texts[0] and "widen the range" in texts[0]
    assert "c moves no residual" in texts[1] and "--only" in texts[1]
    assert "a up, b down" in texts[2] or "b up, a down" in texts[2]  # as `simtune check` names the combination


def test_a_fit_that_pushes_a_damping_below_zero_is_never_told_to_widen_the_range():
    """Probe 5 #7: negative damping is never physical; an encoder offset may go either way."""
    from simtune.params.kinds import never_negative

    assert never_negative("joint_damping_2") and never_negative("mass_cube_wood") and never_negative("timestep")
    assert not never_negative("joint_offset_3") and not never_negative("command_delay_cube")
    assert not never_negative("marker_offset_x") and not never_negative("no_such_kind")
    names = ["joint_damping_2", "command_delay"]
    jac = np.column_stack([np.ones(10), np.arange(10.0)])
    with pytest.warns(SearchWarning):
        texts = warn_about_start(names, np.array([0.0, 0.5]), np.zeros(2), np.ones(2), jac, np.ones(10))
    assert "pushes joint_damping_2 below 0, which no arm has: not a range to widen" in texts[0]
    assert not any("widen the range" in t for t in texts)


@pytest.fixture
def short_rounds(monkeypatch):
    monkeypatch.setattr(pipeline, "GLOBAL_GENERATIONS", 2)
    monkeypatch.setattr(pipeline, "LOCAL_NFEV", 3)


def test_auto_warns_about_its_start_before_the_global_rounds(tmp_path, short_rounds):
    """A parameter that moves nothing on `cube` (the wood cube's mass: its cube is plastic) is named from the
    opening's own Jacobian, with no extra rollout; a search stopped inside the opening says so."""
    config = RunConfig(
        engine="mujoco",
        tasks="cube",
        space="extended",
        data=str(REFERENCE_DIR),
        seed=1,
        only=["command_delay", "mass_cube_wood"],
        keep_inactive=True,
        optimizer="auto",
        max_evaluations=4,
    )
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        result = start_run(config, tmp_path / "run", show_progress=False)
    texts = [str(w.message) for w in caught if w.category is SearchWarning]
    assert any("mass_cube_wood moves no residual" in t for t in texts), texts
    assert "in the opening" in result.message and "least-squares step" in result.message
