"""A robot described once: links, joints, collision shapes, what is driven and what is tracked.

Every engine, the controller, the model-file writers and the parameter spaces read
a :class:`RobotDescription`, never a particular arm's tables, so one description
(the bundled MICO of :mod:`simtune.robot.mico`, or a URDF read by
:func:`simtune.robot.urdf.load_urdf`) builds the same robot in all engines.

Conventions are URDF's: a joint frame is its parent link's frame moved by ``xyz``
then turned by ``rpy`` (roll about x, pitch about y, yaw about z, applied as
Rz @ Ry @ Rx); a revolute joint turns its child about ``axis`` (in the joint
frame), a prismatic one slides it along ``axis``.  A link's inertia is about its
centre of mass, in the inertial frame turned by ``inertia_rpy`` from the link frame.

Only the driven joints move.  Every other joint is fixed: joints the source
declares fixed, and movable joints held at a pose (a gripper's fingers), which
the loader turns into fixed joints at that pose (:attr:`RobotDescription.held`
remembers them).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from functools import cached_property

import numpy as np

from simtune.common.geometry import rpy_matrix

#: Standard gravity [m/s^2], as every engine's scene has it (along -z).
GRAVITY = 9.81
#: A joint described without a force limit gets at least this multiple of the largest gravity load it carries (it
#: must hold the arm up and still accelerate it).
LOAD_MARGIN = 2.0

Vec3 = tuple[float, float, float]
ZERO3: Vec3 = (0.0, 0.0, 0.0)


@dataclass(frozen=True)
class Box:
    """A collision box in its link's frame: centre, half sizes, and its turn from the link frame."""

    center: Vec3
    half: Vec3
    rpy: Vec3 = ZERO3

    @classmethod
    def spanning(cls, lo: Vec3, hi: Vec3) -> Box:
        c = tuple((a + b) / 2 for a, b in zip(lo, hi))
        h = tuple((b - a) / 2 for a, b in zip(lo, hi))
        return cls(c, h)  # type: ignore[arg-type]


@dataclass(frozen=True)
class Sphere:
    center: Vec3
    radius: float
    rpy: Vec3 = ZERO3


@dataclass(frozen=True)
class Cylinder:
    """A cylinder along its own z axis, centred on ``center``."""

    center: Vec3
    radius: float
    length: float
    rpy: Vec3 = ZERO3


@dataclass(frozen=True)
class Mesh:
    """A mesh file (absolute path), scaled per axis, placed at ``center``/``rpy`` in its link's frame.

    Engines that cannot collide with a mesh use its convex hull (:func:`mesh_hull`).
    """

    path: str
    scale: Vec3 = (1.0, 1.0, 1.0)
    center: Vec3 = ZERO3
    rpy: Vec3 = ZERO3


Shape = Box | Sphere | Cylinder | Mesh


@dataclass(frozen=True)
class Link:
    name: str
    mass: float
    com: Vec3
    inertia: Vec3  # ixx, iyy, izz about the centre of mass, in the inertial frame
    shapes: tuple[Shape, ...] = ()
    #: material group used by the friction/restitution parameters ("arm" or "gripper")
    material: str = "arm"
    products: Vec3 = ZERO3  # ixy, ixz, iyz
    inertia_rpy: Vec3 = ZERO3  # the inertial frame's turn from the link frame
    #: what the link is, for parameter descriptions ("hand with gripper"); default its name
    label: str = ""

    @property
    def boxes(self) -> tuple[Box, ...]:
        return tuple(s for s in self.shapes if isinstance(s, Box))

    def inertia_matrix(self) -> np.ndarray:
        """The 3x3 inertia about the centre of mass, in the link frame."""
        ixy, ixz, iyz = self.products
        if self.products == ZERO3:
            inertia = np.diag(self.inertia)
        else:
            ixx, iyy, izz = self.inertia
            inertia = np.array([[ixx, ixy, ixz], [ixy, iyy, iyz], [ixz, iyz, izz]], dtype=float)
        if self.inertia_rpy != ZERO3:
            r = rpy_matrix(self.inertia_rpy)
            inertia = r @ inertia @ r.T
        return inertia

    @property
    def diagonal_inertia(self) -> bool:
        """Whether the inertia is diagonal in the link frame as written (no products, no turned frame)."""
        return self.products == ZERO3 and self.inertia_rpy == ZERO3


