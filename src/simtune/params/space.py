"""Parameter spaces: what is tuned, over which range.

``shared`` (31 values) and ``individual`` (57) are the seed paper's Table I;
``extended`` adds what the real recordings show the paper's set lacks: the
delay between the start of the recording and the start of the commanded
motion, where the motion-capture marker sits on the hand, and the drive train's
armature, Coulomb joint friction, controller gain and servo gain per joint.  ``calibrated``
adds the arm's calibration errors: encoder zero offsets and the joints'
elastic deflection under gravity (:mod:`simtune.engines.controller`).

A space is engine independent but robot dependent: the per-joint parameters
come from the task's robot (:func:`robot_spaces`, rules in docs/parameters.md);
the module-level tables are the bundled MICO's.  Every kind of parameter, its range rule
and the engines that have it are listed once, in :mod:`simtune.params.kinds`.  Each engine declares which
parameters its API really has (:attr:`simtune.engines.base.Engine.supported`); a
parameter an engine lacks is left out of that engine's search space, never faked.
"""

from __future__ import annotations

import json
import math
from collections.abc import Collection, Mapping
from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path

import numpy as np

from simtune.errors import ConfigError
from simtune.params.kinds import (
    AXIS,
    BY_NAME,
    DELAY,
    FIXED_BOUNDS,
    JOINT,
    KINDS,
    LINK,
    MASS_FACTORS,
    MATERIAL,
    OBJECT,
    SELECTIONS,
    SPACE_ORDER,
    TASK_DELAY_PREFIX,
    Kind,
    joint_bounds,
    task_delay_name,
)
from simtune.robot.description import RobotDescription
from simtune.robot.mico import MICO
from simtune.tasks.spec import CONTACT_GROUPS, MATERIALS

#: Nominal masses [kg] the seed paper's mass ranges are relative to (links 1..6 of the MICO, then objects).
ARM_MASS_NOMINAL = MICO.nominal
OBJECT_MASS_NOMINAL = {
    "cube": (0.07, 0.46),
    "cylinder": (0.12, 0.78),
    "cone": (0.04, 0.17),
    "cuboid": (0.14, 0.85),
}


@dataclass(frozen=True)
class Parameter:
    name: str
    low: float
    high: float
    unit: str
    description: str

    def check(self, value: float, where: str = "") -> float:
        """``value`` as a float, or a ConfigError naming the parameter and its range."""
        at = f"{where}: " if where else ""
        # a number, not something that merely converts to one (true, "0.5")
        if isinstance(value, bool | str) or not isinstance(value, int | float | np.integer | np.floating):
            shown = json.dumps(value) if isinstance(value, bool | str | None) else repr(value)
            raise ConfigError(f"{at}parameter {self.name!r}: {shown} is not a number")
        try:
            v = float(value)
        except OverflowError:  # an integer past any float (10**400): out of every range, and too long to print
            digits = int(int(value).bit_length() * math.log10(2)) + 1
            raise ConfigError(
                f"{at}parameter {self.name!r} = an integer of about {digits} digits is outside its range "
                f"[{self.low:g}, {self.high:g}] {self.unit}"
            ) from None
        if not math.isfinite(v) or v < self.low or v > self.high:
            low, high = self.shown_bounds()
            # the bound crossed in as many digits as show that it is (0.00938381 past 0.009383807, not 0.00938381)
            if v < self.low:
                low = _apart_text(self.low, v)
            elif v > self.high:
                high = _apart_text(self.high, v)
            raise ConfigError(
                f"{at}parameter {self.name!r} = {value!r} is outside its range [{low}, {high}] {self.unit}"
            )
        return v

    def shown_bounds(self) -> tuple[str, str]:
        """The range's bounds as text, each in the fewest significant digits (6 or more) whose value lies in the
        range: a bound copied from ``simtune params`` into a parameter file is accepted.

        Returns:
            The low and the high bound's text.
        """
        return _bound_text(self.low, self.low, self.high), _bound_text(self.high, self.low, self.high)


