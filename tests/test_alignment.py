"""Time alignment per recording: per-task command delays, their estimate, and evaluate aligning an unseen clock."""

import json
import math
import subprocess
import sys

import pytest
from scipy.optimize import minimize_scalar

from simtune import alignment
from simtune.alignment import TOLERANCE_S, estimate_delay
from simtune.engines.controller import JointController
from simtune.errors import ConfigError
from simtune.objective import Objective, load_references
from simtune.params import get_space, validate_params
from simtune.params.space import read_params_file
from simtune.reference import REFERENCE_DIR
from simtune.reference.make import TRUTH
from simtune.run_plan import plan_run
from simtune.runs import RunConfig
from simtune.tasks import get_task


def test_a_task_s_own_delay_comes_before_the_shared_one():
    cube = get_task("cube")
    assert JointController(cube, {"command_delay": 1.0, "command_delay_cube": 2.0}).delay == 2.0
    assert JointController(cube, {"command_delay": 1.0, "command_delay_single": 2.0}).delay == 1.0


def test_tasks_tuned_together_get_one_delay_each():
    space = get_space("extended", tasks=["single", "cube"])
    assert "command_delay" not in space.names
    at = space.names.index("command_delay_single")
    assert space.names[at : at + 2] == ["command_delay_single", "command_delay_cube"]
    assert get_space("extended", tasks=["cube"]).names == get_space("extended").names
    only = get_space("extended", None, ["command_delay"], tasks=["single", "cube"])
    assert only.names == ["command_delay_single", "command_delay_cube"]
    config = RunConfig(optimizer="de", engine="mujoco", tasks="single,cube", space="extended", data=str(REFERENCE_DIR))
    assert {"command_delay_single", "command_delay_cube"} <= set(plan_run(config).full_space.names)
    # a run stored before per-task delays shared one delay: resuming it keeps its parameter list
    stored = {"engine": "mujoco", "tasks": "single,cube", "space": "extended", "data": "x"}
    assert RunConfig.from_stored(stored, "old").task_delays is False


def test_per_task_delays_validate_like_the_shared_one(tmp_path):
    supported = frozenset({"command_delay"})
    assert validate_params({"command_delay_cube": 1.5}, supported, "mujoco") == {"command_delay_cube": 1.5}
    with pytest.raises(ConfigError, match="command_delay_cube"):
        validate_params({"command_delay_cube": 4.0}, supported, "mujoco")
    path = tmp_path / "p.json"
    path.write_text(json.dumps({"space": "extended", "params": {"command_delay_cube": 1.5, "command_delay_single": 1}}))
    assert read_params_file(path) == {"command_delay_cube": 1.5, "command_delay_single": 1}


@pytest.fixture(scope="module")
def cube_objective():
    task = get_task("cube")
    return task, Objective("mujoco", [task], load_references(REFERENCE_DIR, [task]))


def test_the_delay_of_a_recording_is_found_with_the_physics_fixed(cube_objective):
    """The shipped reference was simulated with a 1.4 s delay (+- 0.05 s jitter per repeat)."""
    task, objective = cube_objective
    physics = {k: v for k, v in TRUTH.items() if k != "command_delay"}
    estimate = estimate_delay(objective, task, physics, scan=False)  # auto's start-up: one bounded search
    assert estimate.recorded_onset_s is not None and estimate.simulated_onset_s is not None
    assert estimate.onset_delay_s == pytest.approx(1.4, abs=0.15)
    assert estimate.delay_s == pytest.approx(1.4, abs=0.05)
    assert estimate.fitness < estimate.fitness_unaligned
    assert estimate.fitness == pytest.approx(objective.score({**physics, "command_delay": estimate.delay_s}).fitness)


def test_the_scan_finds_the_deepest_of_narrow_valleys_one_bounded_search_misses():
    """A contact task's fitness over the delay: valleys 0.02 s wide, 0.1 s apart, the deepest not the nearest."""
    depths = {0.3: 0.45, 0.4: 0.45, 0.5: 0.45, 0.6: 0.45, 0.7: 0.45, 0.8: 0.7}

    def comb(delay: float) -> float:
        return 1.0 - sum(d * math.exp(-(((delay - at) / 0.01) ** 2)) for at, d in depths.items())

    one_search = minimize_scalar(comb, bounds=(0.2, 0.9), method="bounded", options={"xatol": TOLERANCE_S})
    assert comb(float(one_search.x)) > 0.4  # the premise: Brent's bounded search alone ends elsewhere
    delay, best = alignment._scanned(comb, 0.2, 0.9)
    assert delay == pytest.approx(0.8, abs=0.002)
    assert best == pytest.approx(comb(delay)) and best < 0.31


@pytest.mark.slow  # 25 s
def test_the_scanned_delay_is_never_worse_than_one_search_or_the_delay_the_parameters_carry(cube_objective):
    task, objective = cube_objective
    physics = {k: v for k, v in TRUTH.items() if k != "command_delay"}
    single = estimate_delay(objective, task, physics, scan=False)
    scanned = estimate_delay(objective, task, {**physics, "command_delay": 1.4})
    assert scanned.fitness <= single.fitness
    assert scanned.fitness <= scanned.fitness_unaligned
    assert scanned.delay_s == pytest.approx(1.4, abs=0.05)
    assert scanned.rollouts > 100  # the window's grid, every 10 ms
    assert scanned.fitness == pytest.approx(objective.score({**physics, "command_delay": scanned.delay_s}).fitness)


@pytest.mark.slow  # 30-50 s (two delay scans of cube)
def test_evaluate_aligns_a_clock_when_asked_and_says_so(tmp_path):
    physics = {k: v for k, v in TRUTH.items() if k != "command_delay"}
    path = tmp_path / "tuned.json"
    # tuned on another task: evaluate aligns cube's clock by default
    path.write_text(json.dumps({"engine": "mujoco", "tasks": "single", "params": physics}))
    base = [sys.executable, "-m", "simtune.cli", "evaluate", "--task", "cube", "-p", str(path)]
    proc = subprocess.run([*base, "--json"], capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stderr
    result = json.loads(proc.stdout)
    assert result["clock_aligned"]["cube"] == pytest.approx(1.4, abs=0.05)
    assert result["fitness"] < result["fitness_unaligned"]
    off = json.loads(subprocess.run([*base, "--json", "--no-align-clock"], capture_output=True, text=True).stdout)
    assert off["clock_aligned"] == {} and off["fitness"] == pytest.approx(result["fitness_unaligned"])
    text = subprocess.run(base, capture_output=True, text=True, env=None).stdout
    assert "clock aligned: cube's command delay" in " ".join(text.split())
