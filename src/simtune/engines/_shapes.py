"""Rigid-body helpers shared by the engines that build the scene themselves (ODE, DART, Drake).

MuJoCo and PyBullet derive masses and inertias from the MJCF/URDF; the
engines here get the same numbers from :mod:`simtune.robot.mico` and from
the task's object spec, computed once, in one place.
"""

from __future__ import annotations

import numpy as np

from simtune.geometry import rpy_matrix
from simtune.robot.mico import JOINTS, LINK_BY_NAME, LINKS
from simtune.tasks.spec import ObjectSpec


def joint_transform(joint) -> tuple[np.ndarray, np.ndarray]:
    """(translation, rotation) of ``joint``'s frame in its parent link's frame, at angle 0."""
    return np.asarray(joint.xyz, dtype=float), rpy_matrix(joint.rpy)


def host_links() -> dict[str, tuple[str, np.ndarray, np.ndarray]]:
    """link -> (host link, position, rotation of the link frame in the host's frame).

    The host of a link is the nearest ancestor (or the link itself) that moves on
    its own: ``link_base`` or the child of an arm joint.  Links welded to it (the
    fingers on ``link_6``) ride on the host's rigid body.
    """
    hosts: dict[str, tuple[str, np.ndarray, np.ndarray]] = {"link_base": ("link_base", np.zeros(3), np.eye(3))}
    for joint in JOINTS:  # parents come before children in the table
        if joint.kind != "fixed":
            hosts[joint.child] = (joint.child, np.zeros(3), np.eye(3))
        else:
            host, p, r = hosts[joint.parent]
            t, rj = joint_transform(joint)
            hosts[joint.child] = (host, p + r @ t, r @ rj)
    return hosts


def composite_inertia(parts) -> tuple[float, np.ndarray, np.ndarray]:
    """Total mass, centre of mass and inertia about it of rigid ``parts``.

    ``parts``: (mass, com, inertia 3x3 about its com) in one common frame.
    """
    total = sum(m for m, _, _ in parts)
    com = sum(m * np.asarray(c) for m, c, _ in parts) / total
    inertia = np.zeros((3, 3))
    for m, c, i in parts:
        d = np.asarray(c) - com
        inertia += i + m * (d @ d * np.eye(3) - np.outer(d, d))
    return total, com, inertia


def host_mass_properties(masses: dict[str, float] | None = None) -> dict[str, tuple[float, np.ndarray, np.ndarray]]:
    """host link -> (mass, com, inertia about com) in the host link's frame.

    ``masses`` overrides link masses by name (the inertia of an overridden link
    is scaled with its mass, as every engine does for a changed mass).
    """
    masses = masses or {}
    parts: dict[str, list] = {}
    for name, (host, p, r) in host_links().items():
        link = LINK_BY_NAME[name]
        mass = masses.get(name, link.mass)
        inertia = np.diag(link.inertia) * (mass / link.mass)
        parts.setdefault(host, []).append((mass, p + r @ np.asarray(link.com), r @ inertia @ r.T))
    return {host: composite_inertia(ps) for host, ps in parts.items()}


def link_boxes_in_host() -> dict[str, list[tuple[np.ndarray, np.ndarray, np.ndarray, str]]]:
    """host link -> [(centre, rotation, half sizes, link name)] of the collision boxes it carries."""
    out: dict[str, list] = {}
    hosts = host_links()
    for link in LINKS:
        host, p, r = hosts[link.name]
        for box in link.boxes:
            out.setdefault(host, []).append((p + r @ np.asarray(box.center), r, np.asarray(box.half), link.name))
    return out


def object_mass_properties(obj: ObjectSpec, mass: float | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Centre of mass and inertia about it (3x3) of the solid object, in its shape frame."""
    m = obj.mass if mass is None else mass
    if obj.shape in ("cube", "cuboid"):
        x, y, z = obj.size
        return np.zeros(3), np.diag([m * (y * y + z * z), m * (x * x + z * z), m * (x * x + y * y)]) / 12.0
    if obj.shape == "cylinder":
        r, h = obj.size
        side = m * (3 * r * r + h * h) / 12.0
        return np.zeros(3), np.diag([side, side, m * r * r / 2.0])
    # solid cone, apex up, origin at the centre of its bounding box: the centre of mass
    # lies a quarter of the height above the base
    r, h = obj.size
    side = m * (3 * r * r / 20.0 + 3 * h * h / 80.0)
    return np.array([0.0, 0.0, -h / 4.0]), np.diag([side, side, 3 * m * r * r / 10.0])


def cone_hull(obj: ObjectSpec) -> tuple[np.ndarray, list[np.ndarray], np.ndarray]:
    """The cone's convex hull (the same 24-segment hull as MuJoCo and PyBullet use).

    Returns (vertices, faces as outward-ordered vertex index lists, planes (n, d) with n . x = d).
    """
    from scipy.spatial import ConvexHull

    vertices = obj.cone_vertices()
    hull = ConvexHull(vertices)
    # merge Qhull's triangles into polygons by plane (the base is one 24-gon)
    planes: list[np.ndarray] = []
    faces: list[list[int]] = []
    for simplex, eq in zip(hull.simplices, hull.equations):
        n, d = eq[:3], -eq[3]
        for k, p in enumerate(planes):
            if np.allclose(p, np.r_[n, d], atol=1e-9):
                faces[k].extend(int(i) for i in simplex if int(i) not in faces[k])
                break
        else:
            planes.append(np.r_[n, d])
            faces.append([int(i) for i in simplex])
    ordered = []
    for face, plane in zip(faces, planes):
        pts = vertices[face]
        centre = pts.mean(axis=0)
        n = plane[:3]
        u = pts[0] - centre
        u /= np.linalg.norm(u)
        v = np.cross(n, u)
        angles = np.arctan2((pts - centre) @ v, (pts - centre) @ u)
        ordered.append(np.asarray(face)[np.argsort(angles)])  # counter-clockwise seen from outside
    return vertices, ordered, np.array(planes)
