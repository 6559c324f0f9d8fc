"""How well the recordings pin each tuned parameter: Gauss-Newton uncertainty at a run's best point.

The Jacobian ``J`` of the per-sample residuals (:func:`simtune.fitness.residuals`: marker minus
mean recorded wrist at every sample, stacked over tasks, and the final object offset) is taken by
central finite differences in the unit cube (each parameter scaled to its range, step
:data:`STEP` of the range; one-sided at a bound), all 2D + 1 rollouts as one batch through the
run's :class:`~simtune.optimize.evaluator.Evaluator` (its worker pool; a scratch store, so the
run's own evaluations and best point are untouched).  A point the run's store holds bit for bit, stable and
with its residuals, is read there instead: in practice the best point where a least-squares phase found it.
The solver's own forward differences never coincide with these points (measured on the synthetic MICO
``double``: its best point is a trial the solver stopped at, with no Jacobian taken there, and its unit
coordinates are not those ``(x - low) / width`` gives back bit for bit), so they are simulated again.

Covariance (Gauss-Newton): ``s^2 (J^T J)^+`` with ``s^2 = |r|^2 / (m - rank)`` the residual
variance at the point, and the pseudo-inverse over the singular values of ``J`` above
:data:`RCOND` times the largest (below it a direction counts as unidentifiable).  The samples
of a recording are not independent (20 Hz samples of a smooth track, and a misfit that is
smooth too): the covariance is multiplied by the wrist residuals' integrated autocorrelation
time (:func:`correlation_time`, pooled over tasks and axes), the factor by which correlated
samples inform less than as many independent ones.

A parameter is *identifiable* when it is active, the simulation is smooth in it at the point
(forward and backward differences agree within :data:`KINK`: the time step, for one, changes
the whole number of physics steps per control period, and its local slope says nothing of
its other minima), its direction lies in the span the retained singular vectors cover (its
component in the discarded ones below :data:`NULL_SHARE`), and its 95 % interval (value +-
1.96 standard deviations, not clipped to the bounds) is no wider than the parameter's range;
otherwise its interval is unbounded (``low``/``high`` null).

The noise is not the only error of a run's best point: a run stopped by its budget (a small ``--max-evaluations``)
before it reached the data's minimum sits off it by more than the noise allows (issue 71 item 3: a damping's interval
0.236-0.381 about a tuned 0.308, the truth 0.4).  The Gauss-Newton step still left there, ``-(J^T J)^+ J^T r``
(:func:`remaining_step`), is zero at a converged fit and points toward the minimum otherwise; where it is more than
:data:`UNCONVERGED_SHARE` of an interval's half-width, the interval is widened by it and names it.
"""

from __future__ import annotations

import math
import tempfile
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from simtune.activity import announce
from simtune.errors import ConfigError
from simtune.fitness import Score
from simtune.objective import Objective, generic_values
from simtune.optimize.evaluator import Evaluator
from simtune.optimize.pipeline import LOCAL_NFEV, STALL_FTOL
from simtune.optimize.refine import STEP as LOCAL_STEP
from simtune.optimize.refine import jacobian_from, jacobian_points
from simtune.params import ParameterSpace
from simtune.params.kinds import delay_names
from simtune.store import RunStore

#: Finite-difference step, as a fraction of each parameter's range.
STEP = 0.01
#: Singular values of the unit-scaled Jacobian below this fraction of the largest count as zero.
RCOND = 1e-6
#: Largest share (norm of its unit vector's projection) of a parameter in the discarded directions.
NULL_SHARE = 0.1
#: Two-sided 95 % normal quantile.
Z95 = 1.959963984540054
#: Sokal's window constant for the integrated autocorrelation time (the sum stops at lag >= WINDOW x tau).
WINDOW = 5.0
#: Forward and backward differences that differ by more than this share of the larger mark a kink.
KINK = 0.5
#: Most correlated pairs listed.
TOP_PAIRS = 5
#: A remaining Gauss-Newton step larger than this share of a parameter's 95 % half-width says the fit stopped short of
#: the data's minimum in that parameter: the interval is widened by it and the summary names it.  Below it the step is
#: within what the interval's own width is known to (a converged fit's finite-difference step is a few hundredths).
UNCONVERGED_SHARE = 0.5
#: A parameter this close to a bound (share of its range) counts as on it for the remaining step's bounds.
ON_BOUND = 1e-9


