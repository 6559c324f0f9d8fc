"""Parameter kinds: the one home of every tunable parameter's name, scope, range, unit, generic value and engines.

A *kind* is a family of parameters (``joint_damping`` -> ``joint_damping_1`` .. ``joint_damping_6``).
:data:`KINDS` lists them in the order the parameter spaces hold them; from it come the spaces
(:mod:`simtune.params.space`), each engine's parameter list (:func:`engine_parameters`), the names the
controller, its encoders and the marker model read (:func:`applied_outside`), the exporters' and the
report's generic values (:func:`outside_generics`) and docs/parameters.md's table of kinds.

Adding a kind: one :class:`Kind` entry here (its range rule in :func:`bounds`), and in each engine
that has it, the one method named by ``apply`` (``Engine.<apply>(values)``, per driven joint); an engine
not listed in ``engines`` lacks the kind, and a value for it there is refused with one clear line
(:func:`lacking`).  Exporters write the kinds of :data:`DRIVE_KINDS` from the engines' drive values
(:meth:`simtune.engines.Engine.drive_defaults` and the run's parameters).
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from dataclasses import dataclass, field

from simtune.engines.registry import ENGINES
from simtune.robot.description import RobotDescription
from simtune.robot.generate import servo_gains
from simtune.tasks.spec import CONTACT_GROUPS, MATERIALS, SHAPES

#: Every engine of the registry (``simtune engines``), by name: the registry's, below this table.
ALL_ENGINES = frozenset(ENGINES)
#: The scopes of a kind: once per driven joint, per driven link, per material group, per object,
#: per axis of the marker offset, or once.
JOINT, LINK, MATERIAL, OBJECT, AXIS, GLOBAL = "joint", "link", "material", "object", "axis", "global"
#: Who applies a kind: the engine's physics, simtune's joint controller, its encoder model, or the fitness's
#: marker model (the last three alike in every engine).
ENGINE, CONTROLLER, ENCODERS, MARKER = "engine", "controller", "encoders", "marker"
#: The moving material groups (a per-body velocity damping means nothing for the static floor).
MOVING_GROUPS = ("gripper", *MATERIALS)


@dataclass(frozen=True)
class Kind:
    """One family of parameters.

    ``name``: the kind (``joint_damping``); a parameter of a per-joint or per-link kind is ``<name>_<n>``
    (n = 1 for the first driven joint), of a material kind ``<name>_<group>``, of the object kind
    ``mass_<shape>_<material>``, of the marker ``<name>_<axis>``; a global kind is its own name.
    ``space``: the first space that holds it (the spaces are nested: shared, individual, extended,
    calibrated).  ``engines``: the engines that have it, each with the material groups it maps for a
    material kind (empty for other kinds).  ``apply``: for a drive-train kind, the ``Engine`` method
    that applies it.
    """

    name: str
    scope: str
    unit: str
    space: str
    applied_by: str
    bounds: str  # the range rule, in words (docs/parameters.md)
    generic: str  # the generic value, in words
    description: str  # one parameter's description; {n}, {what} and {group} are filled in
    engines: dict[str, tuple[str, ...]] = field(default_factory=dict)
    apply: str | None = None
    #: the first space that holds it for the seed paper's MICO, where it is not ``space``: the drive-train kinds
    #: go in the MICO's ``drivetrain`` space only, so that its spaces (and every number measured with them) stay
    #: the paper's and the earlier sessions'
    mico_space: str | None = None

    def home(self, mico: bool) -> str:
        """The first space that holds this kind, for the bundled MICO (``mico``) or another robot."""
        return (self.mico_space or self.space) if mico else self.space

    def names(self, n_joints: int, groups: Iterable[str] = CONTACT_GROUPS) -> list[str]:
        """The parameter names of this kind for a robot with ``n_joints`` driven joints (material kinds: of
        ``groups``).

        Args:
            n_joints: the robot's driven joints.
            groups: the material groups of a material kind.

        Returns:
            The names, in the spaces' order.
        """
        if self.scope in (JOINT, LINK):
            return [f"{self.name}_{i}" for i in range(1, n_joints + 1)]
        if self.scope == MATERIAL:
            return [f"{self.name}_{g}" for g in groups]
        if self.scope == OBJECT:
            return [f"{self.name}_{shape}_{material}" for shape in SHAPES for material in MATERIALS]
        if self.scope == AXIS:
            return [f"{self.name}_{a}" for a in "xyz"]
        return [self.name]

    def engine_names(self, engine: str, n_joints: int) -> list[str]:
        """The names of this kind that ``engine`` has (none if it lacks the kind).

        Args:
            engine: an engine's name.
            n_joints: the robot's driven joints.

        Returns:
            The names.
        """
        if engine not in self.engines:
            return []
        groups = self.engines[engine] if self.scope == MATERIAL else CONTACT_GROUPS
        return self.names(n_joints, groups)


def _all(*, but: tuple[str, ...] = ()) -> dict[str, tuple[str, ...]]:
    return {engine: () for engine in sorted(ALL_ENGINES) if engine not in but}


def _groups(**by_engine: tuple[str, ...]) -> dict[str, tuple[str, ...]]:
    return {engine.replace("_", "-"): groups for engine, groups in by_engine.items()}


_RIGID = _all()
_EVERY = CONTACT_GROUPS
#: The kinds, in the order the spaces hold them.
KINDS: tuple[Kind, ...] = (
    Kind("timestep", GLOBAL, "s", "shared", ENGINE, "[0.001, 0.05]", "the engine's own", "physics time step", _RIGID),
    Kind(
        "mass_link",
        LINK,
        "kg",
        "shared",
        ENGINE,
        "[0.7, 1.3] x the link's nominal mass ([0.25, 2] x a mass estimated from the link's geometry)",
        "the description's",
        "mass of {what}",
        _RIGID,
    ),
    Kind(
        "mass",
        OBJECT,
        "kg",
        "shared",
        ENGINE,
        "[0.7, 1.3] x the object's nominal mass",
        "the task's object's",
        "mass of the {material} {shape}",
        _RIGID,
    ),
    Kind(
        "max_torque_joint",
        JOINT,
        "N m",
        "shared",
        ENGINE,
        "[0.7, 1.3] x the described effort, else [100, 9000]",
        "the described effort, else the robot's default",
        "motor force limit of joint {n}",
        _RIGID,
    ),
    Kind(
        "max_velocity_joint",
        JOINT,
        "deg/s",
        "shared",
        CONTROLLER,
        "[10, 40]",
        "the task's max velocity",
        "velocity clamp of joint {n}'s controller",
        _all(),
    ),
    Kind(
        "lateral_friction",
        MATERIAL,
        "",
        "shared",
        ENGINE,
        "[0.0001, 1.25]",
        "the engine's own",
        "sliding friction coefficient of the {group}",
        _groups(mujoco=_EVERY, mujoco_warp=_EVERY, pybullet=_EVERY, ode=_EVERY, dart=_EVERY, drake=_EVERY),
    ),
    Kind(
        "joint_damping",
        JOINT,
        "N m s/rad",
        "individual",
        ENGINE,
        "[0.0001, 0.9]",
        "the description's",
        "viscous damping of joint {n}",
        _RIGID,
    ),
    Kind(
        "rolling_friction",
        MATERIAL,
        "",
        "individual",
        ENGINE,
        "[0.0001, 1.25]",
        "the engine's own",
        "rolling friction of the {group}",
        _groups(mujoco=_EVERY, mujoco_warp=_EVERY, pybullet=_EVERY, ode=_EVERY),
    ),
    Kind(
        "spinning_friction",
        MATERIAL,
        "",
        "individual",
        ENGINE,
        "[0.0001, 1.25]",
        "the engine's own",
        "spinning (torsional) friction of the {group}",
        _groups(mujoco=_EVERY, mujoco_warp=_EVERY, pybullet=_EVERY, ode=_EVERY),
    ),
    Kind(
        "restitution",
        MATERIAL,
        "",
        "individual",
        ENGINE,
        "[0.0001, 0.9]",
        "the engine's own",
        "restitution (bounciness) of the {group}",
        _groups(pybullet=_EVERY, ode=_EVERY, dart=_EVERY),
    ),
    Kind(
        "linear_damping",
        MATERIAL,
        "",
        "individual",
        ENGINE,
        "[0.0001, 0.9]",
        "the engine's own",
        "linear velocity damping of the {group}",
        _groups(mujoco=MATERIALS, mujoco_warp=MATERIALS, pybullet=MOVING_GROUPS, ode=MOVING_GROUPS, dart=MATERIALS),
    ),
    Kind(
        "angular_damping",
        MATERIAL,
        "",
        "individual",
        ENGINE,
        "[0.0001, 0.9]",
        "the engine's own",
        "angular velocity damping of the {group}",
        _groups(mujoco=MATERIALS, mujoco_warp=MATERIALS, pybullet=MOVING_GROUPS, ode=MOVING_GROUPS, dart=MATERIALS),
    ),
    Kind(
        "command_delay",
        GLOBAL,
        "s",
        "extended",
        CONTROLLER,
        "[0, 3]",
        "0",
        "delay from the start of the recording to the first command",
        _all(),
    ),
    Kind(
        "marker_offset",
        AXIS,
        "m",
        "extended",
        MARKER,
        "[-0.05, 0.05]",
        "0",
        "motion-capture marker offset from the wrist, hand frame {axis}",
        _all(),
    ),
    Kind(
        "armature_joint",
        JOINT,
        "kg m^2",
        "extended",
        ENGINE,
        "[0, max(0.01, 2 x the joint's link inertia at the zero pose)]",
        "0 (an MJCF file: its own)",
        "reflected rotor inertia (armature) of joint {n}",
        _all(but=("pybullet", "ode", "dart")),
        apply="set_armature",
        mico_space="drivetrain",
    ),
    Kind(
        "friction_joint",
        JOINT,
        "N m",
        "extended",
        ENGINE,
        "[0, max(0.2 x the joint's generic effort, 2 x the described friction)]",
        "the description's (URDF <dynamics friction>, MJCF frictionloss), else 0",
        "Coulomb friction torque of joint {n}",
        _all(but=("pybullet", "drake")),
        apply="set_joint_friction",
        mico_space="drivetrain",
    ),
    Kind(
        "kp_joint",
        JOINT,
        "1/s",
        "extended",
        CONTROLLER,
        "[1, 40]",
        "the task's kp",
        "proportional gain of joint {n}'s position controller (a servo firmware gain)",
        _all(),
        mico_space="drivetrain",
    ),
    Kind(
        "servo_gain_joint",
        JOINT,
        "N m s/rad",
        "extended",
        ENGINE,
        "[0.1, 2] x the joint's generic gain",
        "MuJoCo's velocity servo gain (the project's servo_gain, else one simtune sets per joint: docs/robots.md)",
        "gain of joint {n}'s velocity servo (torque per rad/s of speed error: a servo's hidden velocity-loop gain)",
        {"mujoco": ()},
        apply="set_servo_gain",
        mico_space="drivetrain",
    ),
    Kind(
        "joint_offset",
        JOINT,
        "deg",
        "calibrated",
        ENCODERS,
        "[-3, 3]",
        "0",
        "encoder zero offset of joint {n} (the encoder reads the true angle plus this)",
        _all(but=("mujoco-warp",)),
    ),
    Kind(
        "compliance_joint",
        JOINT,
        "rad/(N m)",
        "calibrated",
        ENCODERS,
        "[0, 2 deg / the joint's largest gravity load] (no parameter for a joint gravity never loads)",
        "0",
        "elastic deflection of joint {n} per N m of gravity torque",
        _all(but=("mujoco-warp",)),
    ),
)
#: kind name -> kind
BY_NAME = {kind.name: kind for kind in KINDS}
#: The command delay's kind: one delay shared by every task, or (tasks tuned together) one per task.
DELAY = "command_delay"
#: A task's own command delay is named ``command_delay_<task>``.
TASK_DELAY_PREFIX = f"{DELAY}_"


def task_delay_name(task: str) -> str:
    """The name of ``task``'s own command delay (each task's recordings have their own clock)."""
    return f"{TASK_DELAY_PREFIX}{task}"


def delay_names(task: str) -> tuple[str, str]:
    """The names a command delay for ``task`` can go by, the task's own first, then the shared one."""
    return task_delay_name(task), DELAY


