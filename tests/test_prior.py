"""A prior on the tuned parameters (``--prior``, issue 67 item 3): each parameter's distance from its generic value,
over its kind's width, costs the fit, so that a task cannot bend what it barely sees; the data's fit stays what is
reported."""

import json

import numpy as np
import pytest

from simtune import api
from simtune.errors import ConfigError
from simtune.params.kinds import BY_NAME, PRIOR_WIDTHS, prior_width
from simtune.reference import REFERENCE_DIR
from simtune.run_plan import RunConfig, plan_run
from simtune.runs import start_run

#: a few parameters of the shipped `cube`'s space, the time step among them
ONLY = ["timestep", "mass_link_3", "joint_damping_2", "command_delay"]


def cube_objective(prior: float | None):
    config = RunConfig(engine="mujoco", tasks="cube", data=str(REFERENCE_DIR), only=ONLY, prior=prior)
    return plan_run(config).objective(inactive={})


def test_every_kind_has_one_width_rule_and_a_width_is_never_zero():
    assert set(PRIOR_WIDTHS) == set(BY_NAME)
    assert prior_width("mass_link_2", 0.6, 1.1, 0.86) == pytest.approx(0.2 * 0.86)  # +-20 % of the described mass
    assert prior_width("joint_damping_5", 0.0001, 0.9, 0.0) == pytest.approx(0.25 * 0.8999)  # a share of the range
    assert prior_width("servo_gain_joint_1", 5.0, 100.0, 0.0) == pytest.approx(0.5 * 95.0)  # generic 0: the range
    assert prior_width("command_delay_cube", 0.0, 3.0, 0.0) is None  # a recording's clock: no prior


def test_the_prior_adds_one_residual_per_parameter_and_its_penalty_to_the_fitness_only():
    plain, held = cube_objective(None), cube_objective(1.0)
    strong = cube_objective(4.0)
    try:
        names = held.prior.names
        assert names == ["timestep", "mass_link_3", "joint_damping_2"]  # the delay is the recording's clock
        assert held.residual_size == plain.residual_size + 3
        floor_fitness, floor_squares = held.prior_floor
        assert 0 < floor_fitness < 0.02 and floor_squares > 0  # the shipped cube's noise floor
        width = held.prior.widths["mass_link_3"]
        params = {"command_delay": 1.0, "mass_link_3": held.prior.centres["mass_link_3"] + width}
        residuals, score = held.residuals_and_score(params)
        data_residuals, data_score = plain.residuals_and_score(params)
        # the data's rows and fit are the plain objective's exactly; the prior's rows follow
        np.testing.assert_array_equal(residuals[: plain.residual_size], data_residuals)
        np.testing.assert_allclose(residuals[plain.residual_size :], [0.0, np.sqrt(floor_squares), 0.0], rtol=1e-12)
        assert score.data_fitness == data_score.fitness
        assert [t.fitness for t in score.tasks] == [t.fitness for t in data_score.tasks]
        # one width off costs one noise floor, in the fitness as in the residuals' sum of squares
        assert score.prior_penalty == pytest.approx(floor_fitness, rel=1e-9)
        assert score.fitness == pytest.approx(data_score.fitness + floor_fitness, rel=1e-12)
        assert held.score(params).fitness == score.fitness  # the scalar the optimisers minimise, the same
        # strength 4: the rows twice as long, the penalty four times
        rows = strong.residuals(params)[plain.residual_size :]
        np.testing.assert_allclose(rows, [0.0, 2 * np.sqrt(floor_squares), 0.0], rtol=1e-12)
        assert strong.score(params).prior_penalty == pytest.approx(4 * floor_fitness, rel=1e-9)
    finally:
        for objective in (plain, held, strong):
            objective.close()


def test_a_trial_pruned_with_a_prior_still_exceeds_its_bound_and_its_penalty_alone_prunes_at_once():
    objective = cube_objective(1.0)
    try:
        params = {"command_delay": 1.0, "timestep": 0.004}  # one width off: the penalty is one floor
        exact = objective.score(params)
        assert exact.prior_penalty > 0 and not exact.pruned
        bound = exact.prior_penalty + exact.data_fitness / 4
        bounded = objective.score(params, bound=bound)
        assert bounded.pruned and bound < bounded.fitness <= exact.fitness
        assert sum(t.steps for t in bounded.tasks) < sum(t.steps for t in exact.tasks)
        assert objective.score(params, bound=exact.fitness * 2).fitness == exact.fitness
        # a bound below the penalty alone: no trial there can beat its parent, and almost nothing is simulated
        at_once = objective.score(params, bound=exact.prior_penalty / 2)
        assert at_once.pruned and at_once.fitness > exact.prior_penalty / 2
        assert sum(t.steps for t in at_once.tasks) < sum(t.steps for t in exact.tasks) / 10
    finally:
        objective.close()


