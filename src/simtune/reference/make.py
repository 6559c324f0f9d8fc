"""Make the reference recordings simtune ships: a simulation with hidden parameters.

The recording stands in for a real one in the demo and in tests that must run
without the qrg2019 data: MuJoCo runs the ``cube`` task with parameter values
the demo does not know (including a command delay and a marker offset), and
each repeat gets motion-capture-like noise (2 mm, 100 Hz) and a little
start-time jitter, like real repeats.  Files are written in the Qualisys TSV
format so the demo exercises the same loader as real data.

Regenerate with ``python -m simtune.reference.make`` (deterministic).
"""

from __future__ import annotations

import json
import warnings
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from simtune.data import Recording, write_qualisys_tsv
from simtune.engines import make_engine
from simtune.engines.contact import FLOOR_TOUCH_CONSEQUENCE, floor_touches, touch_spans_text
from simtune.errors import SimtuneError, TaskWarning
from simtune.fitness import marker_positions
from simtune.reference import REFERENCE_DIR
from simtune.tasks import TaskSpec, get_task
from simtune.tasks.spec import BASE_BODY

TRUTH_FILE = REFERENCE_DIR / "truth.json"
TASK = "cube"
RATE = 100.0  # Hz, as the real motion-capture system

#: The hidden parameter values (engine-specific ones are MuJoCo's names).
TRUTH = {
    "command_delay": 1.4,
    "max_velocity_joint_2": 26.0,
    "max_velocity_joint_3": 33.0,
    "lateral_friction_plastic": 0.35,
    "lateral_friction_floor": 0.6,
    "marker_offset_x": 0.008,
    "marker_offset_y": -0.01,
    "marker_offset_z": 0.012,
}


def _warn_of_floor(sim, truth: dict[str, float]) -> None:
    """Warn where the truth's arm touches the floor in a task without an object, which is tuned as if it never did
    (its fitness then jumps with the parameters); engines that cannot tell are not asked."""
    if sim.task.object is not None:
        return
    try:
        spans = floor_touches(sim, truth)
    except NotImplementedError:
        return
    if spans:
        warnings.warn(
            f"task {sim.task.name}: the arm touches the floor with these true values ({touch_spans_text(spans, 3)}): "
            + FLOOR_TOUCH_CONSEQUENCE,
            TaskWarning,
            stacklevel=3,
        )


def synthesize(
    engine: str,
    task: TaskSpec,
    truth: dict[str, float],
    *,
    repeats: int,
    noise_m: float,
    jitter_s: float,
    seed: int,
    rate: float = RATE,
    suffix: str = ".tsv.gz",
    joint_names: Sequence[str] | None = None,
    joint_noise_rad: float = 0.0,
    delays: list[float] | None = None,
) -> list[Recording]:
    """Recordings of ``task`` simulated by ``engine`` with parameters ``truth``, plus mocap-like noise.

    Each repeat shifts the command delay by a uniform jitter in +-``jitter_s``
    (real repeats start at slightly different times), samples the simulation's
    marker (wrist plus ``marker_offset_*``) at ``rate`` Hz with Gaussian noise of
    ``noise_m`` per axis, the base marker and the object with a quarter of it.
    Any engine and any task (with or without object) works; ``suffix`` names
    the files ``<task><repeat:04d><suffix>``.  With ``joint_names`` (the
    rollout's joint columns) each recording also logs the joint angles at
    ``rate`` Hz with Gaussian noise of ``joint_noise_rad``, drawn from a stream
    of their own so the markers stay as they are without joints.  A truth
    whose simulation blows up is refused with a SimtuneError.  ``delays``, when
    given, gets each repeat's command delay (the truth's moved by its start
    jitter) appended in repeat order, for the truth files that record them.
    """
    rng = np.random.default_rng(seed)
    joint_rng = np.random.default_rng([seed, 1])
    sim = make_engine(engine, task)
    _warn_of_floor(sim, truth)
    duration = task.duration
    recordings = []
    for r in range(repeats):
        params = dict(truth)
        params["command_delay"] = max(0.0, truth.get("command_delay", 0.0) + rng.uniform(-jitter_s, jitter_s))
        if delays is not None:
            delays.append(params["command_delay"])
        n20 = int(round(duration * 20)) + 1
        rollout = sim.rollout(params, n20)
        if not rollout.stable:
            sim.close()
            placeholders = task.robot.placeholder_masses
            cause = (
                f"; link {', '.join(placeholders)} moves with a placeholder mass (no <inertial>, no geometry): the "
                f"robot cannot be simulated as described (add an <inertial> to it in {task.robot.source})"
                if placeholders
                else "; choose other true values"
            )
            raise SimtuneError(
                f"{engine} on {task.name}: the simulation with these parameters is unstable ({rollout.message}){cause}"
            )
        t = np.arange(int(round(duration * rate)) + 1) / rate
        marker = marker_positions(rollout, params)

        def up(values: np.ndarray, t: np.ndarray = t, times: np.ndarray = rollout.times) -> np.ndarray:
            """20 Hz -> recording rate."""
            return np.stack([np.interp(t, times, values[:, i]) for i in range(values.shape[1])], axis=1)

        positions = {
            BASE_BODY: np.zeros((len(t), 3)) + rng.normal(0, noise_m / 4, (len(t), 3)),
            task.wrist_body: up(marker) + rng.normal(0, noise_m, (len(t), 3)),
        }
        nearest = np.minimum(np.round(t * 20).astype(int), n20 - 1)
        rotations = {BASE_BODY: np.tile(np.eye(3), (len(t), 1, 1)), task.wrist_body: rollout.wrist_rot[nearest]}
        if task.object is not None:
            assert rollout.object_pos is not None, "a task with an object samples its position"
            positions[task.object.mocap_body] = up(rollout.object_pos) + rng.normal(0, noise_m / 4, (len(t), 3))
            rotations[task.object.mocap_body] = np.tile(np.eye(3), (len(t), 1, 1))
        joints = {}
        if joint_names is not None:
            angles = up(rollout.joint_angles) + joint_rng.normal(0, joint_noise_rad, (len(t), len(joint_names)))
            joints = {name: angles[:, j] for j, name in enumerate(joint_names)}
        recordings.append(Recording(Path(f"{task.name}{r + 1:04d}{suffix}"), t, positions, rotations, joints=joints))
    sim.close()
    return recordings


def make(
    out: Path = REFERENCE_DIR, repeats: int = 3, targets: str = "task", truth_file: Path | None = TRUTH_FILE
) -> None:
    """Write the reference recordings of ``TASK`` into ``out/<task>/`` and, unless ``truth_file`` is None, the hidden
    parameters there.

    ``targets``: the task's joint targets (:data:`simtune.tasks.TARGETS`).  The shipped recordings run the bundled
    task as it is (``task``: since 2026-11-27 the cube's phase 2 at 74 deg); ``published`` writes, byte for byte,
    the recordings shipped before that correction, which the runs stored then were tuned on."""
    task = get_task(TASK, targets=targets)
    folder = out / TASK
    folder.mkdir(parents=True, exist_ok=True)
    for rec in synthesize("mujoco", task, TRUTH, repeats=repeats, noise_m=0.002, jitter_s=0.05, seed=2021):
        write_qualisys_tsv(folder / rec.source.name, rec, header=True)
    if truth_file is not None:
        truth_file.write_text(
            json.dumps({"engine": "mujoco", "task": TASK, "noise_m": 0.002, "params": TRUTH}, indent=2) + "\n"
        )


if __name__ == "__main__":
    make()
