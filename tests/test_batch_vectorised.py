"""MuJoCo's vectorised batch path (engines/mujoco/batch.py): a batch in lockstep control periods gives each
member the rollout it gets alone, bit for bit, on one thread and on two."""

import numpy as np
import pytest

from simtune.engines.mujoco.batch import period_steps
from simtune.engines.mujoco.engine import MujocoEngine
from simtune.tasks import get_task

#: members with different time steps, masses, damping, speed limits, encoders and command delays: a delay of
#: whole periods (the controller updates at the sample), delays that put the update inside the period, a
#: member that blows up at once (non-finite state, found by the scheduled check) and, on `cube`, one whose
#: cube is thrown away late in the run
MEMBERS = [
    {},
    {"command_delay": 1.0, "timestep": 0.004, "mass_link_3": 0.9},
    {"command_delay": 1.234, "timestep": 0.0031, "joint_damping_2": 0.3, "max_velocity_joint_1": 25.0},
    {"command_delay": 0.77, "timestep": 0.0125, "mass_link_6": 0.5, "mass_cube_plastic": 0.2},
    {"command_delay": 1.51, "joint_offset_2": 1.5, "compliance_joint_3": 0.002, "mass_link_2": 1.1},
    {"joint_damping_6": -1000.0},
    {"command_delay": 0.9, "timestep": 0.0093, "lateral_friction_plastic": 0.4, "max_velocity_joint_2": 12.0},
    {"linear_damping_plastic": -1.0, "mass_cube_plastic": 0.01},
]


def same_rollout(got, want) -> None:
    """Every array and number of two rollouts equal (``==`` on every float)."""
    for name in ("times", "wrist_pos", "wrist_rot", "joint_angles", "object_pos"):
        a, b = getattr(got, name), getattr(want, name)
        assert (a is None) == (b is None), name
        if a is not None:
            assert a.shape == b.shape and np.array_equal(a, b), name
    for name in ("stable", "message", "steps", "samples_run", "pruned"):
        assert getattr(got, name) == getattr(want, name), name


def watching(k_stop: int | None, budget: float | None):
    """A fresh monitor: stops at sample ``k_stop``, or once the summed wrist height passes ``budget``."""
    total = [0.0]

    def monitor(k, pos, rot) -> bool:
        total[0] += float(pos[2] + rot[2, 2])
        return (k_stop is not None and k >= k_stop) or (budget is not None and total[0] > budget)

    return monitor


