"""Every recorded signal weighed by its own noise (issue 44, item 2): the noise estimated from the repeats' spread,
the residuals divided by it, a run's choice stored, and the paper's runs untouched."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from simtune.data import TaskData
from simtune.engines.base import Rollout
from simtune.errors import ConfigError
from simtune.fitness import DEFAULT_NOISE, LEAST_NOISE, NOISE_UNIT_M, residuals, signal_noise
from simtune.run_plan import RunConfig


def _reference(repeats: int, wrist_sd: float, joint_sd: list[float], n: int = 200, seed: int = 0) -> TaskData:
    """A task's recordings: a wrist track and two joints, each repeat the mean plus white noise of the given sd."""
    rng = np.random.default_rng(seed)
    t = np.arange(n) / 20.0
    wrist_true = np.stack([0.3 + 0.1 * np.sin(t), 0.1 * np.cos(t), 0.5 + 0.0 * t], axis=1)
    joints_true = np.stack([np.sin(0.5 * t), 0.2 * t / t[-1]], axis=1)
    wrist = wrist_true + rng.normal(0.0, wrist_sd, (repeats, n, 3))
    joints = joints_true + rng.normal(0.0, 1.0, (repeats, n, 2)) * np.array(joint_sd)
    return TaskData(
        task="t",
        rate=20.0,
        times=t,
        wrist_mean=wrist.mean(axis=0),
        wrist_repeats=wrist,
        object_final=None,
        object_start=None,
        sources=[Path(f"r{i}.csv") for i in range(repeats)],
        joint_names=["j1", "j2"],
        joint_mean=joints.mean(axis=0),
        joint_repeats=joints,
    )


def _rollout(reference: TaskData, wrist_offset: float, joint_offsets: tuple[float, float]) -> Rollout:
    n = len(reference.times)
    assert reference.wrist_mean is not None and reference.joint_mean is not None
    return Rollout(
        times=reference.times,
        wrist_pos=reference.wrist_mean + wrist_offset,
        wrist_rot=np.tile(np.eye(3), (n, 1, 1)),
        object_pos=None,
        joint_angles=reference.joint_mean + np.array(joint_offsets),
        stable=True,
        message="",
    )


def test_each_signals_noise_is_the_spread_of_its_repeats():
    reference = _reference(repeats=8, wrist_sd=0.002, joint_sd=[math.radians(0.05), math.radians(0.5)])
    noise = signal_noise(reference)
    assert noise.estimated and noise.object_m is None
    assert noise.wrist_m == pytest.approx(0.002, rel=0.05)
    assert noise.joints_rad == pytest.approx([math.radians(0.05), math.radians(0.5)], rel=0.05)


def test_one_repeat_takes_the_default_noise_and_noiseless_repeats_the_least():
    one = signal_noise(_reference(repeats=1, wrist_sd=0.002, joint_sd=[0.01, 0.01]))
    assert not one.estimated
    assert one.wrist_m == DEFAULT_NOISE["wrist"] and one.joints_rad == (DEFAULT_NOISE["joint"],) * 2
    still = signal_noise(_reference(repeats=3, wrist_sd=0.0, joint_sd=[0.0, 0.0]))
    assert still.wrist_m == LEAST_NOISE["wrist"] and still.joints_rad == (LEAST_NOISE["joint"],) * 2


def test_residuals_divide_each_signal_by_its_noise():
    """A joint logged to 0.05 deg weighs as its precision says beside a marker to 2 mm: a misfit of one noise
    in either gives the same residual."""
    reference = _reference(repeats=8, wrist_sd=0.002, joint_sd=[math.radians(0.05), math.radians(0.5)])
    noise = signal_noise(reference)
    n = len(reference.times)
    names = ("j1", "j2")

    def weighed(rollout: Rollout) -> np.ndarray:
        return residuals(rollout, reference, {}, joint_names=names, noise=noise)

    one_sigma_wrist = weighed(_rollout(reference, noise.wrist_m or 0.0, (0.0, 0.0)))
    one_sigma_joint1 = weighed(_rollout(reference, 0.0, (noise.joints_rad[0], 0.0)))
    one_sigma_joint2 = weighed(_rollout(reference, 0.0, (0.0, noise.joints_rad[1])))
    # per sample and signal: NOISE_UNIT_M / sqrt(n) for a misfit of one noise, whichever the signal
    per = NOISE_UNIT_M / math.sqrt(n)
    assert np.abs(one_sigma_wrist[: 3 * n]) == pytest.approx(np.full(3 * n, per))
    joints1 = one_sigma_joint1[3 * n :].reshape(n, 2)
    joints2 = one_sigma_joint2[3 * n :].reshape(n, 2)
    assert joints1[:, 0] == pytest.approx(np.full(n, per)) and not joints1[:, 1].any()
    assert joints2[:, 1] == pytest.approx(np.full(n, per))

    # the plain residuals weigh the precise joint 0.5 m/rad, averaged over the joints: a misfit of one noise in it
    # counts for far less than one in the marker, where the weighed ones count both alike (3 axes against 1)
    def plain(rollout: Rollout) -> float:
        return float(np.linalg.norm(residuals(rollout, reference, {}, joint_names=names)))

    plain_ratio = plain(_rollout(reference, 0.0, (noise.joints_rad[0], 0.0))) / plain(
        _rollout(reference, noise.wrist_m or 0.0, (0.0, 0.0))
    )
    weighed_ratio = np.linalg.norm(one_sigma_joint1) / np.linalg.norm(one_sigma_wrist)
    assert weighed_ratio == pytest.approx(1 / math.sqrt(3)) and plain_ratio < 0.25 * weighed_ratio


def test_new_runs_weigh_by_noise_and_the_papers_and_stored_runs_keep_plain_residuals():
    assert RunConfig(optimizer="de", engine="mujoco", tasks="cube", space="extended", data=None).residuals == "noise"
    exact = RunConfig(optimizer="de", engine="mujoco", tasks="cube", space="shared", data=None, paper_exact=True)
    assert exact.residuals == "plain" and "residuals" not in exact.record()
    stored = RunConfig(optimizer="de", engine="mujoco", tasks="cube", space="extended", data=None).record()
    assert stored["residuals"] == "noise"
    del stored["residuals"]  # a store from before the setting
    assert RunConfig.from_stored(stored, "run.sqlite").residuals == "plain"
    with pytest.raises(ConfigError, match="residuals"):
        RunConfig(optimizer="de", engine="mujoco", tasks="cube", space="extended", data=None, residuals="loud").check()
    with pytest.raises(ConfigError, match="paper-exact"):
        RunConfig(
            optimizer="de",
            engine="mujoco",
            tasks="cube",
            space="shared",
            data=None,
            paper_exact=True,
            residuals="noise",
        ).check()