@dataclass
class Jacobian:
    """Residuals at a point and their Jacobian in unit coordinates, with the rollouts' stability."""

    residuals: np.ndarray  # (m,)
    unit: np.ndarray  # (m, D): d residual / d (value / range)
    stable: bool
    #: (D,) whether the forward and backward differences of a column disagree by more than :data:`KINK`
    #: (a kink or jump in the simulation, such as the time step's whole number of steps per control period)
    kinked: np.ndarray | None = None


def jacobian(
    objective: Objective,
    x: np.ndarray,
    workers: int = 1,
    step: float = STEP,
    known: RunStore | None = None,
    one_sided: bool = False,
) -> Jacobian:
    """Central-difference Jacobian of ``objective``'s residuals at ``x`` (its space's vector), one batch of rollouts.

    Args:
        objective: whose residuals.
        x: the point (its space's vector).
        workers: processes for the rollouts.
        step: the finite-difference step, as a fraction of each parameter's range.
        known: the run's own store: a point it holds bit for bit, stable and with its residuals (in practice the
            best point; see the module's notes) is read from it, not simulated again.
        one_sided: a forward difference (backward at a parameter's upper bound), half the rollouts, for a screen
            that ranks motions (``simtune design``'s library); no kink is then judged.
    Returns:
        The :class:`Jacobian`.
    """
    space = objective.vector_space()
    low = np.array([p.low for p in space.parameters])
    width = np.array([p.high - p.low for p in space.parameters])
    x = np.asarray(x, dtype=float)
    u = (x - low) / width
    up = np.minimum(u + step, 1.0)
    down = np.maximum(u - step, 0.0)
    side = np.where(up > u, up, down)  # one_sided: the one step of each parameter, into its range
    points = [x]
    for i in range(len(x)):
        for v in (side[i],) if one_sided else (up[i], down[i]):
            p = x.copy()
            p[i] = low[i] + v * width[i]
            points.append(p)
    results = _stored(known, points)
    missing = [i for i, result in enumerate(results) if result is None]
    if missing:
        with tempfile.TemporaryDirectory(prefix="simtune-jacobian-") as scratch:
            store = RunStore(Path(scratch), create=True)
            try:
                with Evaluator(objective, store, workers=workers, prune=False) as evaluator:
                    for i, result in zip(missing, evaluator.residuals([points[i] for i in missing])):
                        results[i] = result
            finally:
                store.close()
    done = [result for result in results if result is not None]
    assert len(done) == len(points), "every point read or simulated"
    r0, score0 = done[0]
    columns = []
    kinked = np.zeros(len(x), dtype=bool)
    stable = score0.stable
    for i in range(len(x)):
        if one_sided:
            r_side, s_side = done[1 + i]
            stable = stable and s_side.stable
            span = side[i] - u[i]
            columns.append((r_side - r0) / span if span != 0 else np.zeros_like(r0))
            continue
        (r_up, s_up), (r_down, s_down) = done[1 + 2 * i], done[2 + 2 * i]
        stable = stable and s_up.stable and s_down.stable
        span = up[i] - down[i]
        columns.append((r_up - r_down) / span if span > 0 else np.zeros_like(r0))
        if up[i] > u[i] and down[i] < u[i]:
            forward = (r_up - r0) / (up[i] - u[i])
            backward = (r0 - r_down) / (u[i] - down[i])
            scale = max(float(np.linalg.norm(forward)), float(np.linalg.norm(backward)))
            kinked[i] = scale > 0 and float(np.linalg.norm(forward - backward)) > KINK * scale
    unit = np.stack(columns, axis=1) if columns else np.zeros((len(r0), 0))
    return Jacobian(np.asarray(r0, dtype=float), unit, bool(stable), kinked)


def _stored(store: RunStore | None, points: list[np.ndarray]) -> list[tuple[np.ndarray, Score] | None]:
    """Each point's residuals and score as ``store`` holds them (its key is the vector's exact bytes), or None.

    Only a stable evaluation is taken: a failed one (a timeout, say) may well succeed when simulated again, and a
    rollout is deterministic, so a stable one's residuals are those a new rollout would give, bit for bit.
    """
    found: list[tuple[np.ndarray, Score] | None] = [None] * len(points)
    if store is None:
        return found
    for i, p in enumerate(points):
        score = store.lookup(p)
        if score is None or not score.stable:
            continue
        residuals = store.lookup_residuals(p)
        if residuals is not None:
            found[i] = (residuals, score)
    return found


