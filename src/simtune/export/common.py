"""What every export shares above the engines: the provenance of a run, controller.yaml, the files' hashes.

Every exported file names where it comes from: XML files and scripts in a
header comment, JSON sidecars in a ``provenance`` member (both written from the
export context, :mod:`simtune.engines.export_base`), and the folder as a whole in
``provenance.json`` (which also lists each file with its SHA-256).
"""

from __future__ import annotations

import datetime as dt
import hashlib
from pathlib import Path

import numpy as np
import yaml

import simtune
from simtune.engines import engine_class
from simtune.engines.controller import CONTROL_PERIOD, JointController
from simtune.engines.export_base import ExportContext, hash_comment
from simtune.export.source import TunedRun
from simtune.tasks.spec import TaskSpec

PROVENANCE_FILE = "provenance.json"
CONTROLLER_FILE = "controller.yaml"


def sha256(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


def provenance(run: TunedRun, engine: str, when: dt.datetime) -> dict:
    """The record of where an export comes from (provenance.json, and each sidecar's ``provenance``)."""
    best = run.best
    return {
        "exported_by": f"simtune {simtune.__version__}",
        "date": when.isoformat(timespec="seconds"),
        "run": str(run.path),
        "engine": engine,
        "engine_version": engine_class(engine).version(),
        "engine_version_of_run": run.versions.get(engine),
        "simtune_version": simtune.__version__,
        "versions_of_run": run.versions,
        "tasks": run.task_names,
        "space": run.config.space,
        "seed": run.config.seed,
        "optimizer": run.config.optimizer,
        "evaluations": run.evaluations,
        "run_finished": (
            dt.datetime.fromtimestamp(run.finished_at, dt.UTC).isoformat(timespec="seconds")
            if run.finished_at is not None
            else None
        ),
        "command": run.command,
        "fitness": best.get("fitness"),
        "wrist_error": best.get("wrist_error"),
        "object_error": best.get("object_error"),
        "generic_fitness": best.get("generic_fitness"),
        "data": str(run.config.data),
        "data_note": run.data_note,
        "data_files": run.data_files,
        "tuned_parameters": run.params,
    }


def controller_yaml(ctx: ExportContext, samples: dict[str, int]) -> str:
    """controller.yaml: everything needed to drive the exported model as the run did, without simtune."""
    params = ctx.params
    tasks = {task.name: _task_control(ctx, task, samples.get(task.name)) for task in ctx.tasks}
    delay = float(params.get("command_delay", 0.0))
    values = ctx.values
    joints = range(1, len(ctx.robot.driven_joints) + 1)
    data = {
        "control": {
            "rate_hz": 1.0 / CONTROL_PERIOD,
            "period_s": CONTROL_PERIOD,
            "joints": list(ctx.robot.driven_joints),
            "command_delay_s": delay,
            "update_phase_s": delay % CONTROL_PERIOD,
            "max_torque_n_m": [float(values[f"max_torque_joint_{i}"]) for i in joints],
            # the encoder model of --space calibrated (zero offsets and compliance 0: the encoders read the true angles)
            "encoders": {
                "zero_offset_deg": [float(params.get(f"joint_offset_{i}", 0.0)) for i in joints],
                "compliance_rad_per_n_m": [float(params.get(f"compliance_joint_{i}", 0.0)) for i in joints],
                "gravity_link_masses_kg": [float(values[f"mass_link_{i}"]) for i in joints],
            },
        },
        "tracking": {
            "link": ctx.robot.wrist_link,
            "marker_offset_m": [float(params.get(f"marker_offset_{a}", 0.0)) for a in "xyz"],
        },
        "tasks": tasks,
    }
    lines = ctx.header(f"controller.yaml: the controller that drove the {ctx.engine} model of this export")
    text = yaml.safe_dump(data, sort_keys=False, default_flow_style=None, width=110)
    return hash_comment(lines + _CONTROLLER_NOTES) + text


def _task_control(ctx: ExportContext, task: TaskSpec, samples: int | None) -> dict:
    """controller.yaml's entry of ``task``: its schedule, gain, delay, velocity clamps, start pose and object."""
    params = ctx.params
    ctl = JointController(task, params)
    starts, table = task.schedule
    return {
        "description": task.description,
        "duration_s": float(task.duration),
        "samples": samples,
        "kp_per_s": float(task.kp),
        # kp_joint_<n>: each joint's own gain (the task's kp where the run did not tune it)
        "kp_joint_per_s": [float(v) for v in ctl.kp],
        # the task's own recording clock (its command_delay_<task> when tasks were tuned together)
        "command_delay_s": ctl.delay,
        "update_phase_s": ctl.phase,
        "max_velocity_deg_s": [  # as the controller takes them (in degrees, converted once)
            float(params.get(f"max_velocity_joint_{i}", task.max_velocity_deg))
            for i in range(1, len(ctx.robot.driven_joints) + 1)
        ],
        "start_pose_deg": [float(v) for v in task.start_pose_deg],
        # the true angles the arm starts at: where its encoders (control.encoders) read the start pose
        "start_angles_deg": [float(v) for v in np.degrees(ctl.start_angles())],
        "schedule": [
            {"start_s": float(s), "targets_deg": [float(v) for v in row]} for s, row in zip(starts, table[1:])
        ],
        # hold: each set-point until the next; linear: ramped from each to the next (the task's interpolation)
        "interpolation": task.interpolation,
        "object": None
        if task.object is None
        else {
            "body": ctx.robot.object,
            "shape": task.object.shape,
            "material": task.object.material,
            "size_m": [float(v) for v in task.object.size],
            "start_position_m": [float(v) for v in task.object.start_position],
            "start_rpy_rad": [float(v) for v in task.object.rpy],
        },
    }


#: controller.yaml's comment on how the run drove the model
_CONTROLLER_NOTES = [
    "",
    "How the run drove the model (simtune's controller, written out so that any program can do the same):",
    "- control.joints are driven by velocity motors whose force is limited to control.max_torque_n_m",
    "  (the model files hold the same limits).  At control.rate_hz, for each joint:",
    "    velocity [deg/s] = clamp(kp_joint_per_s * (target - angle), -max_velocity_deg_s, +max_velocity_deg_s)",
    "  sent as the motor's velocity target and held until the next update.",
    "- The controller reads each joint through its encoder (control.encoders; all zero: the true angle):",
    "    encoder = angle + zero_offset_deg - compliance_rad_per_n_m * gravity torque about the joint",
    "  (the static gravity torque [N m] at the present angles, of the model's links with",
    "  gravity_link_masses_kg: the masses of the driven joints' child links, as the model files hold).",
    "- The arm starts at rest at the task's start_angles_deg, where the encoders read start_pose_deg",
    "  (the same angles without an encoder model).  Phase i of the schedule is in force from",
    "  the task's command_delay_s + start_s on; before the first phase the target is the start pose.",
    "  A task's interpolation says what lies between: hold (each phase's targets until the next) or",
    "  linear (ramped from each phase's targets to the next's over the time between their starts).",
    "- Samples are taken at k * period_s (k = 0 .. samples - 1); update k happens update_phase_s later,",
    "  at k * period_s + update_phase_s, from the joint angles at that instant, with the targets in force",
    "  then.  Physics steps are counted so that simulated time stays within half a step of both clocks.",
    "- The fitness compares tracking.link's origin moved by marker_offset_m (in that link's frame) with",
    "  the mean recorded wrist at each sample, plus the object's final position (tasks with an object).",
    "- samples: how many 20 Hz samples the run's recordings of the task span (null if its data is gone).",
    "",
]


def now_utc() -> dt.datetime:
    return dt.datetime.now(dt.UTC)