def _bound_text(bound: float, low: float, high: float) -> str:
    """``bound`` in the fewest significant digits, 6 or more, that read back lie in [``low``, ``high``] (17 always do:
    they are its exact value)."""
    for digits in range(6, 17):
        text = f"{bound:.{digits}g}"
        if low <= float(text) <= high:
            return text
    return repr(float(bound))


def _apart_text(bound: float, value: float) -> str:
    """``bound`` in the fewest significant digits, 6 or more, that read back lie on its side of ``value`` (a value
    past it)."""
    for digits in range(6, 17):
        text = f"{bound:.{digits}g}"
        if (float(text) < value) == (bound < value) and float(text) != value:
            return text
    return repr(float(bound))


def _kind_parameters(kind: Kind, robot: RobotDescription) -> list[Parameter]:
    """The parameters of ``kind`` for ``robot``, with their ranges (:mod:`simtune.params.kinds`' rules)."""
    if kind.scope in (JOINT, LINK):
        ps = []
        for i, link in enumerate(robot.driven_links, start=1):
            bounds = joint_bounds(kind.name, robot, i - 1)
            if bounds is not None:
                what = robot.link_by_name[link].label or f"link {link}"
                text = kind.description.format(n=i, what=what)
                ps.append(Parameter(f"{kind.name}_{i}", bounds[0], bounds[1], kind.unit, text))
        return ps
    if kind.scope == OBJECT:
        low, high = MASS_FACTORS
        return [
            Parameter(
                f"{kind.name}_{shape}_{material}",
                low * m,
                high * m,
                kind.unit,
                kind.description.format(shape=shape, material=material),
            )
            for shape, nominal in OBJECT_MASS_NOMINAL.items()
            for material, m in zip(MATERIALS, nominal)
        ]
    low, high = FIXED_BOUNDS[kind.name]
    if kind.scope == MATERIAL:
        return [
            Parameter(f"{kind.name}_{g}", low, high, kind.unit, kind.description.format(group=g))
            for g in CONTACT_GROUPS
        ]
    if kind.scope == AXIS:
        return [Parameter(f"{kind.name}_{a}", low, high, kind.unit, kind.description.format(axis=a)) for a in "xyz"]
    return [Parameter(kind.name, low, high, kind.unit, kind.description)]


@lru_cache(maxsize=8)
def robot_spaces(robot: RobotDescription) -> dict[str, tuple[Parameter, ...]]:
    """The spaces of :data:`~simtune.params.kinds.SPACE_ORDER` for ``robot``'s driven joints and links, each the
    one before it plus the kinds (:data:`simtune.params.kinds.KINDS`) it adds, and after the step each selection of
    :data:`~simtune.params.kinds.SELECTIONS` extends, that selection: its step plus the parameters of its kinds, in
    the order the whole set holds them (so that no nested space changes its order)."""
    nested: dict[str, tuple[Parameter, ...]] = {}
    held: list[Parameter] = []
    mico = robot == MICO
    for space in SPACE_ORDER:
        held += [p for kind in KINDS if kind.home(mico) == space for p in _kind_parameters(kind, robot)]
        nested[space] = tuple(held)
    spaces: dict[str, tuple[Parameter, ...]] = {}
    for space, params in nested.items():
        spaces[space] = params
        for name, (step, kinds) in SELECTIONS.items():
            if step == space:
                added = {p.name for kind in kinds for p in _kind_parameters(BY_NAME[kind], robot)}
                spaces[name] = tuple(p for p in held if p in params or p.name in added)
    return spaces


def robot_parameters(robot: RobotDescription) -> dict[str, Parameter]:
    """Every parameter known for ``robot``, by name."""
    return {p.name: p for p in robot_spaces(robot)[SPACE_ORDER[-1]]}


#: The bundled MICO's spaces (the seed paper's) and parameters.
SPACES: dict[str, tuple[Parameter, ...]] = robot_spaces(MICO)
PARAMETERS: dict[str, Parameter] = robot_parameters(MICO)


