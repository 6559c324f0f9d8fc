"""`simtune check` and the motion onset it reports."""

import json
import subprocess
import sys

import numpy as np
import pytest

from simtune.check.task import rest_poses
from simtune.data import TaskData
from simtune.data.onset import ONSET_M, motion_onset
from simtune.reference import REFERENCE_DIR
from simtune.tasks import get_task


def _track(onset: float, glitch: bool = False) -> tuple[np.ndarray, np.ndarray]:
    times = np.arange(200) / 20.0
    track = np.zeros((200, 3)) + [0.3, 0.1, 0.4]
    track[:, 0] += np.where(times > onset, 0.05 * (times - onset), 0.0)  # 5 cm/s from the onset on
    track += np.random.default_rng(0).normal(scale=0.0005, size=track.shape)  # marker jitter
    if glitch:
        track[0, 2] += 2 * ONSET_M  # one stray first sample
    return times, track


@pytest.mark.parametrize("glitch", [False, True])
def test_onset_is_where_the_track_leaves_its_rest_position(glitch):
    times, track = _track(1.7, glitch)
    onset = motion_onset(times, track)
    # 5 mm at 5 cm/s: the threshold is crossed 0.1 s after the true onset
    assert onset == pytest.approx(1.7 + ONSET_M / 0.05, abs=0.03)


def test_a_track_that_never_moves_has_no_onset():
    times, track = _track(100.0)
    assert motion_onset(times, track) is None


def test_a_rest_pose_the_targets_do_not_reach_is_named():
    task = get_task("cube")  # phases from 0, 8 and 14 s to 20 s
    times = np.arange(401) / 20.0
    poses = np.array([[0.11, -0.01, 0.50], [0.40, 0.0, 0.25], [0.51, 0.0, 0.33]])
    simulated = poses[np.searchsorted([8.0, 14.0], times, side="right")]  # at rest at each phase's pose at once
    delay = 1.5
    recorded = poses[np.searchsorted([8.0 + delay, 14.0 + delay], times, side="right")]
    recorded[(times >= 8.0 + delay) & (times < 14.0 + delay)] += [-0.03, 0.0, -0.02]  # the real arm rested elsewhere
    reference = TaskData("cube", 20.0, times, recorded, None, None, None, [])
    rows = rest_poses(task, reference, (times, simulated), delay)
    assert [r["stretch"] for r in rows] == ["phase 1", "phase 2", "phase 3"]
    assert [r["end_s"] for r in rows] == [8.0, 14.0, 20.0]
    assert rows[0]["distance_m"] == pytest.approx(0.0, abs=1e-12) and not rows[0]["far"]
    assert rows[1]["distance_m"] == pytest.approx(np.hypot(0.03, 0.02)) and rows[1]["far"]
    np.testing.assert_allclose(rows[1]["recorded_m"], poses[1] + [-0.03, 0.0, -0.02])
    # the last phase's end runs past the recording with the delay added: its last second is compared instead
    assert rows[2]["distance_m"] == pytest.approx(0.0, abs=1e-12)


def _cli(*args):
    return subprocess.run([sys.executable, "-m", "simtune.cli", *args], capture_output=True, text=True, timeout=600)


@pytest.mark.slow  # 7 s
def test_check_reports_quality_onsets_and_what_the_task_informs():
    proc = _cli("check", "--engine", "mujoco", "--task", "cube", "--data", str(REFERENCE_DIR), "-s", "shared", "--json")
    assert proc.returncode == 0, proc.stderr
    result = json.loads(proc.stdout)
    (cube,) = result["data_quality"]
    assert [r["file"] for r in cube["repeats"]] == ["cube0001.tsv.gz", "cube0002.tsv.gz", "cube0003.tsv.gz"]
    for r in cube["repeats"]:
        assert r["lost_frames"] >= 0 and r["distance_to_mean_m"] < 0.05 and r["start_distance_m"] < 0.1
        assert r["onset_s"] is not None and 0.0 < r["onset_s"] < 5.0
        assert abs(r["shift_s"]) < 0.2 and not r["shift_outlier"] and r["floor_fitness"] > 0
    # the floor: the repeats agree better on one clock; the reference checked against is the aligned one
    assert 0 < cube["repeat_spread_aligned_m"] <= cube["repeat_spread_unaligned_m"]
    assert cube["reference"] == result["reference"] == "aligned" and cube["floor_fitness"] > 0
    assert cube["data_checks"] == []  # the shipped reference meets every named check (simtune.data.ingest's too)
    # the shipped repeats rest where each phase's targets put the arm, but for the marker's offset
    assert [r["stretch"] for r in cube["rest_poses"]] == ["phase 1", "phase 2", "phase 3"]
    assert all(0 < r["distance_m"] < 0.03 and not r["far"] for r in cube["rest_poses"])
    jac = result["jacobian"]
    assert 0 < jac["rank"] <= jac["searched"] == len(jac["singular_values"])
    informed = {p["name"] for p in result["parameters"] if p["informed"]}
    inactive = {p["name"] for p in result["parameters"] if "inactive" in p}
    # a velocity limit of the arm is informed (which one depends on the recording: joint 4 on the reference since
    # its phase 2 runs joint 3 to 74 deg)
    assert any(n.startswith("max_velocity_joint_") for n in informed) and "mass_cube_wood" in inactive
    assert not informed & inactive


def test_check_without_tasks_says_what_to_give():
    proc = _cli("check")
    assert proc.returncode == 2 and proc.stderr.startswith("error:") and "--task" in proc.stderr
