"""The Open Dynamics Engine (ODE) itself, through the ``ode-python`` ctypes binding.

ODE works in maximal coordinates: every moving link is a free rigid body and
joints are constraints between bodies.  The robot is built from the task's
robot description (the MICO's in the notes below):

- one body per driven link (link 1-6), its origin at the link's centre of mass
  (ODE's rule), turned like the link frame; links welded to it (the fingers,
  welded open) ride on its body (one composite body: ODE's own fixed joints
  are soft constraints, a single body is the exact weld);
- the root (``link_base``) is static: its shapes are body-less geoms at the base
  pose, and the first joint attaches its link to the static environment;
- each driven joint is a hinge with a velocity motor (``dParamVel`` = the
  commanded joint velocity, ``dParamFMax`` = the maximum torque), a hard
  constraint like PyBullet's motor; limited joints (joint_2/3) have their stops;
- Coulomb joint friction (``friction_joint_<n>``) is ODE's own: an angular motor with target velocity 0 whose
  most torque is the friction; ODE's maximal coordinates have no armature.

Collision: the links' boxes, spheres and cylinders, and the convex hull of a
mesh, a plane for the floor, a box / cylinder for the objects and a convex
hull for the cone; contact joints are made in the
near callback with Coulomb friction (pyramid approximation, so ``mu`` is a
coefficient), restitution (``dContactBounce``) and ODE's rolling friction
(``dContactRolling`` with ``dContactAxisDep``: ``rho`` about the tangent axes =
rolling, ``rhoN`` about the normal = spinning).  ODE leaves combining two surfaces to the near
callback: simtune takes the geometric mean of the two groups' values.

The world is rebuilt on every reset, so no contact or solver state carries
over: the same parameters always give the same trajectory.  Steps use
``dWorldStep`` (ODE's exact LCP solver) rather than the iterative
``dWorldQuickStep``, which lets a chain of hard motors drift.
"""

from __future__ import annotations

import ctypes
import math
from ctypes import POINTER, byref, c_int, c_void_p
from typing import Any

import numpy as np

from simtune.engines._shapes import (
    cone_hull,
    host_links,
    host_mass_properties,
    link_shapes_in_host,
    mesh_hull_faces,
    object_mass_properties,
)
from simtune.engines.base import Engine, unloaded_hard_motors
from simtune.engines.ode.mapping import (
    BOUNCE_VELOCITY,
    DEFAULT_CONTACT,
    DEFAULT_TIMESTEP,
    PairSurface,
    pair_surface,
)
from simtune.errors import ConfigError
from simtune.params.kinds import engine_parameters as kinds_of_engine
from simtune.robot import MICO
from simtune.robot.description import Box, Cylinder, Mesh, RobotDescription, Sphere
from simtune.tasks.spec import ObjectSpec, TaskSpec

try:
    import odepy as ode
except Exception:  # pragma: no cover - ImportError, or odepy's OdePyError when libode is missing
    ode = None

MAX_CONTACTS = 16  # per geom pair
# collision categories: arm shapes touch the floor and the object, never each other
_FLOOR, _ARM, _OBJECT = 1, 2, 4