@dataclass(frozen=True)
class ParameterSpace:
    """An ordered set of parameters, with conversion between vectors and name -> value dicts."""

    name: str
    parameters: tuple[Parameter, ...]

    @property
    def names(self) -> list[str]:
        return [p.name for p in self.parameters]

    @property
    def bounds(self) -> list[tuple[float, float]]:
        return [(p.low, p.high) for p in self.parameters]

    def __len__(self) -> int:
        return len(self.parameters)

    def to_dict(self, x) -> dict[str, float]:
        return {p.name: float(v) for p, v in zip(self.parameters, np.asarray(x, dtype=float))}

    def to_vector(self, values: dict[str, float]) -> np.ndarray:
        return np.array([values[p.name] for p in self.parameters], dtype=float)

    def vector_within_bounds(self, values: Mapping[str, float]) -> np.ndarray:
        """``values`` as a vector, each clipped into its range; a parameter without a value starts mid-range."""
        return np.array([min(max(values.get(p.name, (p.low + p.high) / 2), p.low), p.high) for p in self.parameters])


def task_delay(task: str) -> Parameter:
    """The command delay of one task's recordings (each recording's clock starts when its operator pressed record)."""
    shared = PARAMETERS[DELAY]
    return Parameter(task_delay_name(task), shared.low, shared.high, shared.unit, f"{shared.description}, task {task}")


def find_parameter(name: str, known: Mapping[str, Parameter] | None = None) -> Parameter | None:
    """The parameter called ``name``: one of ``known`` (default: the MICO's :data:`PARAMETERS`) or a task's
    own command delay; None if unknown."""
    known = PARAMETERS if known is None else known
    if name in known:
        return known[name]
    if name.startswith(TASK_DELAY_PREFIX) and len(name) > len(TASK_DELAY_PREFIX):
        return task_delay(name[len(TASK_DELAY_PREFIX) :])
    return None


def is_supported(name: str, supported: frozenset[str]) -> bool:
    return name in supported or (name.startswith(TASK_DELAY_PREFIX) and DELAY in supported)


def get_space(
    name: str,
    supported: frozenset[str] | None = None,
    only: list[str] | None = None,
    *,
    robot: RobotDescription | None = None,
    tasks: list[str] | None = None,
    shared_clock: Collection[str] = (),
) -> ParameterSpace:
    """The space ``name`` for ``robot`` (default the MICO), restricted to the parameters in ``supported``
    (an engine's, :meth:`Engine.supported` for the same robot) and to ``only``.

    With several ``tasks`` (tuned together), ``command_delay`` becomes one delay per task
    (``command_delay_<task>``, in its place): the delay is a property of each recording's clock,
    not of the physics.  ``--only command_delay`` then names all of them.  The tasks in ``shared_clock``
    (commands logged on their recordings' clock: ``TaskSpec.shared_clock``) get none of their own: they share
    ``command_delay``, the robot's, which stays where any of them is tuned.
    """
    known = robot_parameters(robot) if robot is not None else PARAMETERS
    try:
        params = robot_spaces(robot)[name] if robot is not None else SPACES[name]
    except KeyError:
        raise ConfigError(f"unknown parameter space {name!r} (known: {', '.join(SPACES)})") from None
    if supported is not None:
        params = tuple(p for p in params if p.name in supported)
    if only:
        names = {p.name for p in params}
        for wanted in only:
            if wanted not in names:
                why = "unknown parameter" if wanted not in known else f"not in space {name!r} for this engine"
                raise ConfigError(f"--only: {wanted!r}: {why} (see `simtune params`)")
        params = tuple(p for p in params if p.name in only)
    if tasks is not None and len(tasks) > 1:
        own = [task_delay(t) for t in tasks if t not in shared_clock]
        shared = [p for p in params if p.name == DELAY and any(t in shared_clock for t in tasks)]
        params = tuple(q for p in params for q in ([*own, *shared] if p.name == DELAY else [p]))
    return ParameterSpace(name, params)