def wrist_tracks(residuals: np.ndarray, objective: Objective) -> list[np.ndarray]:
    """The wrist part of a residual vector, one (samples, 3) array per task."""
    tracks, start = [], 0
    for task in objective.tasks:
        n = len(objective.references[task.name].times)
        tracks.append(residuals[start : start + 3 * n].reshape(n, 3))
        start += 3 * n + 3 * (task.object is not None and objective.references[task.name].object_final is not None)
    return tracks


def correlation_time(series: list[np.ndarray]) -> float:
    """Integrated autocorrelation time (in samples) of time series (each (n, k), columns pooled), at least 1.

    1 + 2 x the sum of the pooled autocorrelations from lag 1 on, up to Sokal's automatic window
    (:data:`WINDOW`): the factor by which correlated samples inflate the variance of what
    they determine, compared with as many independent ones.
    """
    longest = max((len(s) for s in series), default=0)
    if longest < 2:
        return 1.0
    acov = np.zeros(longest)
    for s in series:
        centred = np.asarray(s, dtype=float) - np.mean(s, axis=0)
        n = len(centred)
        spectrum = np.fft.rfft(centred, n=2 * n, axis=0)
        acov[:n] += np.fft.irfft(spectrum * np.conj(spectrum), n=2 * n, axis=0)[:n].sum(axis=1)
    if acov[0] <= 0:
        return 1.0
    # Sokal's automatic window: the sum up to the first lag M with M >= WINDOW x tau(M), so that the
    # noisy tail of the estimated autocorrelation is left out
    taus = 2.0 * np.cumsum(acov / acov[0]) - 1.0
    within = np.flatnonzero(np.arange(longest) >= WINDOW * taus)
    tau = float(taus[within[0]]) if within.size else float(taus[-1])
    return float(min(max(tau, 1.0), longest))


