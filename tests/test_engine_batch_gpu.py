"""The mujoco-warp engine: a population as one MuJoCo Warp batch gives the MuJoCo engine's trajectories.

Run on Warp's CPU device where there is no GPU (as here): the first use builds Warp's kernels for about a
minute, and each batch steps 20-50 times slower than MuJoCo, so everything that simulates is in the slow
tier.  Without the package (``pip install 'simtune[gpu]'``, not in the test extra: its CPU runs would
add half an hour to the slow tier) those tests skip and say so.
"""

import numpy as np
import pytest
from conftest import engine_or_skip

from simtune.engines import make_engine
from simtune.engines.mujoco_warp.engine import step_counts, time_step_groups
from simtune.params import get_space
from simtune.tasks import get_task

#: The largest distance [m] between the two engines' wrist positions, at any sample, of any member:
#: MJWarp computes in 32-bit floats and stops its solver at 1e-6 (MuJoCo: 64-bit, 1e-8); on `cube`
#: the push amplifies that, and the issue's bound there is 5 mm.
WRIST_BOUND = {"single": 1e-3, "cube": 5e-3}


def population(n_random: int, seed: int = 0) -> list[dict[str, float]]:
    """Generic parameters and ``n_random`` uniform points of the `extended` space of the MuJoCo engine."""
    from simtune.engines.mujoco.engine import MujocoEngine

    space = get_space("extended", MujocoEngine.supported())
    rng = np.random.default_rng(seed)
    return [{}] + [{p.name: float(rng.uniform(p.low, p.high)) for p in space.parameters} for _ in range(n_random)]


@pytest.mark.parametrize("timestep", [0.001, 0.002, 0.0037, 0.0322, 0.05])
@pytest.mark.parametrize("delay", [0.0, 0.03, 1.234])
def test_step_counts_are_those_of_the_shared_rollout(timestep, delay):
    """The batch fixes each world's steps in advance: as many as Engine.rollout takes, period by period."""
    sim = make_engine("mujoco", get_task("single"))
    roll = sim.rollout({"timestep": timestep, "command_delay": delay}, 41)
    counts = step_counts(sim.timestep, delay % 0.05, 41)
    assert counts.shape == (40, 2)
    assert int(counts.sum()) == roll.steps
    assert (counts[:, 1] >= 1).all()  # every period moves the physics on


@pytest.mark.slow
@pytest.mark.parametrize("task_name", ["single", "cube"])
def test_a_batch_gives_the_mujoco_engines_wrist_trajectories(task_name):
    engine_or_skip("mujoco-warp")
    task = get_task(task_name)
    n = int(task.duration * 20) + 1
    params = population(10)
    gpu = make_engine("mujoco-warp", task)
    cpu = make_engine("mujoco", task)
    batch = dict(gpu.rollout_batch(params, n))
    assert sorted(batch) == list(range(len(params)))
    worst = []
    for i, p in enumerate(params):
        got, want = batch[i], cpu.rollout(p, n)
        assert not isinstance(got, Exception), got
        assert got.stable == want.stable, (i, got.message, want.message)
        assert got.steps == want.steps and got.samples_run == want.samples_run
        gap = np.linalg.norm(got.wrist_pos - want.wrist_pos, axis=1).max()
        worst.append(gap)
        np.testing.assert_allclose(got.joint_angles, want.joint_angles, atol=0.01)
    assert max(worst) < WRIST_BOUND[task_name], [f"{g * 1000:.2f} mm" for g in worst]


def test_the_batch_has_the_drive_train_kinds_and_not_the_encoder_model():
    """The armature, joint friction and per-joint gains are MuJoCo Warp's (per-world fields, the control kernel's
    gains); the encoder model, which the kernel does not have, is not offered (asked for, it is refused by name)."""
    from simtune.engines import ENGINES

    names = ENGINES["mujoco-warp"].engine_class().supported()  # its class even where its library is missing
    for kind in ("armature_joint", "friction_joint", "kp_joint"):
        assert {f"{kind}_{i}" for i in range(1, 7)} <= names
    assert not any(name.startswith(("joint_offset_", "compliance_joint_")) for name in names)


@pytest.mark.slow
def test_a_batch_with_drive_train_parameters_gives_the_mujoco_engines_wrist_trajectories():
    """Random armature, joint friction and gains of the MICO's `drivetrain` space: each world follows the MuJoCo
    engine with the same values, where they move the arm far from the generic one."""
    engine_or_skip("mujoco-warp")
    from simtune.engines.mujoco.engine import MujocoEngine

    task = get_task("single")
    n = int(task.duration * 20) + 1
    drive = [
        p
        for p in get_space("drivetrain", MujocoEngine.supported()).parameters
        if p.name.startswith(("armature_joint_", "friction_joint_", "kp_joint_"))
    ]
    assert len(drive) == 18
    rng = np.random.default_rng(1)
    params = [{p.name: float(rng.uniform(p.low, p.high)) for p in drive} for _ in range(3)]
    gpu = make_engine("mujoco-warp", task)
    cpu = make_engine("mujoco", task)
    generic = cpu.rollout({}, n)
    batch = dict(gpu.rollout_batch(params, n))
    for i, p in enumerate(params):
        got, want = batch[i], cpu.rollout(p, n)
        assert not isinstance(got, Exception), got
        assert np.linalg.norm(want.wrist_pos - generic.wrist_pos, axis=1).max() > 0.1  # the kinds act
        assert np.linalg.norm(got.wrist_pos - want.wrist_pos, axis=1).max() < WRIST_BOUND["single"]


@pytest.mark.slow
def test_a_member_of_a_batch_is_the_member_alone_and_monitors_stop_it_as_alone():
    """Worlds with other time steps wait for each other without changing anything; a monitor sees the samples
    Engine.rollout would show it and stops the rollout where it would."""
    engine_or_skip("mujoco-warp")
    task = get_task("single")
    params = population(3, seed=1)
    gpu = make_engine("mujoco-warp", task)
    cpu = make_engine("mujoco", task)
    batch = dict(gpu.rollout_batch(params, 41))
    for i, p in enumerate(params):
        alone = gpu.rollout(p, 41)
        np.testing.assert_allclose(batch[i].wrist_pos, alone.wrist_pos, atol=1e-7)
        assert batch[i].steps == alone.steps

    def stop_at_25(k, pos, rot):
        return k == 25

    got = gpu.rollout(params[1], 41, monitor=stop_at_25)
    want = cpu.rollout(params[1], 41, monitor=stop_at_25)
    assert got.pruned and want.pruned
    assert (got.samples_run, got.steps) == (want.samples_run, want.steps)
    np.testing.assert_array_equal(got.wrist_pos[26:], np.repeat(got.wrist_pos[25:26], 15, axis=0))


def test_cpu_batches_group_members_of_similar_time_steps():
    steps = {0: 0.002, 1: 0.05, 2: 0.0035, 3: 0.001, 4: 0.0041, 5: 0.03}
    groups = time_step_groups(steps, overhead=0.0)  # no cost per batch step: bins within a factor 2
    assert groups == [[3, 0], [2, 4], [5, 1]]
    # a batch step costing 100 worlds' work: merging saves more than the waiting worlds cost
    assert time_step_groups(steps, overhead=100.0) == [[3, 0, 2, 4, 5, 1]]
    many = {i: 0.001 * (1 + i % 50) for i in range(5000)}
    groups = time_step_groups(many, overhead=100.0)
    assert sorted(i for g in groups for i in g) == sorted(many)
    assert 1 < len(groups) < 10