JOINT_KINDS = ("revolute", "continuous", "prismatic", "fixed")


@dataclass(frozen=True)
class Joint:
    name: str
    kind: str  # one of JOINT_KINDS
    parent: str
    child: str
    xyz: Vec3
    rpy: Vec3
    axis: Vec3 = (0.0, 0.0, 1.0)
    lower: float | None = None  # position limits [rad or m]; None = unlimited
    upper: float | None = None
    effort: float | None = None  # the source's force/torque limit [N m or N]; None = not given
    velocity: float | None = None  # the source's velocity limit [rad/s or m/s]; None = not given
    damping: float = 0.0  # viscous damping [N m s/rad]
    friction: float = 0.0  # Coulomb friction [N m] (URDF <dynamics friction>)
    armature: float = 0.0  # rotor inertia added about the axis [kg m^2] (an MJCF file's armature; URDF has none)

    @property
    def moves(self) -> bool:
        return self.kind != "fixed"

    @property
    def limited(self) -> bool:
        return self.lower is not None and self.upper is not None

    def motion(self, q: float) -> tuple[np.ndarray, np.ndarray]:
        """(translation, rotation) of the child frame in the joint frame at position ``q``."""
        axis = np.asarray(self.axis, dtype=float)
        if self.kind == "prismatic":
            return axis * q, np.eye(3)
        return np.zeros(3), axis_angle_matrix(axis, q)


def axis_angle_matrix(axis: np.ndarray, angle: float) -> np.ndarray:
    """Rotation by ``angle`` about the unit ``axis`` (exactly the z-rotation matrix for axis z)."""
    c, s = np.cos(angle), np.sin(angle)
    if axis[0] == 0.0 and axis[1] == 0.0 and axis[2] == 1.0:
        return np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]])
    x, y, z = axis / np.linalg.norm(axis)
    k = np.array([[0, -z, y], [z, 0, -x], [-y, x, 0]])
    return np.eye(3) + s * k + (1 - c) * (k @ k)