def directions(J: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Singular values of ``J`` (m, D), right singular vectors (rows), which are kept (above :data:`RCOND` x the
    largest), and each parameter's share in the discarded directions (0: fully pinned by the kept ones, 1: free)."""
    d = J.shape[1]
    if d == 0:
        return np.zeros(0), np.zeros((0, 0)), np.zeros(0, dtype=bool), np.zeros(0)
    # the full SVD although U is never used (half a second on a few thousand residuals): the reduced one's vt differs
    # in the last digits on some Jacobians (measured: cube's 1203 x 41), and the summary is kept as it was
    _, s, vt = np.linalg.svd(J, full_matrices=True)
    s_max = float(s.max()) if s.size else 0.0
    keep = s > RCOND * s_max if s_max > 0 else np.zeros_like(s, dtype=bool)
    free = np.concatenate([vt[: len(s)][~keep], vt[len(s) :]])  # discarded, and beyond the residuals' count
    null_share = np.linalg.norm(free.T, axis=1) if free.size else np.zeros(d)
    return s, vt, keep, null_share


@dataclass
class RepeatSpread:
    """What the spread of the recordings' repeats says about the parameters, beside Gauss-Newton's residual variance.

    ``deviations``: per task, each repeat's deviation from the mean in residual units (rows; None for a task with
    one repeat): :meth:`~simtune.objective.Objective.repeat_deviations`.  ``counts``: the residuals of each task, in
    order.  ``clock``: parameter index -> the variance [s^2] of the aligned reference's clock origin (the median of
    the repeats' shifts), for each command delay.  ``held_clock``: for each task whose clock origin no searched
    delay takes up (the delay held), its :meth:`~simtune.objective.Objective.clock_columns` column and that
    variance: an origin error then moves the other parameters.
    """

    deviations: list[np.ndarray | None]
    counts: list[int]
    clock: dict[int, float]
    held_clock: list[tuple[np.ndarray, float]] = field(default_factory=list)


def _solver(J: np.ndarray, keep: np.ndarray, s: np.ndarray, vt: np.ndarray) -> np.ndarray:
    """The least-squares solution's linear map ``(J^T J)^+ J^T`` (D, m) over the kept directions: how a change of the
    residuals moves the fitted parameters (unit coordinates)."""
    v_kept = vt[: len(s)][keep].T
    return (v_kept / s[keep] ** 2) @ v_kept.T @ J.T


def remaining_step(J: np.ndarray, r: np.ndarray, u: np.ndarray, held: np.ndarray | None = None) -> np.ndarray:
    """The Gauss-Newton step ``-(J^T J)^+ J^T r`` that is left at a point (unit coordinates, as ``J``): zero where a fit
    converged, toward the data's minimum where it stopped short (a small ``--max-evaluations``).

    The same pseudo-inverse as the intervals (singular values above :data:`RCOND` x the largest).  A parameter on a
    bound whose step points out of its range is held there and the step taken again over the others (the bounded
    least-squares minimum lies on that bound); what is left is cut at each range, as the intervals are.

    Args:
        J: the residuals' Jacobian in unit coordinates (m, D).
        r: the residuals at the point (m,).
        u: the point in unit coordinates (D,): ``(x - low) / width``.
        held: (D,) parameters the step leaves where they are (the simulation is not smooth in them, or they move
            nothing): their columns say nothing of where the minimum is.
    Returns:
        The step (D,) in unit coordinates; ``u + step`` lies within [0, 1].
    """
    d = J.shape[1]
    free = np.ones(d, dtype=bool) if held is None else ~np.asarray(held, dtype=bool)
    step = np.zeros(d)
    for _ in range(d):  # each pass holds one more parameter or ends
        columns = np.flatnonzero(free)
        step = np.zeros(d)
        if columns.size == 0:
            break
        _, s, vt = np.linalg.svd(J[:, columns], full_matrices=False)
        keep = s > RCOND * float(s.max()) if s.size and s.max() > 0 else np.zeros(len(s), dtype=bool)
        if not keep.any():
            break
        step[columns] = -_solver(J[:, columns], keep, s, vt) @ r
        outward = free & (((u <= ON_BOUND) & (step < 0)) | ((u >= 1.0 - ON_BOUND) & (step > 0)))
        if not outward.any():
            break
        free &= ~outward
    return np.clip(u + step, 0.0, 1.0) - u


def repeat_covariance(J: np.ndarray, spread: RepeatSpread, keep: np.ndarray, s: np.ndarray, vt: np.ndarray):
    """The covariance of the parameters (unit coordinates) that the repeats' own scatter gives the mean they are fitted
    to, and the smallest repeat count: ``A (Sum_k d_k d_k^T / (R (R - 1))) A^T`` per task, summed, with ``A`` the
    least-squares solution's linear map (``(J^T J)^+ J^T``) and ``d_k`` repeat k's deviation from the mean.  It holds
    the recordings' whole correlation in time (a smooth misfit shared by a repeat's samples), which the white-noise
    Gauss-Newton variance only approximates by the correlation time.

    Returns:
        ``(covariance (D, D), repeats)``; ``(None, 0)`` where no task has two repeats.
    """
    solve = _solver(J, keep, s, vt)  # (D, m)
    cov, start, fewest = np.zeros((J.shape[1], J.shape[1])), 0, 0
    for rows, count in zip(spread.deviations, spread.counts):
        if rows is not None:
            part = solve[:, start : start + count] @ rows.T  # (D, R): each repeat's pull on the parameters
            repeats = rows.shape[0]
            cov += part @ part.T / (repeats * (repeats - 1))
            fewest = repeats if not fewest else min(fewest, repeats)
        start += count
    return (cov, fewest) if fewest else (None, 0)


def analyse(
    space: ParameterSpace,
    x: np.ndarray,
    jac: Jacobian,
    inflation: float = 1.0,
    inactive: dict[str, str] | None = None,
    variance: float | None = None,
    spread: RepeatSpread | None = None,
    refits: np.ndarray | None = None,
    at_fit: bool = False,
) -> dict:
    """The uncertainty summary of the searched parameters (``space``, values ``x``) from ``jac``.

    ``variance``: of one residual, if known (the check takes it from the repeats' scatter); by
    default the residuals' own at the point.  ``inflation``: the residuals' correlation time.  ``spread``: the
    repeats' scatter (:class:`RepeatSpread`): each parameter's standard deviation is then the larger of Gauss-Newton's
    and the repeats' (at Student's t for their count), and a command delay's adds the aligned clock's origin.
    ``refits``: the point refitted against bootstrap draws of the repeats (:func:`bootstrap_refits`, (draws, D)):
    their standard deviation is a parameter's where the simulation is not smooth in it (no Gauss-Newton there), and
    its least elsewhere.  ``at_fit``: ``x`` is where a fit stopped (a run's best point; the check's generic values are
    none): the noise says nothing of how far the optimiser stopped from the data's minimum, so the Gauss-Newton step
    still left there (:func:`remaining_step`, in each parameter's units) is given for every searched parameter
    (``remaining_steps``), and an identified parameter's interval whose step is more than :data:`UNCONVERGED_SHARE`
    of its half-width is widened by it toward the minimum (its entry's ``remaining_step``): the interval then holds
    the noise and the optimiser's remaining error.

    Returns:
        The summary: ``parameters`` (per parameter its ``name``, ``value``, 95 % ``low``/``high`` (None where not
        identifiable), ``active``, ``identifiable``, ``cut`` where cut at its range, ``remaining_step`` where the
        fit has not converged in it), the Jacobian's rank, singular values and condition number, the residuals'
        variance and correlation time, the non-smooth parameters, the most correlated pairs, the method in words;
        with ``at_fit``, ``remaining_steps`` (name -> the step left, 0 where held).
    """
    inactive = inactive or {}
    width = np.array([p.high - p.low for p in space.parameters])
    J, r = jac.unit, jac.residuals
    m, d = J.shape
    kinked = jac.kinked if jac.kinked is not None else np.zeros(d, dtype=bool)
    s, vt, keep, null_share = directions(J)
    rank = int(keep.sum())
    dof = max(m - rank, 1)
    if variance is None:
        variance = float(r @ r) / dof
    # covariance in unit coordinates over the retained directions, then scaled to each range
    v_kept = vt[: len(s)][keep].T  # (d, rank)
    cov_unit = (v_kept / s[keep] ** 2) @ v_kept.T * variance * inflation
    cov = cov_unit * np.outer(width, width)
    sds = np.sqrt(np.maximum(np.diag(cov), 0.0))
    if spread is not None:
        sds = _with_repeats(sds, J, spread, keep, s, vt, width)
    smooth = ~kinked
    if refits is not None:
        drawn = np.std(refits, axis=0, ddof=1) if len(refits) > 1 else np.full(d, np.inf)
        drawn[drawn == 0.0] = np.inf  # refits that never moved it say the fit is stuck there, not that it is exact
        sds = np.where(kinked, drawn, np.maximum(sds, np.where(np.isinf(drawn), 0.0, drawn)))
        smooth = np.ones(d, dtype=bool)
    steps = np.zeros(d)
    if at_fit:
        low = np.array([p.low for p in space.parameters])
        held = kinked | np.array([p.name in inactive for p in space.parameters], dtype=bool)
        u = np.clip((np.asarray(x, dtype=float) - low) / width, 0.0, 1.0)
        steps = remaining_step(J, r, u, held) * width
    entries = []
    for i, p in enumerate(space.parameters):
        sd = float(sds[i])
        active = p.name not in inactive
        identifiable = bool(active and smooth[i] and null_share[i] < NULL_SHARE and 2 * Z95 * sd <= width[i])
        entry = {
            "name": p.name,
            "value": float(x[i]),
            "low": float(x[i] - Z95 * sd) if identifiable else None,
            "high": float(x[i] + Z95 * sd) if identifiable else None,
            "active": active,
            "identifiable": identifiable,
        }
        if identifiable and abs(steps[i]) > UNCONVERGED_SHARE * Z95 * sd:
            # the interval about where the minimum lies, joined to the one about where the fit stopped
            step = float(steps[i])
            entry["low"] = float(x[i] - Z95 * sd + min(step, 0.0))
            entry["high"] = float(x[i] + Z95 * sd + max(step, 0.0))
            entry["remaining_step"] = step
        entries.append(_cut_to_range(entry, p.low, p.high))
    pairs = []
    ident = [i for i, e in enumerate(entries) if e["identifiable"]]  # correlations: Gauss-Newton's
    for a_pos, a in enumerate(ident):
        for b in ident[a_pos + 1 :]:
            denom = math.sqrt(cov[a, a] * cov[b, b])
            if denom > 0:
                pairs.append((space.names[a], space.names[b], float(cov[a, b] / denom)))
    pairs.sort(key=lambda t: -abs(t[2]))
    kept_s = s[keep]
    summary = {
        "parameters": entries,
        "residuals": m,
        "rank": rank,
        "searched": d,
        "singular_values": [float(v) for v in s],
        "condition_number": float(kept_s.max() / kept_s.min()) if kept_s.size else None,
        "residual_rms": math.sqrt(float(r @ r) / m) if m else None,
        "residual_variance": variance,
        "variance_inflation": inflation,
        "non_smooth": [n for n, k in zip(space.names, kinked) if k],
        "stable": jac.stable,
        "correlated_pairs": [{"a": a, "b": b, "correlation": c} for a, b, c in pairs[:TOP_PAIRS]],
        "method": (
            f"Gauss-Newton at the best point: central differences (step {STEP:g} of each range) of the "
            f"per-sample residuals; pseudo-inverse over singular values above {RCOND:g} x the largest; "
            "covariance x the residuals' integrated autocorrelation time; each standard deviation at least what "
            "the scatter of the recordings' repeats gives the fitted mean (at Student's t for their count), and a "
            "command delay's widened by the aligned clock's origin (every parameter's, where the delay is held); "
            "95 % = value +- "
            f"{Z95:.2f} sd; a parameter whose forward and backward differences disagree is not identifiable"
            + ("" if refits is None else _BOOTSTRAP_WORDS.format(draws=len(refits), steps=LOCAL_NFEV))
            + ("" if not at_fit else _STEP_WORDS.format(share=UNCONVERGED_SHARE))
        ),
        "bootstrap_draws": 0 if refits is None else len(refits),
    }
    if at_fit:
        summary["remaining_steps"] = {name: float(step) for name, step in zip(space.names, steps)}
    return summary


_BOOTSTRAP_WORDS = (
    " - unless the best point's refits against {draws} bootstrap draws of the recordings' repeats (each task's "
    "repeats drawn with replacement, its aligned clock on the draw's median shift; at most {steps} least-squares "
    "steps each) give it a standard deviation: then that one where the differences disagree, and at least it elsewhere"
)


_STEP_WORDS = (
    "; where the Gauss-Newton step left at the best point (-(J^T J)^+ J^T r, bounded by the ranges) is more than "
    "{share:g} of a half-width, the fit stopped short of the data's minimum: that interval is widened by the step "
    "toward it (`remaining_step`)"
)


def bootstrap_refits(objective: Objective, x: np.ndarray, draws: int, workers: int = 1, seed: int = 0) -> np.ndarray:
    """The point ``x`` refitted against ``draws`` bootstrap draws of the recordings' repeats: what the fit would give
    with other repeats of the same arm, including the aligned clock the draw puts its repeats on.

    Gauss-Newton's intervals need a simulation smooth in the parameter; Coulomb friction's stick-slip and the time
    step's whole number of steps are not, and the repeats' clock origin moves the fit nonlinearly.  Each draw takes
    every task's repeats with replacement (:meth:`~simtune.data.TaskData.resampled`) and refits from ``x`` with
    SciPy's bounded least squares in the unit cube on the same residuals as the tuning run's local phase (forward
    differences of the phase's step, 1 % of each range, at most its steps, ending on its cost tolerance), in this
    process, each batch on ``workers`` threads (MuJoCo's batch path; other engines one rollout after another).

    Args:
        objective: the run's objective.
        x: the point (its space's vector), in practice the run's best.
        draws: how many draws.
        workers: threads for a batch's rollouts.
        seed: of the draws.
    Returns:
        The refitted points, (draws, D).
    """
    few = {name: len(ref.sources) for name, ref in objective.references.items() if len(ref.sources) < 2}
    if few:
        name, count = next(iter(few.items()))
        raise ConfigError(
            f"--bootstrap draws the recordings' repeats: task {name!r} has {count} (it needs two or more)"
        )
    rng = np.random.default_rng(seed)
    space = objective.vector_space()
    low = np.array([p.low for p in space.parameters])
    width = np.array([p.high - p.low for p in space.parameters])
    start = np.clip((np.asarray(x, dtype=float) - low) / width, 0.0, 1.0)
    refits = []
    began = time.perf_counter()
    for k in range(draws):
        elapsed = time.perf_counter() - began
        ahead = f", about {elapsed / k * (draws - k):.0f} s to go" if k else ""
        announce(f"bootstrap: refitting the best point against draw {k + 1} of {draws} of the repeats{ahead}")
        references = {
            name: ref.resampled(rng.integers(0, len(ref.sources), len(ref.sources)))
            for name, ref in objective.references.items()
        }
        draw = objective.with_references(references)
        try:
            refits.append(low + _refit(draw, start, low, width, workers) * width)
        finally:
            draw.close()
    return np.array(refits)


def _refit(objective: Objective, start: np.ndarray, low: np.ndarray, width: np.ndarray, workers: int) -> np.ndarray:
    """SciPy's bounded least squares of ``objective``'s residuals from ``start`` in the unit cube (each parameter
    ``low + u x width``), with the local phase's forward differences; where it ends."""
    from scipy.optimize import least_squares

    space = objective.vector_space()
    seen: dict[bytes, np.ndarray] = {}

    def batch(points: list[np.ndarray]) -> list[np.ndarray]:
        out = [objective.penalty_residuals() for _ in points]  # a rollout that fails scores as one that blew up
        params = [space.to_dict(low + u * width) for u in points]
        for i, result in objective.residuals_batch(params, threads=workers):
            if not isinstance(result, Exception):
                out[i] = result[0]
        return out

    def fun(u: np.ndarray) -> np.ndarray:
        if u.tobytes() not in seen:
            seen[u.tobytes()] = batch([u])[0]
        return seen[u.tobytes()]

    def jac(u: np.ndarray) -> np.ndarray:
        points, steps = jacobian_points(u, LOCAL_STEP)
        return jacobian_from(fun(u), batch(points), steps)

    return least_squares(fun, start, jac=jac, bounds=(0.0, 1.0), max_nfev=LOCAL_NFEV, ftol=STALL_FTOL).x


def _cut_to_range(entry: dict, low: float, high: float) -> dict:
    """An identified parameter's interval within its range: a damping, a mass or a time step below its range (below
    zero for those whose range starts there) is no value an arm can have (probe 5: a negative time step, dampings
    reaching below 0).  ``cut`` names the ends that were cut (absent where none was)."""
    if entry["low"] is None or entry["high"] is None:
        return entry
    cut = [end for end, outside in (("low", entry["low"] < low), ("high", entry["high"] > high)) if outside]
    if not cut:
        return entry
    return {**entry, "low": max(entry["low"], low), "high": min(entry["high"], high), "cut": cut}


def _with_repeats(sds, J, spread: RepeatSpread, keep, s, vt, width) -> np.ndarray:
    """``sds`` (each parameter's standard deviation, in its units) raised to what the repeats' scatter gives it (at
    Student's t for the fewest repeats, as a normal-quantile equivalent) and, for a command delay, widened by the
    aligned clock's origin."""
    # Student's t quantile as scipy.stats.t.ppf computes it (its _ppf is stdtrit): scipy.stats itself takes half a
    # second to import, after every tune
    from scipy.special import stdtrit

    cov, repeats = repeat_covariance(J, spread, keep, s, vt)
    sds = np.array(sds, dtype=float)
    if cov is not None:
        stretch = float(stdtrit(repeats - 1, 0.975)) / Z95
        sds = np.maximum(sds, stretch * np.sqrt(np.maximum(np.diag(cov), 0.0)) * width)
    for i, clock_variance in spread.clock.items():
        sds[i] = math.sqrt(sds[i] ** 2 + clock_variance)
    if spread.held_clock:
        solve = _solver(J, keep, s, vt)
        for column, clock_variance in spread.held_clock:
            sds = np.sqrt(sds**2 + (solve @ column * width) ** 2 * clock_variance)
    return sds


def uncertainty(
    objective: Objective,
    x: np.ndarray,
    full: ParameterSpace,
    inactive: dict[str, str],
    workers: int = 1,
    known: RunStore | None = None,
    bootstrap: int = 0,
) -> dict:
    """The full summary: one entry per parameter of ``full`` (the run's whole space, searched or not).

    ``known``: the run's store, whose stored points the central differences read instead of simulating them
    (:func:`jacobian`): the same numbers, fewer rollouts.  ``bootstrap``: draws of the repeats to refit against
    (:func:`bootstrap_refits`; 0: none).
    """
    space = objective.vector_space()
    refits = bootstrap_refits(objective, x, bootstrap, workers) if bootstrap > 0 else None  # first: it checks repeats
    jac = jacobian(objective, x, workers, known=known)
    inflation = correlation_time(wrist_tracks(jac.residuals, objective))
    values = space.to_dict(np.asarray(x, dtype=float))
    spread = repeat_spread(objective, values.get("timestep"))
    result = analyse(
        space, np.asarray(x, dtype=float), jac, inflation, inactive, spread=spread, refits=refits, at_fit=True
    )
    searched = {e["name"]: e for e in result["parameters"]}
    left_out = [n for n in full.names if n not in searched]
    generic = generic_values(objective, left_out) if left_out else {}
    entries = []
    for name in full.names:
        entry = searched.get(name)
        if entry is None:  # not searched (inactive): it keeps its generic value, and the data cannot inform it
            entry = {
                "name": name,
                "value": generic.get(name),
                "low": None,
                "high": None,
                "active": name not in inactive,
                "identifiable": False,
            }
        entries.append(entry)
    result["parameters"] = entries
    return result


#: A median's standard deviation over a mean's, for normal samples (sqrt(pi / 2)): the aligned clock's origin is the
#: median of the repeats' shifts.
MEDIAN_EFFICIENCY = math.sqrt(math.pi / 2)


def repeat_spread(objective: Objective, x_timestep: float | None = None) -> RepeatSpread:
    """The repeats' scatter of ``objective``'s references, for :func:`analyse`.

    Each task's repeat deviations in residual units, and, for each command delay of the space (``command_delay``, or a
    task's own), the variance of its timing: the aligned reference puts its clock at the median of the repeats' shifts
    onto their median onset, itself uncertain by ``MEDIAN_EFFICIENCY x sd(shifts) / sqrt(R)`` (the plain mean has no
    such origin), and the simulation resolves a delay to one physics step (a uniform error: ``timestep^2 / 12``).

    Args:
        objective: the run's objective (its tasks, references and residual weights).
        x_timestep: the physics time step at the point [s] (None: the engine's generic one).
    Returns:
        The :class:`RepeatSpread`.
    """
    names = objective.vector_space().names
    counts = objective.residual_counts()
    # the simulation starts each controller update on a whole physics step: a delay is resolved to one step
    step = x_timestep if x_timestep is not None else generic_values(objective, ["timestep"]).get("timestep")
    resolution = 0.0 if step is None else float(step) ** 2 / 12.0
    clock: dict[int, float] = {}
    held: list[tuple[int, float]] = []  # (task's index, its origin's variance) where no searched delay takes it up
    for t, task in enumerate(objective.tasks):
        alignment = objective.references[task.name].alignment
        shifts = None if alignment is None else np.asarray(alignment.shifts, dtype=float)
        origin = 0.0
        if shifts is not None and len(shifts) >= 2:
            origin = (MEDIAN_EFFICIENCY * float(np.std(shifts, ddof=1))) ** 2 / len(shifts)
        delays = [names.index(name) for name in delay_names(task.name) if name in names]
        for i in delays:
            clock[i] = max(clock.get(i, 0.0), origin + resolution)
        if not delays and origin > 0:
            held.append((t, origin))
    columns = objective.clock_columns() if held else []
    held_clock = [(columns[t], origin) for t, origin in held]
    return RepeatSpread(objective.repeat_deviations(), counts, clock, held_clock)


#: a tuned value this far from its generic one (share of its range) is named in the verdict after a tune
MOVED_SHARE = 0.25


def verdict(
    objective: Objective, references: dict, best: dict[str, float], fitness: float, summary: dict | None
) -> dict:
    """What a newcomer needs after a tune: how close the fit is to what the data allow, and which parameters moved
    far from their generic values and whether the recordings pin them.

    Args:
        objective: the run's objective (its space, tasks and weights).
        references: task -> the run's reference (:class:`~simtune.data.TaskData`); the floor needs aligned ones.
        best: the tuned parameter values (name -> value).
        fitness: the tuned fitness.
        summary: the run's uncertainty summary (:func:`uncertainty`), or None / one with an ``error``.
    Returns:
        ``floor`` (the fitness of the aligned mean against each repeat, summed over the tasks: what a simulation as
        good as the arm's own repeats scores; None against the plain mean or with one repeat), ``over_floor``
        (fitness / floor) and ``moved``: per parameter more than :data:`MOVED_SHARE` of its range from its generic
        value, its ``name``, ``generic``, ``tuned``, ``share`` of the range and ``pinned`` (its 95 % interval is
        bounded; None where no uncertainty was computed), the farthest first.
    """
    from simtune.fitness import reference_floor

    floor: float | None = None
    try:
        floors = [reference_floor(ref, objective.weights).floor for ref in references.values()]
        known = [f for f in floors if f is not None and math.isfinite(f) and f > 0]
        floor = float(sum(known)) if floors and len(known) == len(floors) else None
    except (ValueError, TypeError):
        floor = None  # the plain mean, joint logs only or one repeat: no floor to compare with
    space = objective.vector_space()
    generic = generic_values(objective, space.names)
    pinned = {}
    if summary and not summary.get("error"):
        pinned = {p["name"]: bool(p.get("identifiable")) for p in summary.get("parameters", [])}
    moved: list[dict] = []
    for p in space.parameters:
        width = p.high - p.low
        if p.name not in best or p.name not in generic or width <= 0:
            continue
        share = abs(best[p.name] - generic[p.name]) / width
        if share > MOVED_SHARE:
            moved.append(
                {
                    "name": p.name,
                    "unit": p.unit,
                    "generic": float(generic[p.name]),
                    "tuned": float(best[p.name]),
                    "share": float(share),
                    "pinned": pinned.get(p.name) if pinned else None,
                }
            )
    moved.sort(key=lambda m: -m["share"])
    return {"floor": floor, "over_floor": None if not floor else float(fitness / floor), "moved": moved}