def validate_params(
    values: dict, supported: frozenset[str], engine: str, where: str = "", robot: RobotDescription | None = None
) -> dict[str, float]:
    """Check a name -> value mapping against the parameters known for ``robot`` (default the MICO) and
    what ``engine`` supports."""
    at = f"{where}: " if where else ""
    known = robot_parameters(robot) if robot is not None else PARAMETERS
    out = {}
    for name, value in values.items():
        param = find_parameter(name, known)
        if param is None:
            raise ConfigError(f"{at}unknown parameter {name!r} (see `simtune params`)")
        if not is_supported(name, supported):
            raise ConfigError(f"{at}engine {engine!r} has no parameter {name!r} (see docs/parameters.md)")
        out[name] = param.check(value, where)
    return out


def read_params_file(path: Path, engine: str | None = None, robot: RobotDescription | None = None) -> dict:
    """Parameter values from a JSON file: ``{"params": {...}}`` as ``tune`` writes it, or a flat mapping.

    A file in the first form may say which engine and space its values are for
    (``best_params.json`` and ``truth.json`` do): with ``engine``, a file made for
    another engine is refused; its values must lie in the space it names, as that space is for ``robot``
    (default the MICO: an own robot's spaces hold its own joints' and links' parameters).  An empty
    file, or one that is not an object of names and values, is refused.

    Args:
        path: the JSON file.
        engine: the engine the values are for (None: any).
        robot: the robot the values are for (None: the bundled MICO).

    Returns:
        Parameter name -> value, as the file gives them (unchecked against their ranges: ``validate_params``).
    """
    try:
        data = json.loads(Path(path).read_text(encoding="utf-8-sig"))  # a byte-order mark is harmless
    except FileNotFoundError:
        raise ConfigError(f"{path}: no such parameter file") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise ConfigError(f"{path}: cannot read ({exc})") from None
    except json.JSONDecodeError as exc:
        raise ConfigError(f"{path} line {exc.lineno}: not valid JSON ({exc.msg})") from None
    if not isinstance(data, dict):
        raise ConfigError(f"{path}: expected a JSON object of parameter names and values, got {type(data).__name__}")
    if "params" in data:
        values = data["params"]
        if not isinstance(values, dict):
            raise ConfigError(f"{path}: field 'params' must be an object of parameter names and values")
        _check_file_fields(path, data, values, engine, robot)
    else:
        values = data
    if not values:
        raise ConfigError(f"{path}: no parameter values in it")
    return values


def _check_file_fields(
    path: Path, data: dict, values: dict, engine: str | None, robot: RobotDescription | None
) -> None:
    """The fields beside ``params`` that say what the values are: ``parameters``, ``engine``, ``space``."""
    listed = data.get("parameters")
    if listed is not None:  # a run's file says which parameters it holds: all of them, no others
        if not isinstance(listed, list):
            raise ConfigError(f"{path}: field 'parameters' must be a list of parameter names")
        for name in listed:
            if name not in values:
                raise ConfigError(f"{path}: no value for parameter {name!r}, which the file lists")
        for name in values:
            if name not in listed:
                raise ConfigError(f"{path}: parameter {name!r} is not among those the file lists")
    made_for = data.get("engine")
    if made_for is not None and engine is not None and made_for != engine:
        raise ConfigError(
            f"{path}: field 'engine' says these values are for {made_for!r}, not {engine!r} "
            f"(use --engine {made_for}, or a file made for {engine})"
        )
    space = data.get("space")
    if space is not None:
        if space not in SPACES:
            raise ConfigError(f"{path}: field 'space': unknown parameter space {space!r} (known: {', '.join(SPACES)})")
        names = {p.name for p in (SPACES[space] if robot is None else robot_spaces(robot)[space])}
        for name in values:
            if name not in names and not (name.startswith(TASK_DELAY_PREFIX) and DELAY in names):
                raise ConfigError(f"{path}: parameter {name!r} is not in space {space!r}, which field 'space' names")
