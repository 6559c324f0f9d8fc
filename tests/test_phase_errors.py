"""The report's wrist error per stretch of a task (Table 6a): where in time a fit's error sits."""

import numpy as np
import pytest

from simtune.report.collect import Group
from simtune.report.tables import phase_error_table, phase_errors
from simtune.tasks import get_task


def test_the_stretches_are_the_schedules_phases_from_when_each_command_arrives():
    cube = get_task("cube")
    assert cube.stretches() == [("phase 1", 0.0, 8.0), ("phase 2", 8.0, 14.0), ("phase 3", 14.0, 20.0)]
    assert cube.stretches(delay=1.5) == [
        ("start pose", 0.0, 1.5),
        ("phase 1", 1.5, 9.5),
        ("phase 2", 9.5, 15.5),
        ("phase 3", 15.5, 20.0),
    ]
    single = get_task("single")
    assert single.stretches() == [("phase 1", 0.0, single.duration)]
    assert single.stretches(delay=single.duration + 1) == [("start pose", 0.0, single.duration)]  # none arrives


def test_each_stretch_gets_its_own_error_offset_and_floor():
    task = get_task("cube")
    times = np.round(np.arange(401) * 0.05, 10)
    mean = np.zeros((401, 3))
    moving = (times >= 8.0) & (times < 10.0)  # the recorded wrist moves 0.1 m/s in x from 8 to 10 s only
    mean[:, 0] = 0.1 * np.clip(times - 8.0, 0.0, 2.0)
    repeats = mean[None] + np.array([0.0, 0.0, 0.002])[None, None] * np.array([1.0, -1.0])[:, None, None]
    untuned = mean + [0.1, 0.0, 0.0]
    tuned = mean.copy()
    tuned[times < 8.0] += [0.003, 0.0, 0.0]
    tuned[moving] += [0.0, 0.01, 0.0]
    tuned[(times >= 10.0) & (times < 14.0)] += [0.0, 0.0, -0.03]
    tuned[times >= 14.0] += [0.0, 0.004, 0.0]
    group = Group("mujoco", "cube", "calibrated", [])
    spans = task.stretches()
    entries = phase_errors(group, "cube", spans, times, (mean, repeats), (untuned, np.vstack([tuned, tuned[-1:]])))
    assert [e.phase for e in entries] == ["phase 1", "phase 2", "phase 3"]
    assert [e.samples for e in entries] == [160, 120, 121]  # the last stretch keeps the last sample
    first, second, third = entries
    assert first.tuned == pytest.approx(0.003) and first.tuned_moving is None
    np.testing.assert_allclose(first.tuned_offset, [0.003, 0.0, 0.0], atol=1e-12)
    # phase 2: 40 moving samples 10 mm off in y, 80 at rest 30 mm below (the gradient blurs the edges by one)
    assert second.tuned == pytest.approx((40 * 0.01 + 80 * 0.03) / 120)
    assert second.tuned_at_rest == pytest.approx(0.03, abs=0.001)
    assert second.tuned_moving == pytest.approx(0.01, abs=0.001)
    assert third.tuned == pytest.approx(0.004) and third.tuned_at_rest == pytest.approx(0.004)
    assert all(e.untuned == pytest.approx(0.1) and e.repeat_spread == pytest.approx(0.002) for e in entries)
    weighted = sum(e.tuned * e.samples for e in entries) / 401
    assert weighted == pytest.approx(np.linalg.norm(tuned - mean, axis=1).mean())
    table = phase_error_table(entries)
    row = table.rows[1]
    assert row[:5] == ["mujoco", "cube", "calibrated", "cube", "phase 2"]
    assert row[9] == pytest.approx(1000 * second.tuned) and row[14] == pytest.approx(-20.0)  # z: 80/120 x -30 mm
