"""The peer's cheap warnings before a long search: a start on a bound, and a Jacobian that cannot tell parameters apart.

Both come from what the first local phase computes anyway (its start point and its first forward-difference
Jacobian, in the unit cube), so they cost no rollout.  They are printed once, before the global rounds, so that
a user can stop a run that cannot pin what it is asked to and change the space (``--only``, ``--space``) or the
recordings, rather than learn it from the uncertainty table at the end.

- **On a bound**: a parameter whose start value is its lower or upper bound.  Bounded least squares can move it
  only inwards, and a generic value outside the box was clipped to it: the box may be too narrow for this robot.
- **Ill-conditioned** ``J^T J``: the ratio of the largest to the smallest singular value of the unit-scaled
  Jacobian above :data:`CONDITION` (``J^T J``'s condition number is its square).  The parameters named are those
  that make up the weakest direction (components of at least :data:`SHARE` in its right singular vector): moving
  them together in that proportion changes the residuals least, so the recordings hardly tell them apart there.
  A parameter whose column is (near) zero moves no residual at all at the start and is named on its own.
"""

from __future__ import annotations

import warnings
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from simtune.params.kinds import never_negative

#: Largest to smallest singular value of the unit-scaled Jacobian above which it counts as ill-conditioned
#: (``J^T J`` then has a condition number above its square, 1e8).
CONDITION = 1e4
#: A column whose norm is below this share of the largest moves (practically) no residual.
FLAT = 1e-6
#: Smallest component of a parameter in the weakest right singular vector for it to be named.
SHARE = 0.3
#: A parameter on a bound is named when a step of 1 % of its range outwards would lower the cost (half the squared
#: residuals) by at least this share of it, to first order: the fit pushes against the bound, not merely leans on it.
PUSH = 1e-3
#: Most directions described (the weakest first).
MOST = 3
#: Smallest cosine between a weak direction and its members' values scaled by one factor for it to be called
#: their common scaling ("armature_joint_5, friction_joint_5 and servo_gain_joint_5 scaled together").
COMMON = 0.9
#: Most factor by which the relative changes of a common scaling's members may differ.
LOG_SPREAD = 2.0


class SearchWarning(UserWarning):
    """Something about the search's start a user may want to act on before it runs long."""


def pushed_past_bounds(
    names: Sequence[str], x: np.ndarray, lows: np.ndarray, highs: np.ndarray, gradient: np.ndarray | None
) -> list[str]:
    """The parameters of a start point that sit on a bound the fit pushes against, each as
    ``name (lower bound 0.1)``.

    A parameter on its bound is named only where the cost's gradient points out of the box (the fit would move it
    further): a damping that starts on its lower bound and that the recordings want larger is no concern.

    Args:
        names: the parameters' names, in vector order.
        x: the start point (values, not the unit cube).
        lows, highs: each parameter's bounds.
        gradient: d cost / d (value / range) at ``x`` (``J^T r``), as a share of the cost; None: every parameter on a
            bound is named.
    Returns:
        One entry per such parameter (none where the bounds are equal: nothing to search).
    """
    found = []
    for i, (name, value, low, high) in enumerate(zip(names, x, lows, highs)):
        if high <= low:
            continue
        slope = None if gradient is None else 0.01 * float(gradient[i])  # the cost's share a 1 % step moves
        if value <= low and (slope is None or slope >= PUSH):  # the cost falls as it goes down
            found.append(f"{name} (lower bound {low:g})")
        elif value >= high and (slope is None or slope <= -PUSH):
            found.append(f"{name} (upper bound {high:g})")
    return found


@dataclass(frozen=True)
class WeakDirection:
    """A combination of parameters that the residuals hardly tell apart: a weak right singular vector of the
    unit-scaled Jacobian (or one parameter whose column is (near) zero).

    ``parameters``: those that make it up (components of at least :data:`SHARE`), the largest first; ``weights``:
    their signed components (a step along the direction, in shares of each range); ``relative``: its singular value
    over the largest (0 for a flat column); ``scaled_together``: the direction is (within :data:`COMMON`) that of the
    members' values scaled by one common factor; ``interval_share``: with the residuals' noise known, the width of
    the 95 % interval along it, as a share of the ranges (above 1: the recordings do not pin it within them).
    """

    parameters: tuple[str, ...]
    weights: tuple[float, ...]
    relative: float
    scaled_together: bool = False
    interval_share: float | None = None

    @property
    def flat(self) -> bool:
        """Whether it is one parameter that moves no residual."""
        return self.relative == 0.0

    def words(self) -> str:
        """The combination in words: ``a, b and c scaled together``, ``a up, b down (0.9 : 0.4 of their ranges)``,
        or ``a`` (one parameter)."""
        names = list(self.parameters)
        if len(names) == 1:
            return names[0]
        if self.scaled_together:
            return f"{', '.join(names[:-1])} and {names[-1]} scaled together"
        lead = 1.0 if self.weights[0] >= 0 else -1.0
        moves = ", ".join(f"{n} {'up' if w * lead >= 0 else 'down'}" for n, w in zip(names, self.weights))
        shares = " : ".join(f"{abs(w):.2g}" for w in self.weights)
        return f"{moves} ({shares} of their ranges)"