if ode is not None:
    _lib_fn = ode.common.loadOde
    _NearCallback = ctypes.CFUNCTYPE(None, c_void_p, c_void_p, c_void_p)
    # hot functions with plain pointer arguments (odepy's wrappers build a new ctypes
    # function object on every call for some of these)
    _space_collide = _lib_fn("dSpaceCollide", None, c_void_p, c_void_p, _NearCallback)
    _collide = _lib_fn("dCollide", c_int, c_void_p, c_void_p, c_int, POINTER(ode.dContactGeom), c_int)
    _create_contact = _lib_fn("dJointCreateContact", c_void_p, c_void_p, c_void_p, POINTER(ode.dContact))
    _attach = _lib_fn("dJointAttach", None, c_void_p, c_void_p, c_void_p)
    _create_hinge = _lib_fn("dJointCreateHinge", c_void_p, c_void_p, c_void_p)
    _world_step = _lib_fn("dWorldStep", c_int, c_void_p, ode.dReal)
    _group_empty = _lib_fn("dJointGroupEmpty", None, c_void_p)
    _hinge_anchor = _lib_fn("dJointSetHingeAnchor", None, c_void_p, ode.dReal, ode.dReal, ode.dReal)
    _hinge_axis = _lib_fn("dJointSetHingeAxis", None, c_void_p, ode.dReal, ode.dReal, ode.dReal)
    _hinge_param = _lib_fn("dJointSetHingeParam", None, c_void_p, c_int, ode.dReal)
    _hinge_angle = _lib_fn("dJointGetHingeAngle", ode.dReal, c_void_p)
    _hinge_rate = _lib_fn("dJointGetHingeAngleRate", ode.dReal, c_void_p)
    _add_hinge_torque = _lib_fn("dJointAddHingeTorque", None, c_void_p, ode.dReal)
    _body_pos = _lib_fn("dBodyGetPosition", POINTER(ode.dReal), c_void_p)
    _body_rot = _lib_fn("dBodyGetRotation", POINTER(ode.dReal), c_void_p)
    _PARAM_VEL = ode.dParamVel

    _messages: list[str] = []

    @ctypes.CFUNCTYPE(None, c_int, POINTER(ctypes.c_char))
    def _on_message(number, text):  # ODE prints these to stderr by default: remembered instead
        if len(_messages) < 100:
            _messages.append((ctypes.cast(text, ctypes.c_char_p).value or b"").decode(errors="replace"))

    ode.dInitODE2(0)
    ode.dSetMessageHandler(_on_message)


def _ode_matrix(rot: np.ndarray):
    m = ode.dMatrix3()
    for i in range(3):
        for j in range(3):
            m[4 * i + j] = float(rot[i, j])
    return m


def _link_poses(robot: RobotDescription, q) -> dict[str, tuple[np.ndarray, np.ndarray]]:
    """World pose of the root's and every driven link's frame for joint angles ``q``."""
    return {name: robot.forward_kinematics(q, name) for name in [robot.root, *robot.driven_links]}


def _surface(surface: PairSurface):
    """ODE's contact surface with the values ``surface`` (its mode flags the features they use)."""
    s = ode.dSurfaceParameters()
    s.mode = ode.dContactApprox1  # friction pyramid: mu is a coefficient
    s.mu = surface.mu
    if surface.rolling > 0 or surface.spinning > 0:
        # without dContactAxisDep ODE ignores rho2 and rhoN and uses rho about all three
        # axes (contact.cpp); the flag also makes the second friction direction read mu2
        s.mode |= ode.dContactRolling | ode.dContactAxisDep
        s.mu2 = s.mu
        s.rho, s.rho2, s.rhoN = surface.rolling, surface.rolling, surface.spinning
    if surface.bounce > 0:
        s.mode |= ode.dContactBounce
        s.bounce, s.bounce_vel = surface.bounce, BOUNCE_VELOCITY
    return s


def _set_mass(body, mass: float, inertia) -> None:
    """Give an ODE body its mass and its inertia tensor (about the centre of mass, as ODE expects).  ODE aborts the
    process on a tensor that is not positive definite: the robot loader gives a link with mass and no inertia one
    (:func:`simtune.robot.urdf.load_urdf`), and ``simtune check`` loads each engine in a child process."""
    m = ode.dMass()
    ode.dMassSetParameters(
        byref(m),
        mass,
        0.0,
        0.0,
        0.0,
        inertia[0, 0],
        inertia[1, 1],
        inertia[2, 2],
        inertia[0, 1],
        inertia[0, 2],
        inertia[1, 2],
    )
    ode.dBodySetMass(body, byref(m))


#: the engine's name in the registry and the kinds table
NAME = "ode"


