"""MuJoCo export: one MJCF per task (robot, floor, the task's object), every tuned value written in.

The generic scene MJCF is edited element by element with the values of the
engine's compiled model after the tuned parameters were applied: body masses
and inertias (scaled together, as the engine does), joint damping, armature and frictionloss, the three
friction coefficients and the contact softness (``solref``/``solimp``, MuJoCo's
defaults: simtune does not tune them) of every geom, the velocity servos' force
ranges and gains, and the time step.  Values are written with 17 significant digits, so
the file compiles to the very model the run simulated.

MJCF gives a joint one damping value, but the engine damps an object's
translation and rotation separately (``linear_damping_*``, ``angular_damping_*``
on the free joint's six degrees of freedom).  When the two differ, the object's
free joint is written as three slide joints along the world axes (``ref`` = its
start position, so their positions are the world coordinates of the object's
origin) and a ball joint (its orientation relative to the start orientation):
the same six degrees of freedom, seven position coordinates and damping per
degree of freedom.

A robot read from an MJCF file is attached to the scene as MuJoCo's model editor (``MjSpec``) builds it, with its
own default classes, unnamed geoms and asset folders, which MuJoCo cannot write back as one loadable MJCF: its
export is the tuned, compiled model itself, ``scene_<task>.mjb`` (MuJoCo's binary model, read with
``mujoco.MjModel.from_binary_path`` by the MuJoCo version that wrote it), every body, joint and servo the run
simulated, each value as it simulated it.
"""

from __future__ import annotations

import xml.etree.ElementTree as ET

import mujoco
import numpy as np

from simtune.engines.export_base import ExportContext, hash_comment, num, nums, xml_comment
from simtune.errors import SimtuneError

#: the export's loader, as the other engines' exports have one
SCRIPT = "load_mujoco.py"


def write(ctx: ExportContext) -> list[str]:
    names = _scenes(ctx)
    ctx.write(SCRIPT, hash_comment(ctx.header("load_mujoco.py: load this export in MuJoCo")) + _SCRIPT)
    return [*names, SCRIPT]


def _scenes(ctx: ExportContext) -> list[str]:
    names = []
    for task in ctx.tasks:
        engine = ctx.engines[task.name]
        if ctx.robot.description.mjcf is not None:  # the tuned model as it was compiled (see the module's notes)
            name = f"scene_{task.name}.mjb"
            mujoco.mj_saveModel(engine.model, str(ctx.claim(name)), None)  # type: ignore[attr-defined]
            names.append(name)
            continue
        name = f"scene_{task.name}.xml"
        root = ET.fromstring(ctx.robot.scene_mjcf(task.object))
        _write_values(root, engine.model)  # type: ignore[attr-defined]
        lines = ctx.header(
            f"MJCF of the tuned {ctx.robot.name} scene for task {task.name!r}: load with mujoco.MjModel.from_xml_path"
        )
        lines.append(f"Drive it with controller.yaml (actuators named after the joints they drive: {name}).")
        ctx.write(name, xml_comment(lines) + ET.tostring(root, encoding="unicode") + "\n")
        names.append(name)
    return names


def _write_values(root: ET.Element, model) -> None:
    option = root.find("option")
    if option is None:
        option = ET.SubElement(root, "option")
    option.set("timestep", num(model.opt.timestep))
    world = root.find("worldbody")
    if world is None:
        raise SimtuneError("the scene MJCF has no worldbody")
    for element in world.iter():
        if element.tag in ("body", "joint", "freejoint", "geom") and not element.get("name"):
            raise SimtuneError(f"the scene MJCF has a {element.tag} without a name: export finds elements by name")
    for body in world.iter("body"):
        b = model.body(body.get("name")).id
        inertial = body.find("inertial")
        if inertial is None:  # mass and inertia came from the geoms: write the tuned ones explicitly
            inertial = ET.Element("inertial", pos=nums(model.body_ipos[b]), quat=nums(model.body_iquat[b]))
            inertial.tail = body.text
            body.insert(0, inertial)
            for geom in body.findall("geom"):
                for attr in ("mass", "density"):
                    geom.attrib.pop(attr, None)
        elif "fullinertia" in inertial.attrib:  # the compiled inertia is diagonal in body_iquat's frame
            del inertial.attrib["fullinertia"]
            inertial.set("quat", nums(model.body_iquat[b]))
        inertial.set("mass", num(model.body_mass[b]))
        inertial.set("diaginertia", nums(model.body_inertia[b]))
        for kind in ("joint", "freejoint"):
            for joint in list(body.findall(kind)):
                _write_joint(body, joint, model)
    for geom in world.iter("geom"):
        g = model.geom(geom.get("name")).id
        geom.set("friction", nums(model.geom_friction[g]))
        geom.set("solref", nums(model.geom_solref[g]))
        geom.set("solimp", nums(model.geom_solimp[g]))
    actuators = root.find("actuator")
    for actuator in actuators if actuators is not None else []:
        a = model.actuator(actuator.get("name")).id
        actuator.set("forcerange", nums(model.actuator_forcerange[a]))
        if actuator.tag == "velocity":  # servo_gain_joint_<n>: the gain the run simulated
            actuator.set("kv", num(model.actuator_gainprm[a, 0]))


