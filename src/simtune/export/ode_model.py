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
from simtune.export.common import ExportContext

SIDECAR = "ode.json"


def _list(a) -> list:
    return np.asarray(a, dtype=float).tolist()


def write(ctx: ExportContext) -> list[str]:
    from simtune.engines import ode_engine

    robot = ctx.robot
    described = robot.description
    values = ctx.values
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
            }
        )
    damping = {
        g: {"linear": float(values[f"linear_damping_{g}"]), "angular": float(values[f"angular_damping_{g}"])}
        for g in ("gripper", "wood", "plastic")
        if f"linear_damping_{g}" in values
    }
    objects = {}
    groups = {"arm", "gripper", "floor"}  # arm: the boxes of links 1-5 and the base, ODE defaults
    for task in ctx.run.tasks:
        obj = task.object
        if obj is None:
            continue
        groups.add(obj.material)
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

    def mean(kind: str, a: str, b: str) -> float:
        default = ode_engine.DEFAULT_CONTACT[kind]
        return float(np.sqrt(values.get(f"{kind}_{a}", default) * values.get(f"{kind}_{b}", default)))

    names = sorted(groups)
    surfaces = [
        {
            "groups": [a, b],
            "mu": mean("lateral_friction", a, b),
            "rho_rolling": mean("rolling_friction", a, b),
            "rhoN_spinning": mean("spinning_friction", a, b),
            "bounce": mean("restitution", a, b),
            "bounce_vel_m_s": ode_engine.BOUNCE_VELOCITY,
        }
        for k, a in enumerate(names)
        for b in names[k:]
    ]
    about = {
        "what": "ODE has no model file format: this file holds every value the tuned run's ODE world was built "
        "with, for a program that builds it (docs/parameters.md, 'ODE'); simtune's ode_engine.py is one such program",
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
    ctx.write_json(
        SIDECAR,
        about,
        {
            "time_step": float(values["timestep"]),
            "stepper": "dWorldStep",
            "gravity": [0.0, 0.0, -9.81],
            "bodies": bodies,
            "joints": joints,
            "body_damping": damping,
            "objects": objects,
            "contact_surfaces": surfaces,
            "default_surface": dict(ode_engine.DEFAULT_CONTACT),
        },
    )
    return ctx.files
