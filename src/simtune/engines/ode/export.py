"""ODE export: ``ode.json`` only.  ODE has no model file format: a program builds its world in code.

The sidecar holds every value the tuned run's ODE world was built with, in
ODE's own terms, so that a program can build the same world: the time step
and stepper, one rigid body per moving link (mass, centre of mass and inertia
in the link frame; the welded fingers ride on the hand's body), the collision
boxes on each body, the hinge joints with their velocity motors (force
limits) and stops, the viscous joint damping simtune adds as a torque, the
object, the per-body velocity damping, and the contact surface of every pair
of material groups (already combined: the geometric mean of the two groups'
values, as the run's near callback did).
"""

from __future__ import annotations

import numpy as np

from simtune.engines._shapes import cone_hull, host_mass_properties, link_boxes_in_host, object_mass_properties
from simtune.engines.export_base import ExportContext, RobotDescription
from simtune.engines.ode.mapping import BOUNCE_VELOCITY, DEFAULT_CONTACT, pair_surface

SIDECAR = "ode.json"


def _list(a) -> list:
    return np.asarray(a, dtype=float).tolist()


def write(ctx: ExportContext) -> list[str]:
    robot = ctx.robot
    values = ctx.values
    damping = {
        g: {"linear": float(values[f"linear_damping_{g}"]), "angular": float(values[f"angular_damping_{g}"])}
        for g in ("gripper", "wood", "plastic")
        if f"linear_damping_{g}" in values
    }
    objects = _objects(ctx)
    # arm: the boxes of links 1-5 and the base, ODE defaults
    groups = {"arm", "gripper", "floor"} | {entry["material"] for entry in objects.values()}
    ctx.write_json(
        SIDECAR,
        _ABOUT,
        {
            "time_step": float(values["timestep"]),
            "stepper": "dWorldStep",
            "gravity": [0.0, 0.0, -9.81],
            "bodies": _bodies(robot, values),
            "joints": _joints(robot, values),
            "body_damping": damping,
            "objects": objects,
            "contact_surfaces": _surfaces(sorted(groups), values),
            "default_surface": dict(DEFAULT_CONTACT),
        },
    )
    return ctx.files


def _bodies(robot: RobotDescription, values: dict[str, float]) -> dict[str, dict]:
    """One rigid body per moving link's host (the base static), with its mass properties and collision boxes."""
    described = robot.description
    masses = {link: values[f"mass_link_{i}"] for i, link in enumerate(robot.driven_links, start=1)}
    zero = np.zeros(len(robot.driven_joints))
    bodies = {}
    for host, (mass, com, inertia) in host_mass_properties(described, masses).items():
        pos, rot = described.forward_kinematics(zero, host)
        bodies[host] = {
            "static": host == robot.base_link,
            "mass_kg": float(mass),
            "com_in_link_m": _list(com),
            "inertia_about_com_in_link": _list(inertia),
            "link_frame_at_zero": {"position_m": _list(pos), "rotation": _list(rot)},
            "boxes": [
                {"link": link, "centre_in_link_m": _list(c), "rotation_in_link": _list(r), "size_m": _list(2 * h)}
                for c, r, h, link in link_boxes_in_host(described).get(host, [])
            ],
        }
    return bodies


def _joints(robot: RobotDescription, values: dict[str, float]) -> list[dict]:
    """The driven joints' hinges, defined at angle 0, with their motors' force limits and damping."""
    described = robot.description
    zero = np.zeros(len(robot.driven_joints))
    joints = []
    by_name = described.joint_by_name
    for i, name in enumerate(robot.driven_joints, start=1):
        joint = by_name[name]
        pos, rot = described.forward_kinematics(zero, joint.child)
        joints.append(
            {
                "name": name,
                "parent": joint.parent,
                "child": joint.child,
                "anchor_at_zero_m": _list(pos),
                "axis_at_zero": _list(rot[:, 2]),
                "stops_rad": [joint.lower, joint.upper] if joint.limited else None,
                "motor_fmax_n_m": float(values[f"max_torque_joint_{i}"]),
                "viscous_damping_n_m_s": float(values[f"joint_damping_{i}"]),
                # friction_joint_<n>: an angular motor on the hinge's axis, target velocity 0, dParamFMax = this
                "coulomb_friction_n_m": float(values[f"friction_joint_{i}"]),
            }
        )
    return joints


def _objects(ctx: ExportContext) -> dict[str, dict]:
    """Each task's object body (mass properties, start pose, a cone's convex hull), by task."""
    values = ctx.values
    objects = {}
    for task in ctx.tasks:
        obj = task.object
        if obj is None:
            continue
        mass = values[obj.mass_parameter]
        com, inertia = object_mass_properties(obj, mass)
        entry = {
            "shape": obj.shape,
            "size_m": _list(obj.size),
            "material": obj.material,
            "mass_kg": float(mass),
            "com_in_shape_m": _list(com),
            "inertia_about_com": _list(inertia),
            "start_position_m": _list(obj.start_position),
            "start_rotation": _list(obj.rotation),
        }
        if obj.shape == "cone":
            vertices, faces, planes = cone_hull(obj)
            entry["convex_hull"] = {
                "vertices_m": _list(vertices),
                "faces": [[int(i) for i in f] for f in faces],
                "planes": _list(planes),
            }
        objects[task.name] = entry
    return objects


def _surfaces(names: list[str], values: dict[str, float]) -> list[dict]:
    """The contact surface of every pair of material groups ``names`` (sorted), as the run's near callback made it."""
    return [
        {
            "groups": [a, b],
            "mu": surface.mu,
            "rho_rolling": surface.rolling,
            "rhoN_spinning": surface.spinning,
            "bounce": surface.bounce,
            "bounce_vel_m_s": BOUNCE_VELOCITY,
        }
        for k, a in enumerate(names)
        for b in names[k:]
        for surface in [pair_surface(values, a, b)]
    ]


_ABOUT = {
    "what": "ODE has no model file format: this file holds every value the tuned run's ODE world was built "
    "with, for a program that builds it (docs/parameters.md, 'ODE'); simtune's engines/ode/engine.py is one "
    "such program",
    "time_step": "seconds per dWorldStep (the exact LCP stepper; dWorldQuickStep drifts with these hard motors)",
    "bodies": "one rigid body per moving link (static: body-less geoms), keyed by link; its origin is the centre "
    "of mass (ODE's rule), turned like the link frame; inertia 3x3 about the centre of mass in the link frame; "
    "boxes: its collision boxes; link_frame_at_zero: the link frame in the world with all joints at 0",
    "joints": "hinges, defined at joint angle 0 (anchor, axis in the world), velocity motor (dParamVel = the "
    "commanded velocity, dParamFMax), stops (dParamLoStop/HiStop), and the viscous damping applied as "
    "dJointAddHingeTorque(-d * rate) before each step (ODE's hinge has none)",
    "body_damping": "dBodySetLinearDamping / dBodySetAngularDamping of the hand's body (gripper) and the object",
    "objects": "per task: the object body (mass, centre of mass and inertia in the shape frame, start pose)",
    "contact_surfaces": "dSurfaceParameters for each pair of material groups (arm: the boxes of the base and "
    "links 1-5, which keep the defaults): mode dContactApprox1, plus dContactRolling when a rolling "
    "or spinning value is > 0 (rho = rho2 = rho_rolling, rhoN), dContactBounce when bounce > 0",
    "collision": "categories: arm boxes touch the floor and the object, never each other",
}