#: The drive-train kinds each engine applies through one method of its own (``Kind.apply``).
DRIVE_KINDS = tuple(kind for kind in KINDS if kind.apply is not None)
#: The nested spaces, smallest first (``drivetrain``: ``calibrated`` plus, for the MICO, the drive-train kinds; for
#: another robot they are in ``extended`` already, and ``drivetrain`` is ``calibrated``).
SPACE_ORDER = ("shared", "individual", "extended", "calibrated", "drivetrain")
#: Spaces that are a step of :data:`SPACE_ORDER` plus some kinds of the next, listed after the step they extend:
#: ``gains`` is ``calibrated`` plus each joint's controller gain and servo gain - a servo's hidden firmware
#: gains, without the armature and friction that a wrist marker alone cannot pin (docs/calibration.md).  For
#: another robot those kinds are in ``extended`` already, and ``gains`` is ``calibrated``.
SELECTIONS = {"gains": ("calibrated", ("kp_joint", "servo_gain_joint"))}

#: The seed paper's motor force limit range [N m], for joints whose description gives no effort.
TORQUE_RANGE = (100.0, 9000.0)
#: A described effort limit e is tuned in [low, high] x e, like the masses.
MASS_FACTORS = EFFORT_FACTORS = (0.7, 1.3)
#: A link mass estimated from its geometry (no ``<inertial>``: :mod:`simtune.robot.inertia`) m is tuned in
#: [low, high] x m: a solid of the assumed density, where a real link is a shell with motors inside.
ESTIMATED_MASS_FACTORS = (0.25, 2.0)
#: The lowest upper end of an armature range [kg m^2], and the multiple of the joint's link inertia it spans.
ARMATURE_FLOOR, ARMATURE_FACTOR = 0.01, 2.0
#: The upper end of a Coulomb joint friction range, as a fraction of the joint's generic effort.
FRICTION_FRACTION = 0.2
#: The range of the position controller's gain [1/s] (the seed tasks' kp is 10).
KP_RANGE = (1.0, 40.0)
#: A velocity servo's gain is tuned in [low, high] x its generic gain: a servo ten times softer (a hobby servo's
#: firmware, a current-limited drive) to twice as stiff (above that a clipped servo force can spin a light link:
#: simtune.robot.generate.servo_gains lowers the generic gain for the same reason)
SERVO_GAIN_FACTORS = (0.1, 2.0)
#: Range of the encoder zero offsets ``joint_offset_<n>`` [deg]: a mounting or homing error of a few degrees.
JOINT_OFFSET_RANGE = 3.0
#: The compliance range of each joint reaches this deflection [deg] under the largest gravity load the
#: joint can carry (harmonic drives of arms of the MICO's class deflect by about that much).
FULL_LOAD_DEFLECTION_DEG = 2.0
#: The ranges that are the same for every robot and every parameter of a kind.
FIXED_BOUNDS = {
    "timestep": (0.001, 0.05),
    "max_velocity_joint": (10.0, 40.0),
    "lateral_friction": (0.0001, 1.25),
    "joint_damping": (0.0001, 0.9),
    "rolling_friction": (0.0001, 1.25),
    "spinning_friction": (0.0001, 1.25),
    "restitution": (0.0001, 0.9),
    "linear_damping": (0.0001, 0.9),
    "angular_damping": (0.0001, 0.9),
    "command_delay": (0.0, 3.0),
    "marker_offset": (-0.05, 0.05),
    "kp_joint": KP_RANGE,
    "joint_offset": (-JOINT_OFFSET_RANGE, JOINT_OFFSET_RANGE),
}