@dataclass(frozen=True)
class RobotDescription:
    """One robot: links and joints as a tree from ``root``, the driven joints in order, the tracked link.

    ``arm_joints`` are the joints the controller drives, in the order of the task's targets and
    of the per-joint parameters (``mass_link_<n>`` is the child link of ``arm_joints[n-1]``).
    ``tracked_link`` is the link whose frame origin the motion capture follows.
    """

    name: str
    links: tuple[Link, ...]
    joints: tuple[Joint, ...]  # parents before children
    arm_joints: tuple[str, ...]
    tracked_link: str
    base_position: Vec3 = ZERO3
    base_rpy: Vec3 = ZERO3
    #: joints the source declares movable that are held at a fixed pose (name, position)
    held: tuple[tuple[str, float], ...] = ()
    #: masses [kg] the ``mass_link_<n>`` ranges are relative to; default the driven links' own masses
    nominal_masses: tuple[float, ...] | None = None
    #: where the description comes from (a URDF path, or "bundled")
    source: str = "bundled"
    #: the robot's generic velocity-servo/motor force limit per driven joint when its source gives none [N m]
    default_effort: float = 100.0
    #: an MJCF file the robot comes from: the MuJoCo-family engines build the robot from it; the others from the
    #: URDF this description generates
    mjcf: str | None = None
    #: the gain of the velocity servos that drive the joints in MuJoCo and Drake [N m s/rad] (None: each
    #: engine's own, MuJoCo 50, Drake 100).  Such a servo lags its command by about the joint's inertia
    #: over the gain: a heavier arm than the MICO needs a stiffer servo to follow as a real arm's velocity
    #: loop does (PyBullet, ODE and DART drive velocities as constraints, without that lag).
    servo_gain: float | None = None
    #: the range of the controller's velocity clamp (``max_velocity_joint_<n>``) [deg/s] a project states
    #: (``[robot] max_velocity_deg = [low, high]``); None: from the description (each joint's velocity limit)
    max_velocity_range: tuple[float, float] | None = None
    #: links whose mass and inertia the source does not give, estimated from their geometry (a URDF link without
    #: an ``<inertial>``: :mod:`simtune.robot.inertia`); their ``mass_link_<n>`` is tuned in the extended space
    estimated_masses: tuple[str, ...] = ()
    #: links that move with no mass and no geometry to estimate one from: a placeholder mass
    #: (``simtune.robot.urdf.FLOOR_MASS``), so the robot cannot be simulated as described
    placeholder_masses: tuple[str, ...] = ()
    #: what the loader chose for the user and why (root, tracked link, held joints), for ``simtune init``
    choices: tuple[str, ...] = field(default=(), compare=False)

    # --- lookups ----------------------------------------------------------------------------
    @cached_property
    def link_by_name(self) -> dict[str, Link]:
        return {link.name: link for link in self.links}

    @cached_property
    def joint_by_name(self) -> dict[str, Joint]:
        return {joint.name: joint for joint in self.joints}

    @cached_property
    def parent_joint(self) -> dict[str, Joint]:
        """link -> the joint whose child it is (the root has none)."""
        return {joint.child: joint for joint in self.joints}

    @property
    def root(self) -> str:
        return self.links[0].name

    @property
    def n_joints(self) -> int:
        return len(self.arm_joints)

    @property
    def driven_links(self) -> tuple[str, ...]:
        """The child link of each driven joint, in order."""
        return tuple(self.joint_by_name[j].child for j in self.arm_joints)

    def children(self, link_name: str) -> list[Joint]:
        """The joints whose parent is ``link_name``, in table order."""
        return [j for j in self.joints if j.parent == link_name]

    def chain(self, link: str) -> list[Joint]:
        """The joints from the root down to ``link``, root first."""
        chain = []
        name = link
        while name != self.root:
            joint = self.parent_joint[name]
            chain.append(joint)
            name = joint.parent
        return chain[::-1]

    @property
    def nominal(self) -> tuple[float, ...]:
        """The masses the ``mass_link_<n>`` ranges are relative to, one per driven joint."""
        if self.nominal_masses is not None:
            return self.nominal_masses
        return tuple(self.link_by_name[link].mass for link in self.driven_links)

    def generic_effort(self, index: int) -> float:
        """The generic force limit of driven joint ``index`` (0-based): the source's; where it gives none, the
        default or :data:`LOAD_MARGIN` times the largest gravity load the joint can carry, whichever is larger (an
        industrial arm described without efforts must hold itself up: MuJoCo and Drake compensate gravity beside
        their servos, but PyBullet's, ODE's and DART's motors carry it within this limit)."""
        effort = self.joint_by_name[self.arm_joints[index]].effort
        if effort is not None:
            return float(effort)
        return max(self.default_effort, LOAD_MARGIN * float(self._load_bounds[index]))

    @cached_property
    def _load_bounds(self) -> np.ndarray:
        return self.gravity_load_bounds()

    @property
    def reach(self) -> float:
        """Base offset plus the lengths of the joint offsets up to the tracked link [m]: no pose puts its
        origin farther from the world origin (prismatic travel added at its upper limit)."""
        length = float(np.linalg.norm(self.base_position))
        for joint in self.chain(self.tracked_link):
            length += float(np.linalg.norm(joint.xyz))
            if joint.kind == "prismatic":
                length += max(abs(joint.lower or 0.0), abs(joint.upper or 0.0))
        return length

    # --- kinematics -------------------------------------------------------------------------
    def forward_kinematics(self, q, link: str | None = None) -> tuple[np.ndarray, np.ndarray]:
        """World position and rotation of ``link``'s frame (default the tracked link) for driven joint
        positions ``q`` [rad or m].  A plain NumPy chain over the joint table: the engines are checked
        against it."""
        positions = dict(zip(self.arm_joints, np.asarray(q, dtype=float)))
        pos = np.array(self.base_position, dtype=float)
        rot = rpy_matrix(self.base_rpy) if self.base_rpy != ZERO3 else np.eye(3)
        for joint in self.chain(link or self.tracked_link):
            pos = pos + rot @ np.asarray(joint.xyz, dtype=float)
            rot = rot @ rpy_matrix(joint.rpy)
            if joint.moves:
                t, r = joint.motion(positions.get(joint.name, 0.0))
                if joint.kind == "prismatic":
                    pos = pos + rot @ t
                else:
                    rot = rot @ r
        return pos, rot

    def driven_axes(
        self, q: np.ndarray | None = None
    ) -> tuple[dict[str, tuple[np.ndarray, np.ndarray]], list[tuple[np.ndarray, np.ndarray, list[str]]]]:
        """Every link's frame at a pose, and per driven joint its axis and where it stands, with the links it moves:
        what the joint-space inertia, the mass matrix and a per-link damping torque each sum over.

        Args:
            q: the driven joints' positions [rad or m]; default the zero pose.

        Returns:
            ``(frames, axes)``: link name -> its (position, rotation) in the world; per driven joint ``(axis,
            origin, below)``, its unit axis and its child frame's origin in the world and the names of the links
            below it (its child first, parents before children).
        """
        q = np.zeros(self.n_joints) if q is None else np.asarray(q, dtype=float)
        frames = {link.name: self.forward_kinematics(q, link.name) for link in self.links}
        axes = []
        for name in self.arm_joints:
            joint = self.joint_by_name[name]
            origin, turn = frames[joint.child]
            axis = turn @ np.asarray(joint.axis, dtype=float)
            axis /= np.linalg.norm(axis)
            # a list in the joint table's order, not a set: the sums over it must not depend on the process's
            # string hashing (a set's order did: the inertias, and the ranges and gains made from them, differed
            # in their last digits from one process to the next)
            below = [joint.child]
            for other in self.joints:  # parents before children
                if other.parent in below:
                    below.append(other.child)
            axes.append((axis, origin, below))
        return frames, axes

    def joint_inertias(self, q: np.ndarray | None = None) -> np.ndarray:
        """Per driven joint, the moment of inertia [kg m^2] about its axis of every link below it: what its servo
        accelerates (the arm's reflected inertia, no motor rotor).

        Args:
            q: the driven joints' positions [rad or m]; default the zero pose.

        Returns:
            One inertia per driven joint.
        """
        frames, axes = self.driven_axes(q)
        inertias = np.zeros(self.n_joints)
        for i, (axis, origin, below) in enumerate(axes):
            for link_name in below:
                link = self.link_by_name[link_name]
                pos, rot = frames[link_name]
                r = pos + rot @ np.asarray(link.com, dtype=float) - origin
                about = rot @ link.inertia_matrix() @ rot.T + link.mass * (r @ r * np.eye(3) - np.outer(r, r))
                inertias[i] += float(axis @ about @ axis)
        return inertias

    def mass_matrix(self, q: np.ndarray | None = None) -> np.ndarray:
        """The driven joints' joint-space mass matrix [kg m^2, kg for prismatic rows] (held joints fixed, no motor
        rotor): its diagonal is :meth:`joint_inertias`, its off-diagonal terms how one joint's force accelerates
        another (a shoulder and elbow that pitch together).

        Args:
            q: the driven joints' positions [rad or m]; default the zero pose.

        Returns:
            An (n, n) symmetric matrix, n the number of driven joints.
        """
        frames, axes = self.driven_axes(q)
        n = self.n_joints
        moved: dict[str, list[tuple[int, np.ndarray, np.ndarray, bool]]] = {}  # link -> (joint, axis, origin, slides)
        for i, (axis, origin, below) in enumerate(axes):
            slides = self.joint_by_name[self.arm_joints[i]].kind == "prismatic"
            for link_name in below:
                moved.setdefault(link_name, []).append((i, axis, origin, slides))
        matrix = np.zeros((n, n))
        for link_name, joints in moved.items():
            link = self.link_by_name[link_name]
            pos, rot = frames[link_name]
            com = pos + rot @ np.asarray(link.com, dtype=float)
            linear, angular = np.zeros((3, n)), np.zeros((3, n))  # the link's Jacobian at its centre of mass
            for i, axis, origin, slides in joints:
                linear[:, i] = axis if slides else np.cross(axis, com - origin)
                angular[:, i] = 0.0 if slides else axis
            world_inertia = rot @ link.inertia_matrix() @ rot.T
            matrix += link.mass * linear.T @ linear + angular.T @ world_inertia @ angular
        return matrix

    # --- statics: gravity torques (the calibration model's elastic deflection) ----------------
    def gravity(self, masses: dict[str, float] | None = None) -> GravityModel:
        """The gravity torques about the driven joints as a function of their positions, with the
        description's link masses (``masses``: link -> mass [kg] replacing some)."""
        return GravityModel(self, masses or {})

    def gravity_torques(self, q, masses: dict[str, float] | None = None) -> np.ndarray:
        """The torque [N m] (force [N] for a prismatic joint) that gravity exerts about each driven joint at
        driven joint positions ``q``; see :class:`GravityModel`."""
        return self.gravity(masses)(q)

    def gravity_load_bounds(self) -> np.ndarray:
        """Per driven joint, an upper bound [N m] of the gravity torque about it over all poses: every
        link below it at its largest possible lever (the joint offsets down to it plus its centre of
        mass's distance).  0 for a joint gravity never loads: an upright axis that no joint above it turns."""
        bounds = np.zeros(self.n_joints)
        root_rot = rpy_matrix(self.base_rpy) if self.base_rpy != ZERO3 else np.eye(3)
        for i, name in enumerate(self.arm_joints):
            chain = self.chain(self.joint_by_name[name].child)
            if not any(j.moves for j in chain[:-1]):
                rot = root_rot
                for j in chain:
                    rot = rot @ rpy_matrix(j.rpy)
                axis = rot @ np.asarray(chain[-1].axis, dtype=float)
                if np.linalg.norm(np.cross(axis, [0.0, 0.0, 1.0])) < 1e-9 * np.linalg.norm(axis):
                    continue
            lever = {chain[-1].child: 0.0}
            for joint in self.joints:  # parents before children: the path length from this joint down
                if joint.parent in lever:
                    lever[joint.child] = lever[joint.parent] + float(np.linalg.norm(joint.xyz))
            bounds[i] = GRAVITY * sum(
                self.link_by_name[link].mass * (path + float(np.linalg.norm(self.link_by_name[link].com)))
                for link, path in lever.items()
            )
        return bounds

    @property
    def gripper_links(self) -> tuple[str, ...]:
        """The links with the gripper's contact parameters (material ``gripper``)."""
        return tuple(link.name for link in self.links if link.material == "gripper")

    @property
    def gripper_surface(self) -> bool:
        """Whether a gripper link has a collision shape: what a task's object can touch."""
        return any(self.link_by_name[g].shapes for g in self.gripper_links)

    def check(self) -> None:
        """Raise ValueError if the tree or the named joints and link do not fit together."""
        names = [link.name for link in self.links]
        if len(set(names)) != len(names):
            raise ValueError(f"robot {self.name!r}: a link name is used twice")
        seen = {self.root}
        for joint in self.joints:
            if joint.kind not in JOINT_KINDS:
                raise ValueError(f"joint {joint.name!r}: unknown type {joint.kind!r}")
            if joint.parent not in seen or joint.child not in self.link_by_name or joint.child in seen:
                raise ValueError(f"joint {joint.name!r}: links out of tree order ({joint.parent} -> {joint.child})")
            seen.add(joint.child)
        for name in self.arm_joints:
            driven = self.joint_by_name.get(name)
            if driven is None or not driven.moves:
                raise ValueError(f"driven joint {name!r} is not a movable joint of robot {self.name!r}")
        for joint in self.joints:
            if joint.moves and joint.name not in self.arm_joints:
                raise ValueError(f"joint {joint.name!r} moves but is neither driven nor held")
        if self.tracked_link not in self.link_by_name:
            raise ValueError(f"tracked link {self.tracked_link!r} is not a link of robot {self.name!r}")
        # a gripper without a surface is fine until a task has an object for it to touch (tasks/files.py says so)
        if self.nominal_masses is not None and len(self.nominal_masses) != len(self.arm_joints):
            raise ValueError("one nominal mass per driven joint")