def run_config(**settings) -> RunConfig:
    base = dict(
        engine="mujoco",
        tasks="cube",
        space="extended",
        data=str(REFERENCE_DIR),
        seed=3,
        only=ONLY,
        optimizer="de",
        keep_inactive=True,
    )
    return RunConfig(**{**base, "max_evaluations": 12, **settings})


@pytest.mark.slow  # the default tier's 4 minutes
def test_a_prior_of_0_is_a_plain_run_to_the_last_digit(tmp_path):
    plain = start_run(run_config(), tmp_path / "plain", show_progress=False)
    zero = start_run(run_config(prior=0.0), tmp_path / "zero", show_progress=False)
    assert zero.fitness == plain.fitness and zero.evaluations == plain.evaluations
    np.testing.assert_array_equal(zero.x, plain.x)
    best = json.loads((tmp_path / "zero" / "best_params.json").read_text())
    assert best["fitness"] == plain.fitness and "prior_penalty" not in best


def test_a_strong_prior_holds_what_single_barely_sees_and_reports_the_datas_fit(mocap_root, tmp_path):
    """Real `single` barely sees the physics time step (a width of 2 ms changes its fit by a fraction of its noise
    floor): a plain search of a few dozen evaluations takes it ten times the generic, a strong prior keeps it."""
    settings = dict(
        tasks="single",
        data=str(mocap_root),
        space="calibrated",
        seed=0,
        only=["command_delay", "timestep", "mass_link_3"],
        max_evaluations=40,
        max_generations=1000,
    )
    plain = start_run(run_config(**settings), tmp_path / "plain", show_progress=False)
    held = start_run(run_config(**settings, prior=100.0), tmp_path / "held", show_progress=False)
    assert plain.params["timestep"] > 0.01  # five widths and more off the generic 2 ms
    assert abs(held.params["timestep"] - 0.002) < 0.002  # within one width
    # the data's fit is what is written and what evaluate reproduces; the prior's part beside it
    best = json.loads((tmp_path / "held" / "best_params.json").read_text())
    assert best["fitness"] == held.score.data_fitness and best["prior"] == 100.0
    assert best["prior_penalty"] == pytest.approx(held.score.fitness - held.score.data_fitness)
    assert best["prior_penalty"] > 0
    evaluated = api.evaluate("mujoco", "single", data=mocap_root, params=tmp_path / "held" / "best_params.json")
    assert evaluated.fitness == pytest.approx(best["fitness"], abs=1e-12) and evaluated.prior_penalty == 0.0
    read_back = api.read_run(tmp_path / "held")
    assert read_back.fitness == best["fitness"] and read_back.prior_penalty == pytest.approx(best["prior_penalty"])


def test_a_prior_is_checked_refused_with_paper_exact_and_absent_from_older_stores():
    for bad in (-1.0, float("nan"), "1", True):
        with pytest.raises(ConfigError, match="prior must be a finite number of at least 0"):
            RunConfig(prior=bad).check()
    with pytest.raises(ConfigError, match="--paper-exact minimises the paper's fitness alone: drop --prior 1"):
        RunConfig(paper_exact=True, workers=1, prior=1.0).check()
    RunConfig(paper_exact=True, workers=1, prior=0.0).check()  # 0 is no prior
    assert "prior" not in RunConfig().record()
    assert RunConfig(prior=0.5).record()["prior"] == 0.5
    stored = RunConfig().record()
    assert RunConfig.from_stored(stored, "run.sqlite").prior is None


@pytest.mark.slow  # two runs of `auto` on real `single`: about 10 s
def test_least_squares_with_a_strong_prior_holds_a_mass_single_barely_sees(mocap_root, tmp_path):
    """The residual vector's side: `auto`'s least squares moves link 3's mass, which `single` barely sees, by a third
    of a width to gain a trifle; the prior's rows keep it at the described 0.606 kg."""
    settings = dict(
        tasks="single",
        data=str(mocap_root),
        space="calibrated",
        seed=0,
        optimizer="auto",
        only=["command_delay", "mass_link_3", "joint_damping_2"],
        max_evaluations=40,
    )
    plain = start_run(run_config(**settings), tmp_path / "plain", show_progress=False)
    held = start_run(run_config(**settings, prior=100.0), tmp_path / "held", show_progress=False)
    assert abs(plain.params["mass_link_3"] - 0.606) > 0.02
    assert abs(held.params["mass_link_3"] - 0.606) < 0.005