#: The prior's width of each kind (``simtune tune --prior``: :func:`prior_width`), beside its range rule: ``("generic",
#: f)``, f x the parameter's generic value (a described mass is known to about 20 %: the seed paper's ranges span
#: +-30 %); ``("range", f)``, f x its range's width (a damping, a friction, an armature: a description rarely knows
#: them, so a quarter of the range; the encoders' and the marker's offsets: half the range, wide, the data set them).
#: A generic value of 0 (or none) takes the range's rule at the same f: its width is never 0.  None: no prior - a
#: command delay is the recording's clock (when its operator pressed record), not the arm's, and has no generic value.
PRIOR_WIDTHS: dict[str, tuple[str, float] | None] = {
    "timestep": ("generic", 1.0),  # a numerical choice, not the arm's: 2 ms is a width from 4 ms
    "mass_link": ("generic", 0.2),
    "mass": ("generic", 0.2),
    "max_torque_joint": ("generic", 0.2),
    "max_velocity_joint": ("range", 0.25),
    "lateral_friction": ("range", 0.25),
    "joint_damping": ("range", 0.25),
    "rolling_friction": ("range", 0.25),
    "spinning_friction": ("range", 0.25),
    "restitution": ("range", 0.25),
    "linear_damping": ("range", 0.25),
    "angular_damping": ("range", 0.25),
    "command_delay": None,
    "marker_offset": ("range", 0.5),
    "armature_joint": ("range", 0.25),
    "friction_joint": ("range", 0.25),
    "kp_joint": ("range", 0.25),
    "servo_gain_joint": ("generic", 0.5),
    "joint_offset": ("range", 0.5),
    "compliance_joint": ("range", 0.5),
}


