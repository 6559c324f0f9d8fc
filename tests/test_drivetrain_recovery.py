"""Recovery of drive-train parameters on a short synthetic problem: ``synth`` with a truth that sets a joint's
Coulomb friction and controller gain, then ``tune --only`` them back in MuJoCo (benchmarks/drivetrain_recovery.py
measures the SO-101's and the Panda's every joint, in every engine)."""

from __future__ import annotations

import json

import numpy as np
import pytest

from simtune import api
from simtune.objective import Objective, load_references
from simtune.params import get_space
from simtune.tasks import parse_tasks

TASK = "single"  # the MICO's joint 2 to -100 deg at 30 deg/s, 6 s
TRUTH = {"command_delay": 0.0, "kp_joint_2": 4.0, "friction_joint_2": 3.0}
TUNED = ("kp_joint_2", "friction_joint_2")
SPACE = "drivetrain"  # the MICO's drive-train kinds are in this space only
WITHIN = 0.05  # of each range


@pytest.fixture(scope="module")
def recordings(tmp_path_factory):
    out = tmp_path_factory.mktemp("drive")
    truth = out / "truth-input.json"
    truth.write_text(json.dumps(TRUTH))
    api.synth("mujoco", TASK, out=out / "data", truth=truth, repeats=4, fmt="csv", noise_m=0.002, jitter_s=0.0)
    return out / "data"


def test_synth_with_a_drive_train_truth_differs_from_the_generic_recordings(recordings):
    written = json.loads((recordings / "truth.json").read_text())
    assert written.get("params", written)["kp_joint_2"] == 4.0
    tasks = parse_tasks(TASK)
    objective = Objective("mujoco", tasks, load_references(recordings, tasks))
    try:
        at_truth = objective.score(TRUTH).fitness
        generic_gain = objective.score({**TRUTH, "kp_joint_2": 10.0, "friction_joint_2": 0.0}).fitness
    finally:
        objective.close()
    assert generic_gain > 3 * at_truth  # the drive train shows in the recordings


def test_mujoco_recovers_a_joints_coulomb_friction_and_gain(recordings, tmp_path):
    only = list(TUNED)
    result = api.tune("mujoco", TASK, out=tmp_path / "run", data=recordings, space=SPACE, only=only, max_evaluations=60)
    ranges = {p.name: p.high - p.low for p in get_space(SPACE, only=only).parameters}
    for name in TUNED:
        value = TRUTH[name]
        error = abs(result.x[name] - value) / ranges[name]
        assert error < WITHIN, (name, result.x[name], value)
    assert np.isfinite(result.fitness)
