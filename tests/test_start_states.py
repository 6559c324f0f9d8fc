"""Start states from the recordings: the object starts where they put it (task-file key
``start_from_recordings``), and the arm's start pose is checked against the first recorded wrist."""

import dataclasses
import warnings

import numpy as np
import pytest

from simtune.errors import ProjectError, RecordingWarning
from simtune.objective import Objective, load_references, start_pose_gap, started_as_recorded
from simtune.project import load_project
from simtune.tasks import get_task

TASK = """\
name = "cube"
duration = 20.0
{key}

[controller]
law = "clamped-p-velocity"
gain = 10.0

[mocap]
body = "RB1(Orange)"
base_body = "RB2(Black)"

{object}

[[phases]]
start = 0.0
targets_deg = [0, 30, 120, 90, 0, 0]
"""
OBJECT = """\
[object]
shape = "cube"
material = "plastic"
mass = 0.0884
size = [0.075, 0.075, 0.075]
xy = [0.5, 0.0]
mocap_body = "PCube"
"""


def write_project(tmp_path, key: str, obj: str = OBJECT):
    (tmp_path / "tasks").mkdir(parents=True)
    (tmp_path / "tasks" / "cube.toml").write_text(TASK.format(key=key, object=obj))
    (tmp_path / "simtune.toml").write_text('robot = "mico"\ntasks = ["tasks/cube.toml"]\n')
    return tmp_path


def test_the_key_reads_defaults_off_and_needs_an_object(tmp_path):
    on = load_project(write_project(tmp_path / "a", "start_from_recordings = true")).task("cube")
    off = load_project(write_project(tmp_path / "b", "")).task("cube")
    assert on.start_from_recordings and not off.start_from_recordings
    assert not get_task("cube").start_from_recordings  # the bundled cube keeps its stored runs resumable
    with pytest.raises(ProjectError, match="start_from_recordings.*no object"):
        load_project(write_project(tmp_path / "c", "start_from_recordings = true", obj="")).task("cube")
    with pytest.raises(ProjectError, match="start_from_recordings"):
        load_project(write_project(tmp_path / "d", 'start_from_recordings = "yes"')).task("cube")


def test_the_real_cube_starts_where_its_recordings_put_it(mocap_root):
    task = dataclasses.replace(get_task("cube"), start_from_recordings=True)
    refs = load_references(mocap_root, [task])
    rest = refs["cube"].object_start_mean
    assert rest is not None
    # about 4.5 mm from the nominal (0.5, 0), as the issue measured
    assert 0.003 < np.hypot(rest[0] - 0.5, rest[1]) < 0.006
    placed = started_as_recorded(task, refs["cube"])
    assert placed.object is not None and placed.object.xy == pytest.approx(tuple(rest[:2]))
    assert started_as_recorded(get_task("cube"), refs["cube"]) is get_task("cube")  # key off: unchanged
    pytest.importorskip("mujoco")
    objective = Objective("mujoco", [task], refs)
    roll = objective.rollouts({})["cube"]
    np.testing.assert_allclose(roll.object_pos[0, :2], rest[:2], atol=1e-4)


def test_a_start_pose_far_from_the_recorded_wrist_is_warned_about(mocap_root):
    task = get_task("cube")
    with warnings.catch_warnings():
        warnings.simplefilter("error", RecordingWarning)  # the real start pose passes the check
        refs = load_references(mocap_root, [task])
    assert start_pose_gap(task, refs["cube"]) < 0.015
    bent = dataclasses.replace(task, start_pose_deg=(0.0, 10.0, 0.0, 0.0, 0.0, 0.0))
    with pytest.warns(RecordingWarning, match=r"start pose check: the arm's link_6 starts \d+\.\d cm"):
        load_references(mocap_root, [bent])


def test_the_start_pose_check_reads_the_wrist_before_it_moves_not_the_whole_first_second():
    # a schedule that starts at once (a synthetic recording, a short command delay): the wrist rests for 0.4 s,
    # then moves 10 cm within the first second; the mean of that second would lie centimetres off the start
    from simtune.data.task import REST_S, TaskData

    times = np.arange(60) / 20.0
    wrist = np.tile([0.2, 0.0, 0.9], (60, 1))
    wrist[8:, 0] += np.minimum(0.2 * (times[8:] - 0.4) / 0.5, 0.2)
    data = TaskData("reach", 20.0, times, wrist, wrist[None], None, None, [])
    assert 0.4 <= data.wrist_rest_end < 0.5
    np.testing.assert_allclose(data.wrist_start_mean, [0.2, 0.0, 0.9])
    resting = dataclasses.replace(data, wrist_mean=np.tile([0.2, 0.0, 0.9], (60, 1)))
    assert resting.wrist_rest_end == REST_S  # an arm at rest all second long: the whole second, as before
    moving = dataclasses.replace(data, wrist_mean=wrist + times[:, None] * [0.3, 0.0, 0.0])
    np.testing.assert_allclose(moving.wrist_start_mean, [0.2, 0.0, 0.9])  # moving from the first sample
