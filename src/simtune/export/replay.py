"""Drive exported model files with each engine's own Python API: the round trip of `simtune export`.

Each engine's replay (``engines/<name>/replay.py``, a :class:`~simtune.engines.replay_base.FromFiles`) loads
only the files of an export folder (the model files, the sidecar, controller.yaml).  They are `Engine`s, so
simtune's shared control loop (`Engine.rollout`: the 20 Hz controller, its phase, the step counting) drives
them exactly as it drove the tuned run, and simtune's fitness scores them here.
Used by the round-trip tests and ``benchmarks/export_round_trip.py``.
"""

from __future__ import annotations

from pathlib import Path

from simtune.data import TaskData
from simtune.engines import ENGINES, load_part
from simtune.engines.base import Rollout
from simtune.engines.replay_base import controller
from simtune.errors import SimtuneError
from simtune.fitness import TaskScore, rollout_joint_names, score_rollout
from simtune.tasks.spec import Phase, TaskSpec


def task_from_controller(folder: Path, name: str, like: TaskSpec) -> TaskSpec:
    """The task as controller.yaml gives it (``like`` only says whether there is an object to track)."""
    t = controller(folder)["tasks"][name]
    phases = tuple(Phase(p["start_s"], tuple(p["targets_deg"])) for p in t["schedule"])
    return TaskSpec(
        name,
        t["description"],
        t["duration_s"],
        phases,
        t["kp_per_s"],
        object=like.object,
        start_pose_deg=tuple(t["start_pose_deg"]),
        interpolation=t.get("interpolation", "hold"),  # exports from before the key held every set-point
        robot=like.robot,  # the encoders' gravity torques are the robot's
    )


def controller_params(folder: Path, name: str) -> dict[str, float]:
    """The controller's and the marker's values from controller.yaml, as simtune's controller and fitness read them."""
    ctl = controller(folder)
    params = {f"max_velocity_joint_{i}": v for i, v in enumerate(ctl["tasks"][name]["max_velocity_deg_s"], start=1)}
    # the task's own delay (tasks tuned together each had one); files from before it hold the shared one only
    params["command_delay"] = ctl["tasks"][name].get("command_delay_s", ctl["control"]["command_delay_s"])
    params.update({f"marker_offset_{a}": v for a, v in zip("xyz", ctl["tracking"]["marker_offset_m"])})
    gains = ctl["tasks"][name].get("kp_joint_per_s")  # exports from before the per-joint gains have none
    if gains is not None:
        params.update({f"kp_joint_{i}": v for i, v in enumerate(gains, start=1)})
    encoders = ctl["control"].get("encoders")  # exports from before the encoder model have none
    if encoders is not None:
        for kind, key in (
            ("joint_offset", "zero_offset_deg"),
            ("compliance_joint", "compliance_rad_per_n_m"),
            ("mass_link", "gravity_link_masses_kg"),  # the controller's gravity torques; the files hold the masses
        ):
            params.update({f"{kind}_{i}": v for i, v in enumerate(encoders[key], start=1)})
    return params


#: engines whose exported files can be driven again (the registry's; ODE has no model file)
REPLAYS: tuple[str, ...] = tuple(name for name, entry in ENGINES.items() if entry.replay is not None)


def replay_task(engine: str, folder: Path, task: TaskSpec, reference: TaskData) -> tuple[Rollout, TaskScore]:
    """Drive ``engine``'s exported model of ``task`` with controller.yaml's commands; its rollout and score.

    ``task`` (simtune's) only says whether there is an object to track: its
    schedule, gain and start pose are taken from controller.yaml.
    """
    exported = task_from_controller(folder, task.name, task)
    params = controller_params(folder, task.name)
    replay = ENGINES[engine].replay
    if replay is None:
        raise SimtuneError(f"engine {engine!r} has no model files to replay")
    sim = load_part(replay)(exported, folder)
    try:
        rollout = sim.rollout(params, len(reference.times))
    finally:
        sim.close()
    return rollout, score_rollout(rollout, reference, params, joint_names=rollout_joint_names(task))


__all__ = [
    "REPLAYS",
    "controller_params",
    "replay_task",
    "task_from_controller",
]
