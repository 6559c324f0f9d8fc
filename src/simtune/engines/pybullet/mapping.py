"""How simtune's parameters become PyBullet settings: read by the engine's reset and by its export alike.

Surfaces and velocity damping go per material group (docs/parameters.md): every body
and link of a group gets the group's values in one ``changeDynamics`` call (Bullet
multiplies the two touching bodies' friction and restitution).  The floor is static,
so its velocity damping means nothing and is left out.
"""

from __future__ import annotations

from simtune.tasks.spec import CONTACT_GROUPS, MATERIALS, ObjectSpec

#: surface parameter kind -> changeDynamics keyword
CONTACT_KEYWORDS = {
    "lateral_friction": "lateralFriction",
    "spinning_friction": "spinningFriction",
    "rolling_friction": "rollingFriction",
    "restitution": "restitution",
}
#: velocity damping parameter kind -> changeDynamics keyword
BODY_DAMPING_KEYWORDS = {"linear_damping": "linearDamping", "angular_damping": "angularDamping"}
DEFAULT_TIMESTEP = 1.0 / 240.0  # Bullet's own default

#: the group parameters PyBullet maps: surfaces of every contact group, damping of the moving ones
GROUP_PARAMETERS = frozenset(
    {f"{kind}_{g}" for kind in CONTACT_KEYWORDS for g in CONTACT_GROUPS}
    | {f"{kind}_{g}" for kind in BODY_DAMPING_KEYWORDS for g in ("gripper", *MATERIALS)}
)


def material_groups(gripper_links: list[str], obj: ObjectSpec | None) -> dict[str, list[tuple[str, str | None]]]:
    """Material group -> the (body, link) pairs it covers, in the order the run changes them: body ``floor``,
    ``robot`` or ``object``, link None for a body's base."""
    groups: dict[str, list[tuple[str, str | None]]] = {
        "floor": [("floor", None)],
        "gripper": [("robot", link) for link in gripper_links],
    }
    if obj is not None:
        groups[obj.material] = [("object", None)]
    return groups


def dynamics_changes(group: str, values: dict[str, float]) -> dict[str, float]:
    """The ``changeDynamics`` keywords of ``group``'s bodies: each of the group's parameters in ``values``."""
    return {
        keyword: values[f"{kind}_{group}"]
        for kind, keyword in {**CONTACT_KEYWORDS, **BODY_DAMPING_KEYWORDS}.items()
        if f"{kind}_{group}" in values
    }


#: Bullet's own velocity damping of every multibody link (``btMultiBody``'s ``m_linearDamping`` and
#: ``m_angularDamping``), the generic value of the ``linear_damping_*`` and ``angular_damping_*`` kinds.
BULLET_LINK_DAMPING = 0.04


def link_damping_torques(robot, speed: float) -> list[float]:
    """Per driven joint, the torque [N m] Bullet's own link damping (:data:`BULLET_LINK_DAMPING`) opposes it with
    while it alone turns at ``speed`` [rad/s]: ``btMultiBody`` damps each link's centre-of-mass velocity v by
    ``k m v (1 + |v|)`` and its angular velocity w by ``k I w (1 + |w|)``, k the damping, in proportion to the link's
    mass and inertia and above what a joint's force limit holds on a heavy arm.  No other engine damps a link."""
    import numpy as np

    k = BULLET_LINK_DAMPING
    frames, axes = robot.driven_axes()
    torques = []
    for name, (axis, origin, below) in zip(robot.arm_joints, axes):
        joint = robot.joint_by_name[name]
        torque = 0.0
        for link_name in below:
            link = robot.link_by_name[link_name]
            pos, rot = frames[link_name]
            lever = np.linalg.norm(np.cross(axis, pos + rot @ np.asarray(link.com, dtype=float) - origin))
            v = speed * lever
            torque += k * link.mass * v * (1 + v) * lever
            torque += k * float(axis @ rot @ link.inertia_matrix() @ rot.T @ axis) * speed * (1 + speed)
        torques.append(torque if joint.kind != "prismatic" else 0.0)
    return torques
