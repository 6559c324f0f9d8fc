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


def weak_directions(names: Sequence[str], jacobian: np.ndarray) -> tuple[list[str], list[list[str]], float]:
    """What a unit-scaled Jacobian at the start cannot resolve.

    Args:
        names: the parameters' names, in column order.
        jacobian: d residuals / d (value / range), shape (residuals, parameters).
    Returns:
        ``(flat, groups, condition)``: the parameters whose column is (near) zero; for each weak direction among the
        others (singular value below ``1 / CONDITION`` of the largest, weakest first, at most :data:`MOST`), the
        parameters that make it up (a set of parameters once, at its weakest direction); and the ratio of the
        largest to the smallest singular value of the others (``inf`` where one is zero).
    """
    jacobian = np.asarray(jacobian, dtype=float)
    if jacobian.ndim != 2 or jacobian.size == 0 or not np.all(np.isfinite(jacobian)):
        return [], [], float("nan")
    norms = np.linalg.norm(jacobian, axis=0)
    largest = float(norms.max())
    if largest == 0.0:
        return list(names), [], float("inf")
    moving = norms > FLAT * largest
    flat = [name for name, m in zip(names, moving) if not m]
    kept = [name for name, m in zip(names, moving) if m]
    _, s, vt = np.linalg.svd(jacobian[:, moving], full_matrices=False)
    condition = float(s[0] / s[-1]) if s[-1] > 0 else float("inf")
    groups: list[list[str]] = []
    for k in range(len(s) - 1, -1, -1):
        if len(groups) >= MOST or s[k] * CONDITION >= s[0]:
            break
        share = np.abs(vt[k])
        members = [kept[i] for i in np.argsort(-share) if share[i] >= SHARE]
        # two weak directions among the same parameters name one group, once (probe 5: "a with b with c; d; a with
        # c with b"): the set is what the user learns, the order within it only which weighs most
        if members and set(members) not in [set(group) for group in groups]:
            groups.append(members)
    return flat, groups, condition


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
    flat, groups, condition = weak_directions(names, jacobian)
    if flat:
        one = len(flat) == 1
        texts.append(
            f"at the start, {', '.join(flat)} {'moves' if one else 'move'} no residual: the recordings cannot pin "
            f"{'it' if one else 'them'} there (leave {'it' if one else 'them'} out with --only, or record what "
            f"{'it changes' if one else 'they change'})"
        )
    if groups:
        described = "; ".join(" with ".join(group) if len(group) > 1 else group[0] for group in groups)
        texts.append(
            f"at the start the recordings hardly tell apart: {described} (Jacobian condition number "
            f"{condition:.1e}; J^T J's is its square): the search may trade one for another, and their intervals "
            "will be wide"
        )
    for text in texts:
        warnings.warn(text, SearchWarning, stacklevel=2)
    return texts