@pytest.mark.parametrize("task_name", ["single", "cube"])
@pytest.mark.parametrize("threads", [1, 2])
def test_a_vectorised_batch_equals_its_members_alone(task_name, threads):
    task = get_task(task_name)
    n = int(round(task.duration * 20))
    members = MEMBERS if task.object is not None else MEMBERS[:-1]
    alone_engine, batch_engine = MujocoEngine(task), MujocoEngine(task)
    alone = [alone_engine.rollout(p, n) for p in members]
    batch = dict(batch_engine.rollout_batch(members, n, threads=threads))
    assert sorted(batch) == list(range(len(members)))
    for i, want in enumerate(alone):
        same_rollout(batch[i], want)
    # the batch holds what it must: phases inside the period, an early blow-up, contact moving the cube
    assert alone[5].stable is False and alone[5].samples_run == 1
    if task.object is not None:
        assert alone[7].stable is False and "object thrown" in alone[7].message
        moved = [np.linalg.norm(r.object_pos[-1] - r.object_pos[0]) for r in alone[:5]]
        assert max(moved) > 0.005  # the hand pushed the cube
    # monitors: stopped at a sample, stopped by what they saw, never stopped
    seen = np.cumsum(alone[1].wrist_pos[:, 2] + alone[1].wrist_rot[:, 2, 2])
    stops = [(40, None), (None, float(seen[n // 2])), (None, None), (None, 1e9), (3, None)]
    want = [alone_engine.rollout(p, n, monitor=watching(*s)) for p, s in zip(members, stops)]
    got = dict(batch_engine.rollout_batch(members[:5], n, [watching(*s) for s in stops], threads=threads))
    for i, roll in enumerate(want):
        same_rollout(got[i], roll)
    assert [r.pruned for r in want] == [True, True, False, False, True]
    alone_engine.close()
    batch_engine.close()


def test_a_member_that_fails_is_that_members_error():
    """Parameters that cannot be applied or simulated, a monitor that raises: that member's error, the others
    run on."""

    def failing(k, pos, rot) -> bool:
        if k == 7:
            raise RuntimeError("monitor failed")
        return False

    engine, alone = MujocoEngine(get_task("single")), MujocoEngine(get_task("single"))
    members = [{}, {"max_velocity_joint_1": "fast"}, {"command_delay": 1.1}, {"timestep": 0.004}, {"timestep": 0.0}]
    results = dict(engine.rollout_batch(members, 30, [None, None, failing, None, None], threads=2))
    assert isinstance(results[1], ValueError) and isinstance(results[4], ZeroDivisionError)
    assert isinstance(results[2], RuntimeError) and str(results[2]) == "monitor failed"
    for i in (0, 3):
        same_rollout(results[i], alone.rollout(members[i], 30))
    engine.close()
    alone.close()


def test_step_counts_follow_each_members_clock():
    dts = np.array([0.002, 0.0031, 0.0125, 0.05, 0.03])
    phases = np.array([0.0, 0.034, 0.02, 0.01, 0.0])
    before, after = period_steps(dts, phases, 201, 0.05)
    # simulated time stays within half a step of the sample clock, and of the controller's before the update
    clock = np.cumsum((before + after) * dts[:, None], axis=1)
    assert np.all(np.abs(clock - 0.05 * np.arange(1, 201)) <= dts[:, None] / 2 + 1e-12)
    assert np.all(after >= 1) and not before[[0, 4]].any() and before[1:4].any()


def test_a_member_mujoco_warns_about_ends_as_alone():
    """MuJoCo's bad-acceleration warning (raised here by a monitor, between two samples) ends that member at the
    next sample, as alone, with MuJoCo's reason; the others run on."""
    import mujoco

    def warning(data):
        def monitor(k, pos, rot) -> bool:
            if k == 12:
                data.warning[int(mujoco.mjtWarning.mjWARN_BADQACC)].number += 1
            return False

        return monitor

    task, n = get_task("single"), 40
    members = [{}, {"command_delay": 1.13, "timestep": 0.003}, {"timestep": 0.004}]
    alone, engine = MujocoEngine(task), MujocoEngine(task)
    want = alone.rollout(members[1], n, monitor=warning(alone.data))
    assert not want.stable and want.samples_run == 13 and "bad accelerations" in want.message
    copies = engine._thread_copies(len(members))
    got = dict(engine.rollout_batch(members, n, [None, warning(copies[1].data), None], threads=2))
    same_rollout(got[1], want)
    for i in (0, 2):
        same_rollout(got[i], alone.rollout(members[i], n))
    alone.close()
    engine.close()


def test_marker_budgets_watched_together_sum_and_stop_as_each_alone():
    """Differential evolution's pruning monitor, advanced for many members by one NumPy computation, gives each
    the sums (==) and the stopping sample it gets alone; the batch path watches its members that way."""
    from simtune.engines.base import MarkerBudget

    rng = np.random.default_rng(3)
    n, m = 40, 9
    targets = rng.normal(size=(n, 3))
    offsets = rng.normal(scale=0.1, size=(m, 3))
    pos = rng.normal(size=(n, m, 3))
    rot = np.linalg.qr(rng.normal(size=(n, m, 3, 3)))[0]
    budgets = rng.uniform(5.0, 60.0, size=m)
    alone = [MarkerBudget(targets, o, b) for o, b in zip(offsets, budgets)]
    together = [MarkerBudget(targets, o, b) for o, b in zip(offsets, budgets)]
    stops_alone = [next((k for k in range(n) if alone[j](k, pos[k, j], rot[k, j])), None) for j in range(m)]
    stops_together: list[int | None] = [None] * m
    for k in range(n):
        going = [j for j in range(m) if stops_together[j] is None]
        stop = MarkerBudget.watch_all([together[j] for j in going], k, pos[k, going], rot[k, going])
        for j in np.asarray(going)[stop]:
            stops_together[j] = k
    assert stops_together == stops_alone and len(set(stops_alone)) > 3  # members stop at different samples
    assert [b.spent for b in together] == [b.spent for b in alone]
    # the distance is the marker's (R @ offset + pos) from the target, as the fitness measures it
    probe = MarkerBudget(targets, offsets[0], 1e9)
    probe(0, pos[0, 0], rot[0, 0])
    assert np.isclose(probe.spent, np.linalg.norm(pos[0, 0] + rot[0, 0] @ offsets[0] - targets[0]), rtol=1e-14)
