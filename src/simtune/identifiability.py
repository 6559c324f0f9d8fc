"""Which parameter combinations recordings cannot tell apart, and what motion would: ``simtune check``'s
identifiability section.

The combinations are :func:`~simtune.optimize.start_check.weak_combinations` of the check's noise-weighted
Jacobian (the one rule tune's start check warns by), with the recordings' noise known: a direction is weak where its
singular value is below ``1 / CONDITION`` of the largest or where the noise leaves its 95 % interval wider than the
ranges.  Each gets a one-line suggestion of the motion that would separate it, from :data:`SEPARATING`, a table keyed
by the kinds of the direction's two leading parameters (one kind: two parameters of that kind, or one alone); the
suggestion's numbers (a step's size, a speed) come from the parameters' values at the point.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence

import numpy as np

from simtune.optimize.start_check import CONDITION, WeakDirection, weak_combinations
from simtune.params.kinds import BY_NAME, per_joint_kind

Rule = Callable[[list[int], Mapping[str, float]], str]


def _kind(name: str) -> str | None:
    """The kind of a parameter name (``command_delay_cube`` -> ``command_delay``), or None."""
    kinds = [kind for kind in BY_NAME if name == kind or name.startswith(f"{kind}_")]
    return max(kinds, key=len) if kinds else None


def _joints(joints: list[int]) -> str:
    """``joint 5`` or ``joints 2 and 3``."""
    if len(joints) == 1:
        return f"joint {joints[0]}"
    return f"joints {', '.join(map(str, joints[:-1]))} and {joints[-1]}"


def _saturate(joints: list[int], values: Mapping[str, float]) -> str:
    """A step that drives a velocity servo into its force limit: there the joint accelerates by the limit over its
    inertia (armature included) and friction, whatever the servo's gain, which below the limit scales them all."""
    if not joints:
        return "a step large enough to saturate the servo of the joint they belong to"
    n = joints[0]
    torque, gain = values.get(f"max_torque_joint_{n}"), values.get(f"servo_gain_joint_{n}")
    kp, limit = values.get(f"kp_joint_{n}"), values.get(f"max_velocity_joint_{n}")
    if not torque or not gain or not kp or not limit:
        return f"a step of joint {n} large enough to saturate its servo (its force limit reached)"
    speed = math.degrees(torque / gain)  # [deg/s] the commanded speed at which the servo's torque reaches its limit
    if speed <= limit:
        step = speed / kp
        return (
            f"a step of joint {n} large enough to saturate its servo (at least {step:.3g} deg, commanding "
            f"{speed:.3g} deg/s within its velocity limit of {limit:.3g} deg/s)"
        )
    return (
        f"a step of joint {n} that saturates its servo, which reaches its force limit only at a commanded "
        f"{speed:.3g} deg/s, above its velocity limit of {limit:.3g} deg/s: raise the task's max_velocity_deg to at "
        f"least that and step it by at least {speed / kp:.3g} deg (or load it against gravity)"
    )


def _two_speeds(joints: list[int], values: Mapping[str, float]) -> str:
    return (
        f"moves of {_joints(joints)} at two or more steady speeds, with starts and stops (Coulomb friction is the same "
        "at every speed, a damping grows with it, an armature shows only where the speed changes)"
    )


def _delay_and_speed(joints: list[int], values: Mapping[str, float]) -> str:
    return (
        "a move that starts from rest and one at a different speed"
        + (f" of {_joints(joints)}" if joints else "")
        + " (a delay shifts every move alike, a velocity limit only the fast ones)"
    )


def _delay_and_gain(joints: list[int], values: Mapping[str, float]) -> str:
    return (
        f"steps of {_joints(joints) if joints else 'a joint'} of clearly different sizes (a delay shifts each move's "
        "start alike, a gain slows each approach's end in proportion to the distance left)"
    )


def _delay_and_gain_free(joints: list[int], values: Mapping[str, float]) -> str:
    return (
        f"steps of {_joints(joints) if joints else 'the joint'} of clearly different sizes, some to rest short of "
        "its velocity limit (a gain slows each approach in proportion to the distance left, friction by the same "
        "amount at every distance)"
    )


