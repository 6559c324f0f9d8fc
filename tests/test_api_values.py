"""The Python API refuses values that mean nothing with one ConfigError naming the argument (issue 50, item 10):
negative or string worker counts, worker counts past simtune.common.limits.MAX_WORKERS (10**6 used to fork until the
machine stalled), negative budgets and sample counts (sensitivity_evaluations(..., -5) returned -270), None
where a count is due."""

import pytest

import simtune.api as st
from simtune.common.limits import MAX_WORKERS
from simtune.errors import ConfigError


@pytest.mark.parametrize("workers", [0, -1, "2", 2.0, None, True, MAX_WORKERS + 1, 10**6])
def test_worker_counts_out_of_range_or_of_the_wrong_type_are_refused(workers, tmp_path):
    with pytest.raises(ConfigError, match=rf"workers must be an integer from 1 to {MAX_WORKERS}, got"):
        st.run_config("mujoco", "cube", workers=workers)
    with pytest.raises(ConfigError, match="workers must be an integer"):
        st.uncertainty(tmp_path, workers=workers)
    with pytest.raises(ConfigError, match="workers must be an integer"):
        st.demo(tmp_path / "demo", workers=workers)


@pytest.mark.parametrize(
    ("settings", "message"),
    [
        ({"max_evaluations": -5}, "max_evaluations must be an integer of at least 1"),
        ({"max_seconds": -1.0}, "max_seconds must be a finite number of seconds above 0"),
        ({"max_seconds": float("nan")}, "max_seconds must be a finite number"),
        ({"max_generations": 0}, "max_generations must be an integer of at least 1"),
        ({"seed": None}, "seed must be an integer"),
        ({"seed": -1}, "seed must be an integer"),
        ({"target_fitness": -0.1}, "target_fitness must be a finite number of at least 0"),
    ],
)
def test_budgets_that_mean_nothing_are_refused_before_anything_runs(settings, message):
    with pytest.raises(ConfigError, match=message):
        st.run_config("mujoco", "cube", **settings)


def test_sample_counts_seeds_and_budgets_of_the_studies_are_checked(tmp_path):
    with pytest.raises(ConfigError, match="samples must be an integer of at least 1, got -5"):
        st.sensitivity_evaluations("mujoco", "shared", "morris", -5)
    assert st.sensitivity_evaluations("mujoco", "shared", "morris", 2) > 0
    with pytest.raises(ConfigError, match="budget must be an integer of at least 1"):
        st.compare("mujoco", "cube", out=tmp_path / "c", budget=-3)
    with pytest.raises(ConfigError, match="seeds must be an integer of at least 1"):
        st.compare("mujoco", "cube", out=tmp_path / "c", seeds="3")
    with pytest.raises(ConfigError, match="max_seconds must be a finite number of seconds above 0"):
        st.demo(tmp_path / "demo", max_seconds=-3)
    assert not (tmp_path / "c").exists() and not (tmp_path / "demo").exists()


def test_only_parameters_that_change_no_rollout_are_refused_before_the_search(tmp_path):
    """`tune --only P` with P inactive used to run its whole budget, then blame --keep-inactive, a flag not given."""
    from simtune.errors import RecordingWarning
    from simtune.run_plan import plan_run

    config = st.run_config("mujoco", "cube", only="max_velocity_joint_1", max_seconds=30)
    with pytest.raises(ConfigError, match=r"--only: it changes no rollout of cube \(max_velocity_joint_1: task 'cube'"):
        st.start(config, tmp_path / "run")
    assert not (tmp_path / "run").exists()
    mixed = plan_run(st.run_config("mujoco", "cube", only="max_velocity_joint_1,command_delay"))
    with pytest.warns(RecordingWarning, match="max_velocity_joint_1 change"):
        assert mixed.search_space().names == ["max_velocity_joint_1", "command_delay"]