def weak_combinations(
    names: Sequence[str],
    jacobian: np.ndarray,
    values: np.ndarray | None = None,
    widths: np.ndarray | None = None,
    noise: float | None = None,
) -> tuple[list[WeakDirection], float]:
    """What a unit-scaled Jacobian cannot resolve, as named combinations: what tune's start check warns of and
    ``simtune check`` lists (one rule for both).

    A direction is weak where its singular value is below ``1 / CONDITION`` of the largest, or (with ``noise``) where
    the recordings' noise leaves its 95 % interval wider than the ranges (the rule by which
    :mod:`simtune.uncertainty` calls a parameter unidentifiable).

    Args:
        names: the parameters' names, in column order.
        jacobian: d residuals / d (value / range), shape (residuals, parameters).
        values: the parameters' values at the point (to tell a common scaling); None: never told.
        widths: each parameter's range (with ``values``).
        noise: the 95 % half-width of one residual's noise (1.96 x its standard deviation, its correlation time
            included), in the residuals' units; None: the condition rule alone.
    Returns:
        ``(directions, condition)``: the parameters whose column is (near) zero, each alone, then the weak
        directions among the others, weakest first (at most :data:`MOST`, a set of parameters once); and the ratio
        of the largest to the smallest singular value of the others (``inf`` where one is zero, ``nan`` for a
        Jacobian with no finite entries to read).
    """
    jacobian = np.asarray(jacobian, dtype=float)
    if jacobian.ndim != 2 or jacobian.size == 0 or not np.all(np.isfinite(jacobian)):
        return [], float("nan")
    norms = np.linalg.norm(jacobian, axis=0)
    largest = float(norms.max())
    if largest == 0.0:
        return [WeakDirection((name,), (1.0,), 0.0) for name in names], float("inf")
    moving = norms > FLAT * largest
    found = [WeakDirection((name,), (1.0,), 0.0) for name, m in zip(names, moving) if not m]
    kept = [i for i, m in enumerate(moving) if m]
    _, s, vt = np.linalg.svd(jacobian[:, moving], full_matrices=False)
    condition = float(s[0] / s[-1]) if s[-1] > 0 else float("inf")
    sets: list[set[str]] = []
    for k in range(len(s) - 1, -1, -1):
        if len(sets) >= MOST:
            break
        interval = 2.0 * noise / s[k] if noise is not None and s[k] > 0 else None
        if s[k] * CONDITION >= s[0] and not (interval is not None and interval > 1.0):
            break
        share = np.abs(vt[k])
        order = [i for i in np.argsort(-share) if share[i] >= SHARE]
        together = False
        if values is not None and widths is not None and order:
            common = _common_scaling(vt[k], order, np.asarray(values, float)[kept], np.asarray(widths, float)[kept])
            together = common is not None
            order = common or order
        members = [names[kept[i]] for i in order]
        # two weak directions among the same parameters name one group, once (probe 5: "a with b with c; d; a with
        # c with b"): the set is what the user learns, the order within it only which weighs most
        if not members or set(members) in sets:
            continue
        sets.append(set(members))
        weights = tuple(float(vt[k][i]) for i in order)
        found.append(WeakDirection(tuple(members), weights, float(s[k] / s[0]), together, interval))
    return found, condition


def _common_scaling(
    direction: np.ndarray, members: list[int], values: np.ndarray, widths: np.ndarray
) -> list[int] | None:
    """The parameters a weak direction scales by one common factor, where it is (within :data:`COMMON`) such a
    scaling, largest component first; else None.

    A step ``v`` (in shares of each range) changes parameter i's value by the factor ``1 + v_i width_i / x_i``:
    a common scaling moves every member's logarithm alike.  The members are those of ``members`` (the direction's
    largest components) and every other parameter whose logarithm moves within a factor :data:`LOG_SPREAD` as much,
    the same way: a wide range makes a parameter's component small however much it scales (the SO-101's wrist
    roll: armature 0.92, friction 0.39, servo gain 0.11, each value scaled by 1.28-1.31 x the step).
    """
    positive = values > 0  # a parameter at 0 has no scale to share
    logs = np.where(positive, direction * widths / np.where(positive, values, 1.0), 0.0)
    leading = [i for i in members if positive[i]]
    if not leading:
        return None
    reference = float(np.median([logs[i] for i in leading]))
    if reference == 0.0:
        return None
    ratio = logs / reference
    group = [i for i in np.argsort(-np.abs(direction)) if positive[i] and 1 / LOG_SPREAD <= ratio[i] <= LOG_SPREAD]
    if len(group) < 2:
        return None
    common = np.zeros(len(direction))
    common[group] = values[group] / widths[group]
    if abs(float(direction @ common)) / float(np.linalg.norm(common)) < COMMON:
        return None
    return [int(i) for i in group]