def kind_of(name: str) -> Kind | None:
    """The kind of parameter ``name`` (``joint_damping_3``: ``joint_damping``; ``command_delay_cube``: the command
    delay's), the longest kind name it starts with; None for a name of no kind.

    Args:
        name: a parameter name.

    Returns:
        The kind, or None.
    """
    kinds = [kind for kind in BY_NAME if name == kind or name.startswith(f"{kind}_")]
    return BY_NAME[max(kinds, key=len)] if kinds else None


def prior_width(name: str, low: float, high: float, generic: float) -> float | None:
    """The prior's width of parameter ``name`` (its kind's :data:`PRIOR_WIDTHS` rule): how far from its generic
    value a tuned value may go at the cost of one noise floor (:class:`simtune.objective.Prior`).

    Args:
        name: a parameter name of a kind.
        low: its range's low end.
        high: its range's high end.
        generic: its generic value (the prior's centre).

    Returns:
        The width, in the parameter's unit, above 0; None for a kind the prior holds not (a command delay).

    Raises:
        KeyError: for a name of no kind.
    """
    kind = kind_of(name)
    if kind is None:
        raise KeyError(f"parameter {name!r} is of no kind")
    if (width_rule := PRIOR_WIDTHS[kind.name]) is None:
        return None
    rule, factor = width_rule
    if rule == "generic" and generic != 0 and math.isfinite(generic):
        return factor * abs(generic)
    return factor * (high - low)


