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


def test_a_joint_without_load_moves_alike_with_its_drive_train_scaled_together():
    """Why no recording pins a wrist roll's drive train (docs/parameters.md, "Clear of the floor"): below its force
    limit a velocity servo moves a joint by (link inertia + armature) / gain and friction / gain, so where the link's
    own inertia is small and gravity does not load the joint, the three scaled together give the same motion, while
    each scaled alone moves the joint by more than an encoder's noise (0.05 deg)."""
    import dataclasses

    from simtune.engines import make_engine
    from simtune.tasks import get_task
    from simtune.tasks.spec import Phase

    rest = (0.0,) * 6
    turns = (Phase(0.0, rest), Phase(0.5, (*rest[:5], 60.0)), Phase(3.0, (*rest[:5], -30.0)))
    engine = make_engine("mujoco", dataclasses.replace(get_task("single"), phases=turns))
    truth = {"armature_joint_6": 0.05, "friction_joint_6": 0.5, "servo_gain_joint_6": 2.0}

    def wrist_roll_deg(scales: dict[str, float]) -> np.ndarray:
        params = {name: value * scales.get(name, 1.0) for name, value in truth.items()}
        return np.degrees(engine.rollout(params, 121).joint_angles[:, 5])

    try:
        at_truth = wrist_roll_deg({})
        assert at_truth.max() > 30.0  # it turns
        for scale in (0.8, 1.25):
            together = wrist_roll_deg(dict.fromkeys(truth, scale))
            assert np.abs(together - at_truth).max() < 0.005
            for name in truth:
                assert np.abs(wrist_roll_deg({name: scale}) - at_truth).max() > 0.05, name
    finally:
        engine.close()