def weak_directions(names: Sequence[str], jacobian: np.ndarray) -> tuple[list[str], list[list[str]], float]:
    """What a unit-scaled Jacobian at the start cannot resolve (:func:`weak_combinations`, by name only).

    Args:
        names: the parameters' names, in column order.
        jacobian: d residuals / d (value / range), shape (residuals, parameters).
    Returns:
        ``(flat, groups, condition)``: the parameters whose column is (near) zero; for each weak direction among the
        others (singular value below ``1 / CONDITION`` of the largest, weakest first, at most :data:`MOST`), the
        parameters that make it up (a set of parameters once, at its weakest direction); and the ratio of the
        largest to the smallest singular value of the others (``inf`` where one is zero).
    """
    found, condition = weak_combinations(names, jacobian)
    flat = [d.parameters[0] for d in found if d.flat]
    return flat, [list(d.parameters) for d in found if not d.flat], condition


def warn_about_start(
    names: Sequence[str], x: np.ndarray, lows, highs, jacobian: np.ndarray, residuals: np.ndarray
) -> list[str]:
    """Warn (:class:`SearchWarning`) about a search's start; the warnings' texts.

    Args:
        names: the parameters' names, in vector order.
        x: the start point (values).
        lows, highs: the bounds.
        jacobian: the unit-scaled Jacobian of the residuals at ``x``.
        residuals: the residuals at ``x``.
    Returns:
        The texts warned, in order (none when the start looks sound).
    """
    texts = []
    jacobian = np.asarray(jacobian, dtype=float)
    residuals = np.asarray(residuals, dtype=float)
    cost = 0.5 * float(residuals @ residuals)
    gradient = jacobian.T @ residuals / cost if cost > 0 else None
    x, lows, highs = (np.asarray(v, dtype=float) for v in (x, lows, highs))
    bound = pushed_past_bounds(names, x, lows, highs, gradient) if gradient is not None else []
    # below 0 for a damping, a friction, a mass: no range to widen (probe 5: "widen the range" of a damping at 0)
    unphysical = [b for b in bound if b.endswith("(lower bound 0)") and never_negative(b.split(" ")[0])]
    bound = [b for b in bound if b not in unphysical]
    if unphysical:
        one = len(unphysical) == 1
        names_at_zero = ", ".join(b.split(" ")[0] for b in unphysical)
        texts.append(
            f"the fit pushes {names_at_zero} below 0, which no arm has: not a range to widen, but what the "
            "recordings' noise or a part of the arm the model lacks (another controller, a delay) asks of "
            f"{'it' if one else 'them'}"
        )
    if bound:
        one = len(bound) == 1
        texts.append(
            f"the search starts on a bound that the fit pushes against: {', '.join(bound)}; the recordings ask for "
            f"{'a value' if one else 'values'} beyond it: if that is physically possible, widen the range"
        )
    found, condition = weak_combinations(names, jacobian, x, highs - lows)
    flat = [d.parameters[0] for d in found if d.flat]
    weak = [d for d in found if not d.flat]
    if flat:
        one = len(flat) == 1
        texts.append(
            f"at the start, {', '.join(flat)} {'moves' if one else 'move'} no residual: the recordings cannot pin "
            f"{'it' if one else 'them'} there (leave {'it' if one else 'them'} out with --only, or record what "
            f"{'it changes' if one else 'they change'})"
        )
    if weak:
        # the words `simtune check` lists them in (its identifiability section), and where it says what would part them
        described = "; ".join(d.words() for d in weak)
        texts.append(
            f"at the start the recordings hardly tell apart: {described} (Jacobian condition number "
            f"{condition:.1e}; J^T J's is its square): the search may trade one for another, and their intervals "
            "will be wide (`simtune check --task ... --only ...` says which motion would tell them apart)"
        )
    for text in texts:
        warnings.warn(text, SearchWarning, stacklevel=2)
    return texts
