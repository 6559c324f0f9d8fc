"""The Python API (simtune.api): evaluate, tune and read_run give one Result, the CLI's numbers."""

import json
import subprocess
import sys

import pytest

import simtune.api as st
from simtune.errors import ConfigError, ProjectError


def test_evaluate_generic_and_given_parameters():
    generic = st.evaluate("mujoco", "cube")
    assert generic.x == {} and generic.fitness == generic.generic_fitness and generic.run_dir is None
    assert generic.tasks == ("cube",) and generic.parts["cube"].object_error is not None
    assert generic.fitness == pytest.approx(generic.wrist_error + generic.object_error)
    delayed = st.evaluate("mujoco", "cube", params={"command_delay": 1.5}, project=st.load_project())
    assert delayed.x == {"command_delay": 1.5} and delayed.generic_fitness == generic.fitness
    assert delayed.fitness != generic.fitness and delayed.evaluations == 2


def test_evaluate_is_the_commands_fitness():
    cli = subprocess.run(
        [sys.executable, "-m", "simtune.cli", "evaluate", "--engine", "mujoco", "--task", "cube", "--json"],
        capture_output=True,
        text=True,
    )
    assert cli.returncode == 0, cli.stderr
    assert json.loads(cli.stdout)["fitness"] == st.evaluate("mujoco", "cube").fitness


def test_bad_input_is_one_simtune_error():
    with pytest.raises(ConfigError, match="params: unknown parameter 'grip'"):
        st.evaluate("mujoco", "cube", params={"grip": 1.0})
    with pytest.raises(ConfigError, match="unknown task 'cubes'"):
        st.evaluate("mujoco", "cubes")
    with pytest.raises(ProjectError, match="no such folder"):
        st.load_project("/nonexistent/project")


def test_tune_and_read_run(tmp_path):
    out = tmp_path / "run"
    tuned = st.tune("mujoco", "cube", out=out, only=["command_delay"], max_evaluations=6, seed=1)
    assert tuned.run_dir == out and list(tuned.x) == ["command_delay"]
    assert tuned.fitness < tuned.generic_fitness and tuned.evaluations >= 6
    assert st.read_run(out) == tuned
    best = json.loads((out / "best_params.json").read_text())
    assert best["params"] == tuned.x and best["fitness"] == tuned.fitness
    # the tuned parameters, simulated again, score what the run stored
    assert st.evaluate("mujoco", "cube", params=out / "best_params.json").fitness == tuned.fitness


def test_tune_runs_in_calibrated_unless_paper_exact_or_told() -> None:
    assert st.run_config("mujoco", "cube").space == "calibrated"
    # the paper's 31 shared parameters: --paper-exact runs the paper's spaces only (it refused its own default before)
    assert st.run_config("mujoco", "cube", paper_exact=True).space == "shared"
    assert st.run_config("mujoco", "cube", space="shared").space == "shared"