def _gain_and_limit(joints: list[int], values: Mapping[str, float]) -> str:
    where = _joints(joints) if joints else "the joint"
    n = joints[0] if joints else None
    kp, limit = values.get(f"kp_joint_{n}"), values.get(f"max_velocity_joint_{n}")
    size = f" (below and well above {limit / kp:.3g} deg, where the clamp takes over)" if kp and limit else ""
    return f"steps of {where} both small, where the gain alone sets the speed, and large, where the limit does{size}"


def _speeds_below_limit(joints: list[int], values: Mapping[str, float]) -> str:
    where = _joints(joints) if joints else "the joint"
    n = joints[0] if joints else None
    limit = values.get(f"max_velocity_joint_{n}")
    below = f" (slower than {limit:.3g} deg/s)" if limit else ""
    return (
        f"moves of {where} at two speeds below its velocity limit{below} and one at it (the limit caps only the "
        "fast ones; friction's lag over the servo's gain slows every one)"
    )


def _gravity(joints: list[int], values: Mapping[str, float]) -> str:
    below = min(joints) if joints else None
    where = f"joint {below} and those below it" if below is not None else "the joints"
    return f"poses that load {where} differently against gravity (each link's mass pulls by its own lever arm)"


def _load(joints: list[int], values: Mapping[str, float]) -> str:
    return (
        f"poses that hold {_joints(joints) if joints else 'the joint'} against gravity by different amounts, at "
        "rest and moving (a compliance bends with the load, an encoder offset is the same at every load, an "
        "armature shows only in accelerations)"
    )


def _orientations(joints: list[int], values: Mapping[str, float]) -> str:
    return (
        f"poses that turn the hand through several orientations by {_joints(joints) if joints else 'its joints'} "
        "(an encoder offset moves the marker by the lever arm of its joint, the marker's offset by the hand's "
        "turn)"
    )


def _force_limit(joints: list[int], values: Mapping[str, float]) -> str:
    return (
        f"moves of {_joints(joints) if joints else 'the joint'} both within and at its force limit (a fast step, or "
        "a lift against gravity)"
    )


def _time_step(joints: list[int], values: Mapping[str, float]) -> str:
    return "none: the time step is the simulator's, not the arm's: hold it (leave it out of --only)"


def _object(joints: list[int], values: Mapping[str, float]) -> str:
    return "pushes of the object at two or more speeds and over different distances (mass vs friction vs damping)"


#: The motion that separates a weak combination, by the kinds of its parameters: all of them, else its two leading
#: kinds (a one-kind key: two parameters of that kind, or one alone).  Each rule is given the joints the parameters
#: belong to (1 = the first driven joint) and every parameter's value at the point.
SEPARATING: dict[frozenset[str], Rule] = {
    # the drive train's scale symmetry (below its force limit a velocity servo moves a joint by (inertia + armature)
    # / gain and friction / gain only): at the limit the gain drops out
    frozenset({"armature_joint", "friction_joint", "servo_gain_joint"}): _saturate,
    frozenset({"armature_joint", "servo_gain_joint"}): _saturate,
    frozenset({"friction_joint", "servo_gain_joint"}): _saturate,
    frozenset({"joint_damping", "servo_gain_joint"}): _saturate,
    frozenset({"max_torque_joint", "servo_gain_joint"}): _force_limit,
    frozenset({"servo_gain_joint"}): _saturate,
    frozenset({"armature_joint", "friction_joint"}): _two_speeds,
    frozenset({"armature_joint", "joint_damping"}): _two_speeds,
    frozenset({"friction_joint", "joint_damping"}): _two_speeds,
    frozenset({"armature_joint"}): _two_speeds,
    frozenset({"friction_joint"}): _two_speeds,
    frozenset({"joint_damping"}): _two_speeds,
    frozenset({"command_delay", "max_velocity_joint"}): _delay_and_speed,
    frozenset({"command_delay", "kp_joint"}): _delay_and_gain,
    frozenset({"command_delay"}): _delay_and_speed,
    frozenset({"kp_joint", "max_velocity_joint"}): _gain_and_limit,
    frozenset({"max_velocity_joint", "servo_gain_joint"}): _speeds_below_limit,
    frozenset({"friction_joint", "max_velocity_joint"}): _speeds_below_limit,
    frozenset({"friction_joint", "kp_joint"}): _delay_and_gain_free,
    frozenset({"kp_joint", "servo_gain_joint"}): _gain_and_limit,
    frozenset({"kp_joint"}): _gain_and_limit,
    frozenset({"max_velocity_joint"}): _gain_and_limit,
    frozenset({"mass_link"}): _gravity,
    frozenset({"mass_link", "max_torque_joint"}): _force_limit,
    frozenset({"mass_link", "compliance_joint"}): _load,
    frozenset({"mass_link", "joint_offset"}): _load,
    frozenset({"mass_link", "armature_joint"}): _load,
    frozenset({"compliance_joint", "joint_offset"}): _load,
    frozenset({"compliance_joint"}): _load,
    frozenset({"joint_offset"}): _orientations,
    frozenset({"joint_offset", "marker_offset"}): _orientations,
    frozenset({"marker_offset"}): _orientations,
    frozenset({"max_torque_joint"}): _force_limit,
    frozenset({"timestep"}): _time_step,
    frozenset({"mass"}): _object,
}