def _write_joint(body: ET.Element, joint: ET.Element, model) -> None:
    j = model.joint(joint.get("name")).id
    dof = model.jnt_dofadr[j]
    free = joint.tag == "freejoint" or joint.get("type") == "free"
    if not free:
        joint.set("damping", num(model.dof_damping[dof]))
        # the drive train's kinds (simtune.params.kinds): the armature and Coulomb friction the run simulated
        joint.set("armature", num(model.dof_armature[dof]))
        joint.set("frictionloss", num(model.dof_frictionloss[dof]))
        return
    damping = model.dof_damping[dof : dof + 6]
    index = list(body).index(joint)
    body.remove(joint)
    if np.all(damping == damping[0]):  # one value: MJCF's free joint holds it (<freejoint> takes no damping)
        body.insert(index, ET.Element("joint", name=joint.get("name", ""), type="free", damping=num(damping[0])))
        return
    start = model.body_pos[model.jnt_bodyid[j]]
    turn = model.body_quat[model.jnt_bodyid[j]]
    rotation = np.zeros(9)
    _quat_to_matrix(turn, rotation)
    axes = rotation.reshape(3, 3).T  # world x, y, z in the body's frame, where MJCF gives joint axes
    elements = [
        ET.Element(
            "joint",
            name=f"{joint.get('name')}_{axis}",
            type="slide",
            axis=nums(axes[:, k]),
            ref=num(start[k]),
            damping=num(damping[k]),
        )
        for k, axis in enumerate("xyz")
    ]
    # a ball joint has one damping for its three rotational DOFs: they are equal (one parameter)
    elements.append(ET.Element("joint", name=joint.get("name", ""), type="ball", damping=num(damping[3])))
    for offset, element in enumerate(elements):
        element.tail = joint.tail
        body.insert(index + offset, element)


def _quat_to_matrix(quat, out) -> None:
    import mujoco

    mujoco.mju_quat2Mat(out, np.asarray(quat, dtype=float))