class OdeEngine(Engine):
    name = NAME
    engine_parameters = kinds_of_engine(NAME, 6)  # its kinds in simtune.params.kinds

    @classmethod
    def version(cls) -> str:
        if ode is None:
            return "not installed"
        from importlib.metadata import version

        lib = "libode"
        try:  # the ODE library exports no version: name the file the binding loaded
            with open("/proc/self/maps") as maps:
                lib = next(line.split()[-1].rsplit("/", 1)[-1] for line in maps if "libode.so" in line)
        except (OSError, StopIteration):
            pass
        return f"{lib} (ode-python {version('ode-python')})"

    @classmethod
    def inactive_parameters(cls, task: TaskSpec) -> dict[str, str]:
        # measured on every task and probe: only joints 1 and 2, pushing or pressing an object, reach the limit
        return super().inactive_parameters(task) | unloaded_hard_motors(
            "ODE", task, measured_on=MICO, joints=(3, 4, 5, 6), damping=(3, 4, 5, 6)
        )

    def __init__(self, task: TaskSpec):
        super().__init__(task)
        self._world = None
        self.robot = robot = task.robot
        if any(robot.joint_by_name[j].kind == "prismatic" for j in robot.arm_joints):
            raise ConfigError(f"robot {robot.name!r}: simtune's ODE engine drives revolute joints only")
        # the host body of every link, and the tracked link's frame in its host's
        self._hosts = host_links(robot)
        self._tracked_host, self._tracked_pos, self._tracked_rot = self._hosts[robot.tracked_link]
        self._callback = _NearCallback(self._near)  # kept alive as long as the engine
        self._contact_geoms = (ode.dContactGeom * MAX_CONTACTS)()
        self._contact = ode.dContact()
        #: each convex hull's arrays as ODE reads them, by shape (a link's mesh, the task's cone), and each mesh hull's
        #: centre in the mesh's frame, made once
        self._hulls: dict[object, tuple] = {}
        self._hull_centres: dict[Mesh, np.ndarray] = {}
        #: the links' mesh geoms kept from one world to the next, by mesh, in the order they were made (spare), and
        #: those of the present world with their mesh (in use): every reset builds a fresh world, and dCreateConvex
        #: takes its time over a hull's edges (22 ms for each of a published SO-101's 17 hulls: 0.37 s of its
        #: 0.49-s rollout), while a geom's hull never changes
        self._spare_geoms: dict[Mesh, list] = {}
        self._geoms_in_use: list[tuple[Mesh, Any]] = []
        self._defaults = self._generic()
        self._build(self._defaults)
        self._pose_arm(np.radians(task.start_pose_deg))
        self._defaults.update(
            {
                f"{kind}_{g}": v
                for g, body in self._damped_bodies().items()
                for kind, v in (
                    ("linear_damping", ode.dBodyGetLinearDamping(body)),
                    ("angular_damping", ode.dBodyGetAngularDamping(body)),
                )
            }
        )

    # --- generic values ------------------------------------------------------------
    def _generic(self) -> dict[str, float]:
        robot = self.robot
        values = {"timestep": DEFAULT_TIMESTEP}
        for i, link in enumerate(robot.driven_links, start=1):
            values[f"mass_link_{i}"] = robot.link_by_name[link].mass
            values[f"max_torque_joint_{i}"] = robot.generic_effort(i - 1)
            # ODE's hinge has no damping of its own: the description's, added as a torque
            values[f"joint_damping_{i}"] = robot.joint_by_name[robot.arm_joints[i - 1]].damping
        values |= self.drive_defaults()  # Coulomb joint friction: the description's
        groups = ["gripper", "floor"]
        if self.task.object is not None:
            values[self.task.object.mass_parameter] = self.task.object.mass
            groups.append(self.task.object.material)
        for g in groups:
            for kind, v in DEFAULT_CONTACT.items():
                values[f"{kind}_{g}"] = v
        return values

    def defaults(self) -> dict[str, float]:
        return dict(self._defaults)

    # --- scene ----------------------------------------------------------------------
    def _destroy(self) -> None:
        if self._world is not None:
            for shape, geom in self._geoms_in_use:  # out of the space before it destroys its geoms, off its body
                ode.dSpaceRemove(self._space, geom)
                ode.dGeomSetBody(geom, None)
                self._spare_geoms.setdefault(shape, []).append(geom)
            self._geoms_in_use.clear()
            ode.dJointGroupDestroy(self._contacts)
            ode.dSpaceDestroy(self._space)  # destroys its geoms (cleanup mode is on)
            ode.dWorldDestroy(self._world)  # destroys bodies and joints
            self._world = None

    def _build(self, p: dict[str, float]) -> None:
        """Create the world with parameters ``p`` (a complete set), the arm at angle 0.

        The parts are made in a fixed order (arm, floor, joints, object), which fixes the order of
        ODE's bodies, geoms and joints and so the solver's: the same parameters, the same trajectory."""
        self._new_world(float(p["timestep"]))
        poses = _link_poses(self.robot, np.zeros(self.robot.n_joints))
        self._build_arm(p, poses)
        floor = ode.dCreatePlane(self._space, 0.0, 0.0, 1.0, 0.0)
        self._register(floor, "floor", None, _FLOOR, _ARM | _OBJECT)
        self._build_joints(p, poses)
        self._object = None
        if self.task.object is not None:
            self._build_object(self.task.object, p[self.task.object.mass_parameter])
        for g, body in self._damped_bodies().items():
            if f"linear_damping_{g}" in p:
                ode.dBodySetLinearDamping(body, p[f"linear_damping_{g}"])
            if f"angular_damping_{g}" in p:
                ode.dBodySetAngularDamping(body, p[f"angular_damping_{g}"])
        names = {g for g, _ in self._geoms.values()}
        self._surfaces = {(a, b): _surface(pair_surface(p, a, b)) for a in names for b in names}

    def _new_world(self, timestep: float) -> None:
        """An empty world, space and contact group in place of the last ones."""
        self._destroy()
        self._pose_views: dict[int, tuple[np.ndarray, np.ndarray]] = {}  # id(body) -> views of its pose
        _messages.clear()
        self._failed = ""
        ode.dRandSetSeed(0)
        self._timestep = timestep
        world = self._world = ode.dWorldCreate()
        ode.dWorldSetGravity(world, 0.0, 0.0, -9.81)
        self._space = ode.dSimpleSpaceCreate(0)  # simple space: pairs in a fixed order
        self._space_ptr = ctypes.cast(self._space, c_void_p).value
        self._contacts = ode.dJointGroupCreate(0)
        self._world_ptr = ctypes.cast(world, c_void_p).value
        self._contacts_ptr = ctypes.cast(self._contacts, c_void_p).value
        self._geoms: dict[int, tuple[str, int | None]] = {}  # geom address -> (group, body address)
        self._arm_geoms: set[int] = set()  # addresses of the arm's and fingers' geoms
        self._object_geom: int | None = None
        self._touching = False  # the last step's collision pass found an arm-object contact

    def _build_arm(self, p: dict[str, float], poses: dict[str, tuple[np.ndarray, np.ndarray]]) -> None:
        """One body per driven link's host (the root's shapes static, without a body), with its shapes;
        ``poses``: the link frames at angle 0."""
        robot = self.robot
        masses = {link: p[f"mass_link_{i}"] for i, link in enumerate(robot.driven_links, start=1)}
        mass_props = host_mass_properties(robot, masses)
        shapes = link_shapes_in_host(robot)
        self._bodies: dict[str, ctypes._Pointer[Any]] = {}  # odepy's dBodyID of each moving link
        self._com: dict[str, np.ndarray] = {}
        for host in (robot.root, *robot.driven_links):
            if host not in mass_props and host != robot.root:
                raise ConfigError(f"robot {robot.name!r}: link {host!r} and the links welded to it have no mass")
            mass, com, inertia = mass_props.get(host, (0.0, np.zeros(3), np.zeros((3, 3))))
            pos, rot = poses[host]
            body = None
            if host != robot.root:  # the base is static: geoms without a body
                body = ode.dBodyCreate(self._world)
                _set_mass(body, mass, inertia)
                c = pos + rot @ com
                ode.dBodySetPosition(body, *c)
                ode.dBodySetRotation(body, _ode_matrix(rot))
                self._bodies[host] = body
                self._com[host] = com
            group = "gripper" if robot.link_by_name[host].material == "gripper" else "arm"
            for centre, shape_rot, shape, link in shapes.get(host, []):
                geom, shift = self._link_geom(shape)
                if shift is not None:  # a hull about its own centre
                    centre = centre + shape_rot @ shift
                member_group = "gripper" if robot.link_by_name[link].material == "gripper" else group
                if body is not None:
                    ode.dGeomSetBody(geom, body)
                    ode.dGeomSetOffsetPosition(geom, *(centre - com))
                    ode.dGeomSetOffsetRotation(geom, _ode_matrix(shape_rot))
                else:
                    ode.dGeomSetPosition(geom, *(pos + rot @ centre))
                    ode.dGeomSetRotation(geom, _ode_matrix(rot @ shape_rot))
                self._register(geom, member_group, body, _ARM, _FLOOR | _OBJECT)
                self._arm_geoms.add(ctypes.cast(geom, c_void_p).value or 0)

    def _build_joints(self, p: dict[str, float], poses: dict[str, tuple[np.ndarray, np.ndarray]]) -> None:
        """A hinge with a velocity motor for every driven joint, defined at angle 0 (the link frames ``poses``)."""
        robot = self.robot
        self._joints = []
        self._axes: list[np.ndarray] = []  # each hinge's axis in the world at angle 0
        for i, name in enumerate(robot.arm_joints, start=1):
            joint = robot.joint_by_name[name]
            parent = self._bodies.get(self._hosts[joint.parent][0])
            child = self._bodies[joint.child]
            hinge = _create_hinge(self._world_ptr, None)
            _attach(
                hinge,
                ctypes.cast(child, c_void_p).value,
                ctypes.cast(parent, c_void_p).value if parent is not None else None,
            )
            pos, rot = poses[joint.child]
            _hinge_anchor(hinge, *pos)
            axis = rot[:, 2] if joint.axis == (0.0, 0.0, 1.0) else rot @ np.asarray(joint.axis, dtype=float)
            _hinge_axis(hinge, *axis)  # the hinge's angle 0 is this pose
            self._axes.append(axis)
            if joint.limited:
                _hinge_param(hinge, ode.dParamLoStop, joint.lower)
                _hinge_param(hinge, ode.dParamHiStop, joint.upper)
            _hinge_param(hinge, ode.dParamVel, 0.0)
            _hinge_param(hinge, ode.dParamFMax, float(p[f"max_torque_joint_{i}"]))
            self._joints.append(hinge)
        self._damping = np.array([p[f"joint_damping_{i}"] for i in range(1, robot.n_joints + 1)])

    def _build_object(self, obj: ObjectSpec, mass: float) -> None:
        """The task's object: a body of ``mass`` with its collision shape, at its start pose."""
        com, inertia = object_mass_properties(obj, mass)
        body = self._object = ode.dBodyCreate(self._world)
        _set_mass(body, mass, inertia)
        self._object_com = com
        if obj.shape in ("cube", "cuboid"):
            geom = ode.dCreateBox(self._space, *obj.size)
        elif obj.shape == "cylinder":
            geom = ode.dCreateCylinder(self._space, obj.size[0], obj.size[1])
        else:
            if obj not in self._hulls:
                self._keep_hull(obj, *cone_hull(obj))
            geom = self._convex(obj)
        ode.dGeomSetBody(geom, body)
        ode.dGeomSetOffsetPosition(geom, *(-com))
        self._register(geom, obj.material, body, _OBJECT, _FLOOR | _ARM)
        self._object_geom = ctypes.cast(geom, c_void_p).value
        self._place_object(obj)

    def _link_geom(self, shape) -> tuple[Any, np.ndarray | None]:
        """A body-less ODE geom of a link's collision shape, in the shape's own frame, and None; for a mesh,
        its convex hull about the hull's centre, and that centre in the mesh's frame."""
        if isinstance(shape, Box):
            return ode.dCreateBox(self._space, *(2 * np.asarray(shape.half))), None
        if isinstance(shape, Sphere):
            return ode.dCreateSphere(self._space, shape.radius), None
        if isinstance(shape, Cylinder):
            return ode.dCreateCylinder(self._space, shape.radius, shape.length), None
        if shape not in self._hull_centres:
            vertices, faces, planes, self._hull_centres[shape] = mesh_hull_faces(shape)
            self._keep_hull(shape, vertices, faces, planes)
        spare = self._spare_geoms.get(shape)
        if spare:
            geom = spare.pop(0)  # the same mesh's geoms come back in the order they were made
            ode.dSpaceAdd(self._space, geom)
        else:
            geom = self._convex(shape)
        self._geoms_in_use.append((shape, geom))
        return geom, self._hull_centres[shape]

    def _keep_hull(self, key: object, vertices: np.ndarray, faces, planes: np.ndarray) -> None:
        """The arrays of a convex hull as dCreateConvex reads them, kept by the engine under ``key`` (ODE keeps
        pointers to them and never writes them, so every world's geom of that shape shares them)."""
        plane_arr = (ode.dReal * planes.size)(*planes.ravel())
        point_arr = (ode.dReal * vertices.size)(*vertices.ravel())
        polygons = [int(x) for face in faces for x in (len(face), *face)]
        poly_arr = (ctypes.c_uint32 * len(polygons))(*polygons)
        self._hulls[key] = (plane_arr, len(planes), point_arr, len(vertices), poly_arr)

    def _convex(self, key: object):
        """A body-less ODE convex geom of the hull kept under ``key`` (:meth:`_keep_hull`)."""
        plane_arr, n_planes, point_arr, n_points, poly_arr = self._hulls[key]
        return ode.dCreateConvex(self._space, plane_arr, n_planes, point_arr, n_points, poly_arr)

    def _register(self, geom, group: str, body, category: int, collide: int) -> None:
        ode.dGeomSetCategoryBits(geom, category)
        ode.dGeomSetCollideBits(geom, collide)
        address = ctypes.cast(geom, c_void_p).value
        assert address is not None, "ODE returned a null geom"
        self._geoms[address] = (group, ctypes.cast(body, c_void_p).value if body else None)

    def _damped_bodies(self) -> dict[str, ctypes._Pointer[Any]]:
        bodies = {"gripper": self._bodies[self._tracked_host]}  # the hand
        if self._object is not None and self.task.object is not None:
            bodies[self.task.object.material] = self._object
        return bodies

    def _place_object(self, obj: ObjectSpec) -> None:
        rot = obj.rotation
        c = np.asarray(obj.start_position) + rot @ self._object_com
        ode.dBodySetPosition(self._object, *c)
        ode.dBodySetRotation(self._object, _ode_matrix(rot))
        ode.dBodySetLinearVel(self._object, 0.0, 0.0, 0.0)
        ode.dBodySetAngularVel(self._object, 0.0, 0.0, 0.0)

    def _pose_arm(self, q) -> None:
        """Place the arm's bodies at joint angles ``q`` with zero velocity (kinematic)."""
        poses = _link_poses(self.robot, q)
        for host, body in self._bodies.items():
            pos, rot = poses[host]
            ode.dBodySetPosition(body, *(pos + rot @ self._com[host]))
            ode.dBodySetRotation(body, _ode_matrix(rot))
            ode.dBodySetLinearVel(body, 0.0, 0.0, 0.0)
            ode.dBodySetAngularVel(body, 0.0, 0.0, 0.0)
        self._angles = [float(a) for a in q]

    def _near(self, data, g1, g2) -> None:
        group1, body1 = self._geoms[g1]
        group2, body2 = self._geoms[g2]
        if body1 is None and body2 is None:
            return
        n = _collide(g1, g2, MAX_CONTACTS, self._contact_geoms, ctypes.sizeof(ode.dContactGeom))
        if not n:
            return
        if (g1 == self._object_geom and g2 in self._arm_geoms) or (g2 == self._object_geom and g1 in self._arm_geoms):
            self._touching = True
        contact = self._contact
        contact.surface = self._surfaces[(group1, group2)]
        for k in range(n):
            contact.geom = self._contact_geoms[k]
            joint = _create_contact(self._world_ptr, self._contacts_ptr, byref(contact))
            _attach(joint, body1, body2)

    # --- interface ------------------------------------------------------------------
    @property
    def timestep(self) -> float:
        return self._timestep

    def reset(self, params: dict[str, float]) -> None:
        self._build({**self._defaults, **params})
        self.apply_drive(params)
        self._pose_arm(self.start_angles(params))

    def set_joint_friction(self, values: np.ndarray) -> None:
        """``friction_joint_<n>`` [N m] -> ODE's own joint friction: an angular motor on each driven joint's axis
        with target velocity 0 and its friction as the most torque it may apply (a hard constraint beside the
        velocity motor, solved with it).  Made after the hinges of a fresh world (none for friction 0)."""
        for i, friction in enumerate(values.tolist()):
            if friction <= 0:
                continue
            joint = self.robot.joint_by_name[self.robot.arm_joints[i]]
            motor = ode.dJointCreateAMotor(self._world, None)
            parent = self._bodies.get(self._hosts[joint.parent][0])
            _attach(
                ctypes.cast(motor, c_void_p).value,
                ctypes.cast(self._bodies[joint.child], c_void_p).value,
                ctypes.cast(parent, c_void_p).value if parent is not None else None,
            )
            ode.dJointSetAMotorNumAxes(motor, 1)
            ode.dJointSetAMotorAxis(motor, 0, 1, *(float(a) for a in self._axes[i]))  # 1: fixed in the child body
            ode.dJointSetAMotorParam(motor, ode.dParamVel, 0.0)
            ode.dJointSetAMotorParam(motor, ode.dParamFMax, friction)

    def set_joint_velocities(self, velocities: np.ndarray) -> None:
        for hinge, v in zip(self._joints, velocities.tolist()):
            _hinge_param(hinge, _PARAM_VEL, v)

    def step(self, n: int) -> None:
        damped = [(j, d) for j, d in zip(self._joints, self._damping) if d > 0]
        for _ in range(n):
            for joint, d in damped:  # viscous joint damping as a joint torque (ODE has none built in)
                _add_hinge_torque(joint, -d * _hinge_rate(joint))
            self._touching = False
            _space_collide(self._space_ptr, None, self._callback)
            ok = _world_step(self._world_ptr, self._timestep)
            _group_empty(self._contacts_ptr)
            if not ok and not self._failed:
                self._failed = "dWorldStep failed"

    def arm_object_contact(self) -> bool:
        return self._touching

    def diverged(self) -> str:
        # ODE's messages ("LCP internal error ...": one step's LCP solved inexactly) are
        # notes, not failures: a step that really goes wrong shows in the state checks
        return f"ODE: {self._failed}" if self._failed else ""

    @property
    def solver_messages(self) -> list[str]:
        """ODE's messages since the last reset (kept for diagnosis, never printed)."""
        return list(_messages)

    def joint_angles(self) -> np.ndarray:
        # ODE reports hinge angles in (-pi, pi]: unwrap against the last reading
        last = self._angles
        self._angles = [a + math.remainder(_hinge_angle(j) - a, 2 * math.pi) for j, a in zip(self._joints, last)]
        return np.array(self._angles)

    def _body_pose(self, body) -> tuple[np.ndarray, np.ndarray]:
        # ODE keeps a body's position and rotation at fixed addresses: wrap them once per body
        views = self._pose_views.get(id(body))
        if views is None:
            ptr = ctypes.cast(body, c_void_p).value
            views = self._pose_views[id(body)] = (
                np.ctypeslib.as_array(_body_pos(ptr), shape=(3,)),
                np.ctypeslib.as_array(_body_rot(ptr), shape=(12,)).reshape(3, 4)[:, :3],
            )
        return views[0].copy(), views[1].copy()

    def wrist_pose(self) -> tuple[np.ndarray, np.ndarray]:
        host = self._tracked_host
        pos, rot = self._body_pose(self._bodies[host])
        frame = pos - rot @ self._com[host]
        if host == self.robot.tracked_link:
            return frame, rot
        return frame + rot @ self._tracked_pos, rot @ self._tracked_rot

    def object_position(self) -> np.ndarray | None:
        if self._object is None:
            return None
        pos, rot = self._body_pose(self._object)
        return pos - rot @ self._object_com

    def close(self) -> None:
        if ode is not None:
            self._destroy()
            for geoms in self._spare_geoms.values():
                for geom in geoms:
                    ode.dGeomDestroy(geom)
            self._spare_geoms.clear()

    def __del__(self) -> None:
        try:
            self.close()
        except Exception:
            pass
