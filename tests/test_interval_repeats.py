"""Intervals that hold the truth (issue 44, item 5): the repeats' own scatter and the aligned clock's origin widen
Gauss-Newton's intervals where the white-noise picture makes them too narrow."""

from __future__ import annotations

import math

import numpy as np
import pytest

from simtune.reference import REFERENCE_DIR
from simtune.run_plan import RunConfig, plan_run
from simtune.uncertainty import MEDIAN_EFFICIENCY, RepeatSpread, directions, repeat_covariance, repeat_spread


@pytest.fixture(scope="module")
def objective():
    config = RunConfig(
        optimizer="de",
        engine="mujoco",
        tasks="cube",
        space="extended",
        data=str(REFERENCE_DIR),
        only=["command_delay", "timestep"],
    )
    return plan_run(config).objective()


def test_each_repeats_deviation_is_in_the_residuals_units_and_they_average_to_nothing(objective):
    (rows,) = objective.repeat_deviations()
    reference = objective.references["cube"]
    assert rows is not None and rows.shape == (len(reference.sources), objective.residual_size)
    # the mean is the repeats' average: their deviations from it cancel
    assert np.abs(rows.mean(axis=0)).max() < 1e-12
    # a repeat's wrist deviation, in the residuals' units: its distance from the mean, divided by the wrist noise
    # (the residuals weigh by noise) and sqrt(samples)
    n, noise = len(reference.times), objective.noise["cube"].wrist_m
    wrist = (reference.wrist_repeats[0] - reference.wrist_mean) / math.sqrt(n) * 1e-3 / noise
    np.testing.assert_allclose(rows[0, : 3 * n], wrist.ravel(), rtol=1e-12)


def test_the_repeats_covariance_is_the_spread_of_each_repeats_pull_on_the_fit():
    rng = np.random.default_rng(3)
    J = rng.normal(size=(40, 2))
    rows = rng.normal(size=(6, 40))
    s, vt, keep, _ = directions(J)
    cov, repeats = repeat_covariance(J, RepeatSpread([rows], [40], {}), keep, s, vt)
    pull = np.linalg.pinv(J) @ rows.T  # each repeat's own least-squares answer
    assert repeats == 6
    np.testing.assert_allclose(cov, pull @ pull.T / (6 * 5), rtol=1e-10)
    # a task with one repeat says nothing
    assert repeat_covariance(J, RepeatSpread([None], [40], {}), keep, s, vt) == (None, 0)


def test_a_delay_against_the_aligned_reference_carries_its_clocks_origin_and_the_physics_step(objective):
    """The aligned clock's origin is the median of the repeats' shifts; the simulation starts each controller update
    on a whole physics step (MuJoCo's generic 2 ms): a delay is known no better than both allow."""
    spread = repeat_spread(objective)
    shifts = objective.references["cube"].alignment.shifts
    i = objective.vector_space().names.index("command_delay")
    origin = (MEDIAN_EFFICIENCY * np.std(shifts, ddof=1)) ** 2 / len(shifts)
    assert origin > 0 and spread.clock == {i: pytest.approx(origin + 0.002**2 / 12)}
    assert repeat_spread(objective, x_timestep=0.01).clock[i] == pytest.approx(origin + 0.01**2 / 12)