_SCRIPT = '''"""Load the tuned MuJoCo scene of one task (scene_<task>.xml, or scene_<task>.mjb for a robot read from
an MJCF file) and drive it as controller.yaml says, with MuJoCo, NumPy and PyYAML only.

    python load_mujoco.py TASK           # let the arm stand one second at its start pose; print where its wrist is
    python load_mujoco.py TASK --drive   # run the task's own schedule; print the wrist at its end

From Python, ``drive(task, schedule)`` runs any new motion: ``schedule`` a list of (start_s, targets_deg).
"""

import math
import pathlib
import sys

import mujoco
import numpy as np

HERE = pathlib.Path(__file__).resolve().parent


def load(task):
    """The tuned model of ``task`` and a data for it at the model's reference pose: (model, data)."""
    xml, mjb = HERE / f"scene_{task}.xml", HERE / f"scene_{task}.mjb"
    if not xml.is_file() and not mjb.is_file():
        known = sorted(p.stem[len("scene_"):] for p in HERE.glob("scene_*.*") if p.suffix in (".xml", ".mjb"))
        raise SystemExit(f"{HERE}: no scene of task {task!r} (this export has: {', '.join(known)})")
    model = mujoco.MjModel.from_xml_path(str(xml)) if xml.is_file() else mujoco.MjModel.from_binary_path(str(mjb))
    return model, mujoco.MjData(model)


def controller():
    """controller.yaml, read."""
    import yaml

    return yaml.safe_load((HERE / "controller.yaml").read_text())


def drive(task, schedule=None, duration_s=None):
    """Run ``task``'s scene under the run's controller: every 0.05 s (shifted by the command delay's remainder) each
    joint's velocity servo is commanded kp * (target - encoder reading), clamped to the joint's velocity limit, the
    targets those in force a command delay earlier; the encoders read the joint angles plus their zero offsets, less
    each joint's compliance times the gravity torque on it.

    Args:
        task: a task of this export (controller.yaml's ``tasks``).
        schedule: the motion, a list of (start_s, targets_deg) phases (the arm holds its start pose before the
            first); None: the task's own schedule.
        duration_s: how long to run; None: the task's duration, or for a new schedule its last phase's start + 5 s.

    Returns:
        (times [s], joint readings [deg], wrist positions [m]), one row per control period, as simtune samples them.
    """
    control = controller()
    c, t = control["control"], control["tasks"][task]
    model, data = load(task)
    joints = c["joints"]
    qpos = np.array([model.joint(j).qposadr[0] for j in joints])
    dofs = np.array([model.joint(j).dofadr[0] for j in joints])
    servos = np.array([model.actuator(j).id for j in joints])
    wrist = model.body(control["tracking"]["link"]).id
    encoders = c.get("encoders") or {}
    offset = np.radians(encoders.get("zero_offset_deg", [0.0] * len(joints)))
    compliance = np.array(encoders.get("compliance_rad_per_n_m", [0.0] * len(joints)))
    kp = np.array(t["kp_joint_per_s"], dtype=float)
    v_max = np.radians(t["max_velocity_deg_s"])
    delay, phase, period = float(t["command_delay_s"]), float(t["update_phase_s"]), float(c["period_s"])
    own = schedule is None
    phases = [(p["start_s"], p["targets_deg"]) for p in t["schedule"]] if own else list(schedule)
    if duration_s is None:
        duration_s = t["duration_s"] if own else phases[-1][0] + 5.0
    starts = np.array([start for start, _ in phases], dtype=float)
    table = np.radians([t["start_pose_deg"], *(targets for _, targets in phases)])
    still = mujoco.MjData(model)  # the gravity torques: the bias forces of the pose at rest

    def reading():
        q = data.qpos[qpos]
        if not compliance.any():
            return q + offset
        still.qpos[:] = data.qpos
        still.qvel[:] = 0.0
        mujoco.mj_forward(model, still)
        return q + offset + compliance * still.qfrc_bias[dofs]  # bias = minus gravity's torque

    mujoco.mj_resetData(model, data)
    data.qpos[qpos] = np.radians(t["start_angles_deg"])
    mujoco.mj_forward(model, data)
    n = int(round(duration_s / period)) + 1
    dt = model.opt.timestep
    times = np.arange(n) * period
    angles, wrists = np.zeros((n, len(joints))), np.zeros((n, 3))
    t_sim = 0.0
    for k in range(n):
        q = reading()
        angles[k], wrists[k] = q, data.xpos[wrist]
        if k == n - 1:
            break
        if phase:  # on to the controller's update instant, which reads the state there
            steps = int(round((k * period + phase - t_sim) / dt))
            if steps > 0:
                mujoco.mj_step(model, data, nstep=steps)
                t_sim += steps * dt
                q = reading()
        sent = k * period + phase - delay  # when the targets in force now were sent
        row = int(np.searchsorted(starts, sent + 1e-12, side="right"))
        target = table[row]
        if t.get("interpolation") == "linear" and 1 <= row < len(starts):  # ramped towards the next set-point
            share = (sent - starts[row - 1]) / (starts[row] - starts[row - 1])
            target = target + share * (table[row + 1] - target)
        data.ctrl[servos] = np.clip(kp * (target - q), -v_max, v_max)
        steps = max(1, int(round(((k + 1) * period - t_sim) / dt)))
        mujoco.mj_step(model, data, nstep=steps)
        t_sim += steps * dt
    return times, np.degrees(angles), wrists


if __name__ == "__main__":
    control = controller()
    task = sys.argv[1] if len(sys.argv) > 1 else next(iter(control["tasks"]))
    if "--drive" in sys.argv[2:]:
        times, angles, wrists = drive(task)
        print(task, "driven for", times[-1], "s; wrist at", wrists[-1])
        sys.exit(0)
    model, data = load(task)
    start = control["tasks"][task]["start_pose_deg"]
    for joint, angle in zip(control["control"]["joints"], start):
        data.joint(joint).qpos[0] = math.radians(angle)
    # the velocity servos (actuators named after their joints) hold the start pose: zero commanded velocity
    for _ in range(round(1.0 / model.opt.timestep)):
        mujoco.mj_step(model, data)
    print(task, "wrist at", data.body(control["tracking"]["link"]).xpos)
'''
