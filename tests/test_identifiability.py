"""`simtune check`'s identifiability section (issue 68, item 3): the parameter combinations given recordings cannot
tell apart, found from the noise-weighted Jacobian of the rollout residuals, and the motion that would separate
them; tune's start check names them by the same rule."""

from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np
import pytest

from simtune import api
from simtune.identifiability import SEPARATING, separating_motion
from simtune.optimize.start_check import weak_combinations

ROLL = """name = "roll"
description = "the wrist rolls out and back at the velocity clamp"
duration = 4
joints = ["joint_1", "joint_2", "joint_3", "joint_4", "joint_5", "joint_6"]
start_pose_deg = [0, 0, 0, 0, 0, 0]

[controller]
law = "clamped-p-velocity"
gain = 10
max_velocity_deg = 30

[mocap]
link = "link_6"
body = "hand"

[[phases]]
start = 0.5
targets_deg = [0, 0, 0, 0, 0, 50]

[[phases]]
start = 2.5
targets_deg = [0, 0, 0, 0, 0, 20]
"""
ROLL_TRUTH = {"command_delay": 0.0, "friction_joint_6": 1.0, "servo_gain_joint_6": 6.0}


def test_a_direction_that_scales_its_parameters_together_is_named_so_however_wide_their_ranges():
    """The SO-101 wrist roll's weakest direction in shares of the ranges is armature 0.92, friction 0.39, servo gain
    0.11 (its range is wide): every value scaled alike, which a share threshold alone would cut to two."""
    values = np.array([0.007, 0.6, 1.11, 0.4])  # armature, friction, servo gain, delay
    widths = np.array([0.01, 2.0, 13.6, 3.0])
    direction = np.append(values[:3] / widths[:3], 0.0)
    direction /= np.linalg.norm(direction)
    columns, _ = np.linalg.qr(np.random.default_rng(0).normal(size=(50, 4)))
    basis = np.linalg.qr(np.column_stack([direction, np.eye(4)[:, 1:]]))[0]  # the direction, then 3 orthogonal
    jacobian = columns @ np.diag([1.0, 0.5, 0.2, 1e-6]) @ basis[:, [1, 2, 3, 0]].T
    names = ["armature_joint_5", "friction_joint_5", "servo_gain_joint_5", "command_delay"]
    (weak,), _ = weak_combinations(names, jacobian, values, widths)
    assert weak.scaled_together and set(weak.parameters) == set(names[:3])
    assert weak.words().endswith("scaled together") and "command_delay" not in weak.words()
    # without the values the start check's share rule names the two largest components only
    (plain,), _ = weak_combinations(names, jacobian)
    assert set(plain.parameters) == {"armature_joint_5", "friction_joint_5"} and not plain.scaled_together


def test_the_motion_that_separates_a_servo_gain_from_its_armature_is_a_step_that_saturates_it():
    values = {"max_torque_joint_5": 10.0, "servo_gain_joint_5": 1.0, "kp_joint_5": 10.0, "max_velocity_joint_5": 720}
    text = separating_motion(["armature_joint_5", "friction_joint_5", "servo_gain_joint_5"], values)
    # the servo's torque reaches 10 N m at a commanded 573 deg/s, which the gain 10 /s commands from 57.3 deg away
    assert "saturate its servo" in text and "57.3 deg" in text and "573 deg/s" in text
    slow = separating_motion(["servo_gain_joint_5", "armature_joint_5"], {**values, "max_velocity_joint_5": 180.0})
    assert "raise the task's max_velocity_deg to at least that" in slow
    assert "differently against gravity" in separating_motion(["mass_link_3", "mass_link_2"], {})
    assert "different speed" in separating_motion(["command_delay", "max_velocity_joint_2"], {})
    assert all(1 <= len(key) <= 3 for key in SEPARATING)  # one table, keyed by the kinds (pairs, a triple)


@pytest.fixture(scope="module")
def roll(tmp_path_factory):
    """A MICO project whose task rolls the wrist at its velocity clamp, and recordings of a truth with friction."""
    root = tmp_path_factory.mktemp("roll")
    (root / "proj" / "tasks").mkdir(parents=True)
    (root / "proj" / "simtune.toml").write_text('robot = "mico"\ntasks = ["tasks/roll.toml"]\n')
    (root / "proj" / "tasks" / "roll.toml").write_text(ROLL)
    (root / "truth-input.json").write_text(json.dumps(ROLL_TRUTH))
    api.synth(
        "mujoco",
        "roll",
        project=root / "proj",
        out=root / "data",
        truth=root / "truth-input.json",
        repeats=2,
        fmt="csv",
    )
    return root


def test_check_names_what_a_roll_at_the_velocity_clamp_cannot_tell_apart_and_not_the_delay(roll):
    """At the clamp the wrist turns at its velocity limit less friction over the servo's gain: the limit and the gain
    trade; the delay (each move's start) is well told apart and not named."""
    result = api.check(
        "mujoco",
        "roll",
        project=roll / "proj",
        data=roll / "data",
        space="drivetrain",
        only="command_delay,friction_joint_6,servo_gain_joint_6,max_velocity_joint_6",
        params=roll / "data" / "truth.json",
    )
    section = result["identifiability"]
    assert section["point"].endswith("truth.json")
    named = [set(d["parameters"]) for d in section["directions"]]
    assert {"servo_gain_joint_6", "max_velocity_joint_6"} in named
    assert not any("command_delay" in group for group in named)
    (trade,) = [
        d for d in section["directions"] if set(d["parameters"]) == {"servo_gain_joint_6", "max_velocity_joint_6"}
    ]
    assert "up" in trade["combination"] and "down" in trade["combination"]  # one rises as the other falls
    assert trade["relative_sensitivity"] < 1e-2 and trade["interval_share"] > 1.0
    assert "below its velocity limit" in trade["separate_by"]


@pytest.mark.slow  # 45 s: the SO-101 project with the drive-train benchmark's drive task, its truth synthesised
def test_check_names_the_so101_wrist_rolls_drive_train_symmetry_on_the_benchmarks_drive_task(tmp_path):
    """The drive-train benchmark measured that the SO-101's wrist roll (joint 5) fits within 0.01 % with its armature,
    friction and servo gain scaled together by 0.8 or 1.25: the check finds that direction from the Jacobian alone."""
    sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))
    import drivetrain_recovery as bench

    (entry,) = [r for r in bench.CORPUS if r.name == bench.ROBOTS["so101"]]
    if entry.path is None:
        pytest.skip(f"{entry.package} is not installed")
    project = bench.make_project(tmp_path, "so101")
    truth = {**bench.truth(bench.ranges(project, "mujoco"), bench.task_servo_gains(project)), "command_delay": 0.4}
    (tmp_path / "truth.json").write_text(json.dumps(truth))
    api.synth(
        "mujoco", "drive", project=project, out=tmp_path / "data", truth=tmp_path / "truth.json", repeats=3, fmt="csv"
    )
    result = api.check(
        "mujoco",
        "drive",
        project=project,
        data=tmp_path / "data",
        only="armature_joint_5,friction_joint_5,servo_gain_joint_5,kp_joint_5,command_delay",
        params=tmp_path / "truth.json",
    )
    (weakest, *_) = result["identifiability"]["directions"]
    assert weakest["combination"] == "armature_joint_5, friction_joint_5 and servo_gain_joint_5 scaled together"
    assert weakest["scaled_together"] and "saturates its servo" in weakest["separate_by"]
    named = {name for d in result["identifiability"]["directions"] for name in d["parameters"]}
    assert "command_delay" not in named and "kp_joint_5" not in named