def separating_motion(parameters: Sequence[str], values: Mapping[str, float]) -> str:
    """A one-line suggestion of the motion that would tell ``parameters`` apart (the largest first).

    Args:
        parameters: a weak combination's parameters, the largest component first.
        values: every parameter's value at the point (the controller's and the servo's too, for a step's size).
    Returns:
        The suggestion, from :data:`SEPARATING` by the kinds of all the parameters, else of the first two of
        different kinds, else of the first; a generic one where the table has none.
    """
    kinds = [_kind(name) or name for name in parameters]
    distinct = list(dict.fromkeys(kinds))
    key = frozenset(distinct[:2])
    joints = sorted({j for name in parameters if (found := per_joint_kind(name)) for j in [found[1]]})
    rule = SEPARATING.get(frozenset(distinct)) or SEPARATING.get(key) or SEPARATING.get(frozenset(distinct[:1]))
    if rule is None:
        return f"a motion in which {', '.join(parameters)} each change the recorded track in their own way"
    return rule(joints, values)


def identifiability(
    names: Sequence[str],
    jacobian: np.ndarray,
    x: np.ndarray,
    widths: np.ndarray,
    noise: float,
    values: Mapping[str, float],
) -> dict:
    """The check's identifiability section: the weak combinations of a noise-weighted Jacobian, each named, with its
    sensitivity and the motion that would separate it.

    Args:
        names: the searched parameters, in column order.
        jacobian: d residuals / d (value / range) at the point.
        x: the point (values, in column order).
        widths: each parameter's range.
        noise: the 95 % half-width of one residual's noise (correlation time included).
        values: every parameter's value at the point, searched or not (a suggestion's step size).
    Returns:
        ``{"rule", "condition_number", "directions"}``; each direction: ``parameters`` (largest component first),
        ``weights`` (its signed components, in shares of each range), ``combination`` (in words), ``scaled_together``,
        ``flat`` (one parameter that moves no residual), ``relative_sensitivity`` (its singular value over the
        largest), ``interval_share`` (its 95 % interval's width across the ranges; None for a flat one) and
        ``separate_by`` (the motion that would tell them apart).
    """
    found, condition = weak_combinations(names, jacobian, np.asarray(x, float), np.asarray(widths, float), noise)
    return {
        "rule": (
            f"weakest directions of the unit-scaled Jacobian: singular value below 1/{CONDITION:g} of the largest, or "
            "a 95 % interval along it wider than the ranges"
        ),
        "condition_number": None if not math.isfinite(condition) else condition,
        "directions": [_entry(d, values) for d in found],
    }


def _entry(direction: WeakDirection, values: Mapping[str, float]) -> dict:
    return {
        "parameters": list(direction.parameters),
        "weights": [round(w, 4) for w in direction.weights],
        "combination": direction.words(),
        "scaled_together": direction.scaled_together,
        "flat": direction.flat,
        "relative_sensitivity": direction.relative,
        "interval_share": None if direction.flat else direction.interval_share,
        "separate_by": separating_motion(direction.parameters, values),
    }