#: the velocity clamp's range [deg/s] of an own robot's joint without a velocity limit in its description: from a
#: slow arm's to about what industrial arms' joints turn at (the MICO keeps the seed paper's 10-40)
OPEN_VELOCITY_RANGE = (10.0, 180.0)
#: the bundled MICO's name (simtune.robot.mico.MICO), whose ranges stay the seed paper's
MICO_NAME = "kinova_mico"


def velocity_bounds(robot: RobotDescription, limit_rad_s: float | None) -> tuple[float, float]:
    """The range of a joint's velocity clamp (``max_velocity_joint_<n>``) [deg/s].

    The bundled MICO keeps the seed paper's (10, 40); a project's ``max_velocity_deg`` is taken as stated; an own
    robot's otherwise reaches from 10 up to its joint's velocity limit from the description, 40 at the least (probe 5:
    a task commanded at 60 deg/s was clamped at 40 on every robot, and the fit pushed a true damping to 0 to make up
    for it), and :data:`OPEN_VELOCITY_RANGE` where the description gives none.

    Args:
        robot: the robot.
        limit_rad_s: the joint's velocity limit in its description [rad/s] (None: not given).

    Returns:
        (low, high) [deg/s].
    """
    if robot.max_velocity_range is not None:
        return robot.max_velocity_range
    if robot.name == MICO_NAME:  # the bundled MICO, a project's variants of it included
        return FIXED_BOUNDS["max_velocity_joint"]
    if limit_rad_s is None or not math.isfinite(limit_rad_s) or limit_rad_s <= 0:
        return OPEN_VELOCITY_RANGE
    # never narrower than the seed paper's range: a slow joint's task may still clamp at up to 40
    return OPEN_VELOCITY_RANGE[0], max(FIXED_BOUNDS["max_velocity_joint"][1], math.degrees(limit_rad_s))


