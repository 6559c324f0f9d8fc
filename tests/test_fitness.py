import numpy as np
import pytest

from simtune.data import TaskData
from simtune.engines import Rollout
from simtune.fitness import PENALTY, Score, marker_positions, score_rollout


def make_reference(wrist, object_final=None):
    n = len(wrist)
    return TaskData(
        task="t",
        rate=20.0,
        times=np.arange(n) / 20.0,
        wrist_mean=wrist,
        wrist_repeats=wrist[None],
        object_final=object_final,
        object_start=None if object_final is None else object_final * 0,
        sources=[],
    )


def make_rollout(wrist, obj=None, stable=True):
    n = len(wrist)
    return Rollout(np.arange(n) / 20.0, wrist, np.tile(np.eye(3), (n, 1, 1)), np.zeros((n, 6)), obj, stable)


def test_identical_trajectories_score_zero_and_offsets_score_their_distance():
    wrist = np.random.default_rng(0).normal(size=(50, 3))
    ref = make_reference(wrist)
    assert score_rollout(make_rollout(wrist), ref, {}).fitness == pytest.approx(0.0)
    shifted = score_rollout(make_rollout(wrist + [0.03, 0.04, 0.0]), ref, {})
    assert shifted.wrist_error == pytest.approx(0.05)
    assert shifted.object_error is None


def test_marker_offset_turns_with_the_hand():
    wrist = np.zeros((2, 3))
    roll = make_rollout(wrist)
    roll.wrist_rot[1] = [[0, -1, 0], [1, 0, 0], [0, 0, 1]]  # hand turned 90 deg about z
    markers = marker_positions(roll, {"marker_offset_x": 0.01})
    np.testing.assert_allclose(markers, [[0.01, 0, 0], [0, 0.01, 0]], atol=1e-12)


def test_object_error_is_final_position_distance_and_adds_to_fitness():
    wrist = np.zeros((10, 3))
    obj = np.zeros((10, 3))
    obj[-1] = [0.6, 0.0, 0.0375]
    ref = make_reference(wrist, object_final=np.array([[0.5, 0.0, 0.0375], [0.7, 0.0, 0.0375]]))
    s = score_rollout(make_rollout(wrist, obj), ref, {})
    assert s.object_error == pytest.approx(0.0)  # the mean of the repeats' final positions
    obj[-1] = [0.6, 0.03, 0.0375]
    s = score_rollout(make_rollout(wrist + 0.01, obj), ref, {})
    assert s.object_error == pytest.approx(0.03)
    assert s.fitness == pytest.approx(0.03 + np.sqrt(3) * 0.01)


def test_unstable_rollout_gets_finite_penalty_and_flag():
    wrist = np.zeros((5, 3))
    s = score_rollout(make_rollout(wrist, stable=False), make_reference(wrist), {})
    assert s.fitness == PENALTY and not s.stable
    combined = Score.combine([s, score_rollout(make_rollout(wrist), make_reference(wrist), {})])
    assert combined.fitness == PENALTY and not combined.stable
    assert Score.from_dict(combined.to_dict()) == combined
