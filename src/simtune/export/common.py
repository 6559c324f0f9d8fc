"""What every engine's export shares: provenance, the header comment, controller.yaml, number formatting.

Every exported file names where it comes from: XML files and scripts in a
header comment, JSON sidecars in a ``provenance`` member, and the folder as a
whole in ``provenance.json`` (which also lists each file with its SHA-256).
"""

from __future__ import annotations

import datetime as dt
import hashlib
import json
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import yaml

import simtune
from simtune.controller import CONTROL_PERIOD, JointController
from simtune.engines import Engine, engine_class
from simtune.export.source import TunedRun
from simtune.robot import description, generate
from simtune.tasks.spec import ObjectSpec, TaskSpec

PROVENANCE_FILE = "provenance.json"
CONTROLLER_FILE = "controller.yaml"


@dataclass(frozen=True)
class RobotDescription:
    """The robot as export sees it: names and the generic model files, never the engines' internals.

    Every exporter takes the robot from here, so a robot described another way (a
    URDF of the user's) needs only another constructor, not other exporters.
    Tuning parameter ``<kind>_<i>`` of a joint or link (``joint_damping_3``,
    ``mass_link_3``) belongs to the i-th driven joint and to that joint's child link.
    """

    name: str
    driven_joints: tuple[str, ...]
    driven_links: tuple[str, ...]  # the child link of each driven joint
    wrist_link: str
    base_link: str
    base_position: tuple[float, float, float]
    urdf: str  # the robot alone, with generic values, base frame at the origin
    link_materials: dict[str, str]  # link -> material group of the friction/restitution parameters
    floor: str  # names of the floor and object elements in the scenes the engines build
    object: str
    description: description.RobotDescription  # the robot the engines built

    def scene_mjcf(self, obj: ObjectSpec | None) -> str:
        """The MuJoCo scene (robot, floor, the task's object) with generic values."""
        return generate.scene_mjcf(self.description, obj)


def exported_robot(robot: description.RobotDescription) -> RobotDescription:
    """The robot as exporters see it, from the description the engines built the run's tasks with."""
    return RobotDescription(
        name=robot.name,
        driven_joints=tuple(robot.arm_joints),
        driven_links=robot.driven_links,
        wrist_link=robot.tracked_link,
        base_link=robot.root,
        base_position=tuple(float(v) for v in robot.base_position),  # type: ignore[arg-type]
        urdf=generate.robot_urdf(robot),
        link_materials={link.name: link.material for link in robot.links},
        floor=generate.FLOOR,
        object=generate.OBJECT_BODY,
        description=robot,
    )


def num(value: float) -> str:
    """A float written so that parsing it gives the same double back (Python's shortest round-trip form)."""
    return repr(float(value))


def nums(values) -> str:
    return " ".join(num(v) for v in np.asarray(values, dtype=float).ravel())


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
        "space": run.config.get("space"),
        "seed": run.config.get("seed"),
        "optimizer": run.config.get("optimizer", "de"),
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
        "data": str(run.config.get("data")),
        "data_note": run.data_note,
        "data_files": run.data_files,
        "tuned_parameters": run.params,
    }


def header_lines(prov: dict, what: str) -> list[str]:
    """The provenance as comment lines (without comment markers); values are JSON, so they parse back exactly."""
    j = json.dumps
    fitness = prov["fitness"]
    lines = [
        f"{what}",
        f"Exported by {prov['exported_by']} on {prov['date']} from a tuned run; provenance.json has the full record.",
        f"run: {j(prov['run'])}",
        f"engine: {j(prov['engine'])} {j(prov['engine_version'])} (run tuned with {j(prov['engine_version_of_run'])})",
        f"simtune: {j(prov['simtune_version'])}",
        f"tasks: {j(prov['tasks'])}  space: {j(prov['space'])}  seed: {j(prov['seed'])}  "
        f"optimizer: {j(prov['optimizer'])}  evaluations: {prov['evaluations']}",
        f"tuned fitness: {j(fitness)} m (wrist {j(prov['wrist_error'])} m, object {j(prov['object_error'])} m; "
        f"generic {j(prov['generic_fitness'])} m)",
        f"command: {j(prov['command'])}",
        f"data: {j(prov['data'])} ({prov['data_note']})",
    ]
    for task, files in prov["data_files"].items():
        lines += [f"data file: {j(task + '/' + f['file'])} {f['bytes']} bytes sha256 {f['sha256']}" for f in files]
    return lines


def xml_comment(lines: list[str]) -> str:
    # "--" may not appear inside an XML comment: it is written as "-\u002d", which JSON reads back as "--"
    body = "\n".join("  " + line.replace("--", "-\\u002d") for line in lines)
    return f"<!--\n{body}\n-->\n"


def hash_comment(lines: list[str]) -> str:
    return "".join(f"# {line}\n" if line else "#\n" for line in lines)


@dataclass
class ExportContext:
    """One export in progress: the run, the folder, and one engine per task with the tuned values applied."""

    run: TunedRun
    engine: str
    robot: RobotDescription
    out: Path
    engines: dict[str, Engine]  # task name -> engine after reset(values)
    values: dict[str, float]  # every engine parameter in force: the engine's generic values, then the tuned
    provenance: dict
    files: list[str] = field(default_factory=list)

    def header(self, what: str) -> list[str]:
        return header_lines(self.provenance, what)

    def write(self, name: str, text: str) -> Path:
        path = self.out / name
        path.write_text(text)
        if name not in self.files:
            self.files.append(name)
        return path

    def write_json(self, name: str, about: dict, body: dict) -> Path:
        """A JSON sidecar: ``about`` (what each member means), ``provenance``, then ``body``."""
        data = {"about": about, "provenance": self.provenance, **body}
        return self.write(name, json.dumps(data, indent=2) + "\n")


def write_cone_mesh(ctx: ExportContext, obj, task: str) -> str:
    """Write the convex hull of a cone object (the run's collision shape) as ``object_<task>.obj``; its name."""
    from simtune.engines._shapes import cone_hull

    vertices, faces, _ = cone_hull(obj)
    name = f"object_{task}.obj"
    lines = [f"v {num(x)} {num(y)} {num(z)}" for x, y, z in vertices]
    lines += ["f " + " ".join(str(int(i) + 1) for i in face) for face in faces]
    header = hash_comment(ctx.header(f"convex hull of task {task!r}'s cone (the run's collision shape)"))
    ctx.write(name, header + "\n".join(lines) + "\n")
    return name


def controller_yaml(ctx: ExportContext, samples: dict[str, int]) -> str:
    """controller.yaml: everything needed to drive the exported model as the run did, without simtune."""
    params = ctx.run.params
    tasks = {task.name: _task_control(ctx, task, samples.get(task.name)) for task in ctx.run.tasks}
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
    params = ctx.run.params
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