def joint_bounds(kind: str, robot: RobotDescription, index: int) -> tuple[float, float] | None:
    """The range of a per-joint or per-link kind's parameter of driven joint ``index`` (0 = the first).

    Args:
        kind: the kind's name.
        robot: the robot.
        index: the driven joint.

    Returns:
        (low, high), or None where the joint has no such parameter (a compliance gravity never loads).
    """
    joint = robot.joint_by_name[robot.arm_joints[index]]
    if kind == "max_velocity_joint":
        return velocity_bounds(robot, joint.velocity)
    if kind in FIXED_BOUNDS:
        return FIXED_BOUNDS[kind]
    if kind == "mass_link":
        m = robot.nominal[index]
        low, high = ESTIMATED_MASS_FACTORS if robot.driven_links[index] in robot.estimated_masses else MASS_FACTORS
        return low * m, high * m
    if kind == "max_torque_joint":
        if joint.effort is None:  # the paper's range, reaching up to what the arm's own weight asks (an industrial arm)
            generic = robot.generic_effort(index)
            return TORQUE_RANGE[0], max(TORQUE_RANGE[1], EFFORT_FACTORS[1] * generic)
        return EFFORT_FACTORS[0] * joint.effort, EFFORT_FACTORS[1] * joint.effort
    if kind == "armature_joint":
        inertia = ARMATURE_FACTOR * float(robot.joint_inertias()[index])
        return 0.0, max(ARMATURE_FLOOR, inertia, 2.0 * joint.armature)
    if kind == "friction_joint":
        return 0.0, max(FRICTION_FRACTION * robot.generic_effort(index), 2.0 * joint.friction)
    if kind == "servo_gain_joint":
        gain = servo_gains(robot)[index]
        return SERVO_GAIN_FACTORS[0] * gain, SERVO_GAIN_FACTORS[1] * gain
    if kind == "compliance_joint":
        load = float(robot.gravity_load_bounds()[index])
        return (0.0, math.radians(FULL_LOAD_DEFLECTION_DEG) / load) if load > 0 else None
    raise KeyError(f"kind {kind!r} is not per joint")


def generic_joint_value(kind: str, robot: RobotDescription, index: int, task_kp: float) -> float:
    """The generic value of a drive-train or controller kind's parameter of driven joint ``index``, where the
    engines have no value of their own: what a run that does not tune it simulates.

    Args:
        kind: ``armature_joint``, ``friction_joint``, ``kp_joint`` or ``servo_gain_joint``.
        robot: the robot.
        index: the driven joint (0 = the first).
        task_kp: the task's controller gain [1/s].

    Returns:
        The value.
    """
    if kind == "friction_joint":
        return float(robot.joint_by_name[robot.arm_joints[index]].friction)
    if kind == "kp_joint":
        return float(task_kp)
    if kind == "servo_gain_joint":
        return float(servo_gains(robot)[index])
    return float(robot.joint_by_name[robot.arm_joints[index]].armature)  # 0 but an MJCF file's own


