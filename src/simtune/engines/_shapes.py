"""Rigid-body helpers shared by the engines that build the scene themselves (ODE, DART, Drake).

MuJoCo and PyBullet derive masses and inertias from the MJCF/URDF; the
engines here get the same numbers from the task's robot description and from
the task's object spec, computed once, in one place.
"""

from __future__ import annotations

from functools import lru_cache

import numpy as np

from simtune.common.geometry import rpy_matrix
from simtune.robot.description import Box, Cylinder, Mesh, RobotDescription, Sphere, mesh_hull
from simtune.tasks.spec import ObjectSpec


def joint_transform(joint) -> tuple[np.ndarray, np.ndarray]:
    """(translation, rotation) of ``joint``'s frame in its parent link's frame, at angle 0."""
    return np.asarray(joint.xyz, dtype=float), rpy_matrix(joint.rpy)


def host_links(robot: RobotDescription) -> dict[str, tuple[str, np.ndarray, np.ndarray]]:
    """link -> (host link, position, rotation of the link frame in the host's frame).

    The host of a link is the nearest ancestor (or the link itself) that moves on
    its own: the root or the child of a driven joint.  Links welded to it (the
    MICO's fingers on ``link_6``) ride on the host's rigid body.
    """
    root = robot.root
    hosts: dict[str, tuple[str, np.ndarray, np.ndarray]] = {root: (root, np.zeros(3), np.eye(3))}
    for joint in robot.joints:  # parents come before children in the table
        if joint.moves:
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


def host_mass_properties(
    robot: RobotDescription, masses: dict[str, float] | None = None
) -> dict[str, tuple[float, np.ndarray, np.ndarray]]:
    """host link -> (mass, com, inertia about com) in the host link's frame.

    ``masses`` overrides link masses by name (the inertia of an overridden link
    is scaled with its mass, as every engine does for a changed mass).  A host
    whose links are all massless (a bare frame) has no entry.
    """
    masses = masses or {}
    parts: dict[str, list] = {}
    for name, (host, p, r) in host_links(robot).items():
        link = robot.link_by_name[name]
        mass = masses.get(name, link.mass)
        if mass <= 0:
            continue
        inertia = link.inertia_matrix() * (mass / link.mass)
        parts.setdefault(host, []).append((mass, p + r @ np.asarray(link.com), r @ inertia @ r.T))
    return {host: composite_inertia(ps) for host, ps in parts.items()}


def link_shapes_in_host(
    robot: RobotDescription,
) -> dict[str, list[tuple[np.ndarray, np.ndarray, Box | Sphere | Cylinder | Mesh, str]]]:
    """host link -> [(centre, rotation, shape, link name)] of the collision shapes it carries, each placed
    in the host's frame (a mesh's placement is that of its own frame)."""
    out: dict[str, list] = {}
    hosts = host_links(robot)
    for link in robot.links:
        host, p, r = hosts[link.name]
        for shape in link.shapes:
            turn = r if shape.rpy == (0.0, 0.0, 0.0) else r @ rpy_matrix(shape.rpy)
            out.setdefault(host, []).append((p + r @ np.asarray(shape.center), turn, shape, link.name))
    return out


def link_boxes_in_host(robot: RobotDescription) -> dict[str, list[tuple[np.ndarray, np.ndarray, np.ndarray, str]]]:
    """host link -> [(centre, rotation, half sizes, link name)] of the collision boxes it carries."""
    return {
        host: [(c, r, np.asarray(shape.half), link) for c, r, shape, link in shapes if isinstance(shape, Box)]
        for host, shapes in link_shapes_in_host(robot).items()
    }


def hull_faces(vertices: np.ndarray) -> tuple[np.ndarray, list[np.ndarray], np.ndarray]:
    """A convex hull of ``vertices`` as (vertices, faces as outward-ordered index lists, planes (n, d))."""
    from scipy.spatial import ConvexHull

    hull = ConvexHull(vertices)
    points = vertices[hull.vertices]
    hull = ConvexHull(points)
    faces = [np.asarray(simplex) for simplex in hull.simplices]
    planes = []
    for k, (simplex, eq) in enumerate(zip(hull.simplices, hull.equations)):
        a, b, c = points[simplex]
        if np.dot(np.cross(b - a, c - a), eq[:3]) < 0:  # counter-clockwise seen from outside
            faces[k] = simplex[::-1].copy()
        planes.append(np.r_[eq[:3], -eq[3]])
    return points, faces, np.array(planes)


@lru_cache(maxsize=256)  # the scene is rebuilt at every reset: read and hull each mesh once
def mesh_hull_faces(mesh: Mesh) -> tuple[np.ndarray, list[np.ndarray], np.ndarray, np.ndarray]:
    """The convex hull of a mesh shape (scaled) for engines that collide with hulls: (vertices, faces,
    planes, centre), the vertices and planes about the hull's centre (ODE wants its origin inside), which
    lies at ``centre`` in the mesh's own frame."""
    vertices, _ = mesh_hull(mesh)
    centre = vertices.mean(axis=0)
    points, faces, planes = hull_faces(vertices - centre)
    return points, faces, planes, centre


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