def mesh_vertices(mesh: Mesh) -> np.ndarray:
    """The mesh's vertices, scaled, in its own frame (before ``center``/``rpy``), read with trimesh."""
    import trimesh

    loaded = trimesh.load(mesh.path, force="mesh", process=False)
    vertices: np.ndarray = np.asarray(loaded.vertices, dtype=np.float64)  # type: ignore[attr-defined]
    return vertices * np.asarray(mesh.scale, dtype=np.float64)


def mesh_hull(mesh: Mesh) -> tuple[np.ndarray, np.ndarray]:
    """(vertices, triangles) of the convex hull of the scaled mesh, in its own frame."""
    import trimesh

    hull = trimesh.Trimesh(vertices=mesh_vertices(mesh), process=True).convex_hull
    return np.asarray(hull.vertices, dtype=float), np.asarray(hull.faces, dtype=int)


class GravityModel:
    """Gravity torques about a robot's driven joints, for any pose: a static computation.

    The links rigidly attached to each other (fixed joints) are lumped into one body per movable
    joint, once; each call then walks the movable joints down the tree for their frames and sums
    each body's mass and first moment up the tree, so that the torque about driven joint i is
    axis_i . ((first moment below i - mass below i x origin_i) x m g).  Positive turns the joint in
    its positive direction; the static load its motor holds is minus this.
    """

    def __init__(self, robot: RobotDescription, masses: dict[str, float]):
        driven = {name: i for i, name in enumerate(robot.arm_joints)}
        held = dict(robot.held)
        self.n_joints = robot.n_joints
        self.base = np.array(robot.base_position, dtype=float)
        self.base_rot = rpy_matrix(robot.base_rpy) if robot.base_rpy != ZERO3 else np.eye(3)
        body_of = {robot.root: 0}
        # a link's place in its body's frame
        placed: dict[str, tuple[np.ndarray, np.ndarray]] = {robot.root: (np.zeros(3), np.eye(3))}
        #: per movable joint: parent body, joint frame in the parent body's frame, unit axis, prismatic?,
        #: driven index (-1: held at ``value``), held value
        self.joints: list[tuple[int, np.ndarray, np.ndarray, np.ndarray, bool, int, float]] = []
        for joint in robot.joints:
            pos, rot = placed[joint.parent]
            pos = pos + rot @ np.asarray(joint.xyz, dtype=float)
            rot = rot @ rpy_matrix(joint.rpy)
            if joint.moves:
                axis = np.asarray(joint.axis, dtype=float) / np.linalg.norm(joint.axis)
                index = driven.get(joint.name, -1)
                value = float(held.get(joint.name, 0.0))
                self.joints.append((body_of[joint.parent], pos, rot, axis, joint.kind == "prismatic", index, value))
                body_of[joint.child] = len(self.joints)
                placed[joint.child] = (np.zeros(3), np.eye(3))
            else:
                body_of[joint.child] = body_of[joint.parent]
                placed[joint.child] = (pos, rot)
        n_bodies = len(self.joints) + 1
        self.mass = np.zeros(n_bodies)
        self.moment = np.zeros((n_bodies, 3))  # mass times centre of mass, in the body's frame
        for link in robot.links:
            body, (pos, rot) = body_of[link.name], placed[link.name]
            mass = float(masses.get(link.name, link.mass))
            self.mass[body] += mass
            self.moment[body] += mass * (pos + rot @ np.asarray(link.com, dtype=float))
        self.parent = [0] + [j[0] for j in self.joints]

    def __call__(self, q) -> np.ndarray:
        q = np.asarray(q, dtype=float)
        positions, rotations = [self.base], [self.base_rot]
        origins, axes = [], []
        for parent, offset, turn, axis, prismatic, index, value in self.joints:
            pos, rot = positions[parent], rotations[parent]
            origin = pos + rot @ offset
            rot = rot @ turn
            world_axis = rot @ axis
            x = q[index] if index >= 0 else value
            if prismatic:
                origin_child = origin + world_axis * x
            else:
                origin_child = origin
                rot = rot @ axis_angle_matrix(axis, x)
            positions.append(origin_child)
            rotations.append(rot)
            origins.append(origin)
            axes.append(world_axis)
        mass = self.mass.copy()
        moment = mass[:, None] * np.array(positions) + np.einsum("bij,bj->bi", np.array(rotations), self.moment)
        for body in range(len(self.joints), 0, -1):  # children come after their parents
            mass[self.parent[body]] += mass[body]
            moment[self.parent[body]] += moment[body]
        torques = np.zeros(self.n_joints)
        for k, (_, _, _, _, prismatic, index, _) in enumerate(self.joints):
            if index < 0:
                continue
            a, body = axes[k], k + 1
            if prismatic:
                torques[index] = -GRAVITY * mass[body] * a[2]
            else:  # a . (v x g) with g = (0, 0, -G): G (a_y v_x - a_x v_y)
                v = moment[body] - mass[body] * origins[k]
                torques[index] = GRAVITY * (a[1] * v[0] - a[0] * v[1])
        return torques