def engine_parameters(engine: str, n_joints: int, applied_by: Iterable[str] = (ENGINE,)) -> frozenset[str]:
    """The parameter names ``engine`` has, of the kinds applied by ``applied_by``.

    Args:
        engine: an engine's name.
        n_joints: the robot's driven joints.
        applied_by: who applies the kinds wanted (default: the engine itself).

    Returns:
        The names.
    """
    who = set(applied_by)
    return frozenset(name for kind in KINDS if kind.applied_by in who for name in kind.engine_names(engine, n_joints))


def applied_outside(n_joints: int, applied_by: Iterable[str] = (CONTROLLER, ENCODERS, MARKER)) -> frozenset[str]:
    """The names of the kinds simtune applies itself (controller, encoders, marker), whichever engine runs.

    Args:
        n_joints: the robot's driven joints.
        applied_by: which of simtune's models (default: all three).

    Returns:
        The names.
    """
    who = set(applied_by)
    return frozenset(name for kind in KINDS if kind.applied_by in who for name in kind.names(n_joints))


def kinds_of(names: Iterable[str]) -> set[str]:
    """The kinds of the per-joint or per-link parameter names among ``names``.

    Args:
        names: parameter names.

    Returns:
        The kinds' names.
    """
    found = set()
    for name in names:
        stem, _, n = name.rpartition("_")
        if n.isdigit() and stem in BY_NAME and BY_NAME[stem].scope in (JOINT, LINK):
            found.add(stem)
    return found


#: the kinds whose values may be negative: an encoder's zero offset, the marker's offset on the hand, a clock's
#: delay; every other kind (a mass, a damping, a friction, a gain, a time step ...) is never below 0 on any arm
SIGNED_KINDS = frozenset({"joint_offset", "marker_offset", DELAY})


def never_negative(name: str) -> bool:
    """Whether parameter ``name`` is physically at least 0 (a damping: yes; an encoder offset: no).

    Args:
        name: a parameter name.

    Returns:
        True for a parameter of a kind of :data:`KINDS` outside :data:`SIGNED_KINDS`; False for those (a task's own
        delay among them) and for a name of no kind.
    """
    kinds = [kind for kind in BY_NAME if name == kind or name.startswith(f"{kind}_")]
    return bool(kinds) and max(kinds, key=len) not in SIGNED_KINDS


def per_joint_kind(name: str) -> tuple[str, int] | None:
    """(kind, n) of a per-joint or per-link parameter name (``joint_damping_3`` -> ("joint_damping", 3)).

    Args:
        name: a parameter name.

    Returns:
        The kind and the joint's number (1 = the first), or None for another name.
    """
    stem, _, n = name.rpartition("_")
    if n.isdigit() and stem in BY_NAME and BY_NAME[stem].scope in (JOINT, LINK):
        return stem, int(n)
    return None


def lacking(engine: str) -> list[str]:
    """The kinds ``engine`` lacks (docs/parameters.md lists them; a value for one is refused).

    Args:
        engine: an engine's name.

    Returns:
        The kinds' names.
    """
    return [kind.name for kind in KINDS if engine not in kind.engines]


def outside_generics(n_joints: int, max_velocity_deg: float, kp: float) -> dict[str, float]:
    """The generic values of the controller's and the marker model's kinds (what an untuned run uses: the task's
    clamp and gain, no delay, no marker offset).

    Args:
        n_joints: the robot's driven joints.
        max_velocity_deg: the task's velocity clamp [deg/s].
        kp: the task's controller gain [1/s].

    Returns:
        Parameter name -> value.
    """
    values = {name: float(max_velocity_deg) for name in BY_NAME["max_velocity_joint"].names(n_joints)}
    values |= {name: float(kp) for name in BY_NAME["kp_joint"].names(n_joints)}
    values |= dict.fromkeys((*BY_NAME["command_delay"].names(n_joints), *BY_NAME["marker_offset"].names(0)), 0.0)
    return values
