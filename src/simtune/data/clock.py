"""Reality's own clock: the repeats of a task shifted onto one clock before they are averaged.

A recording's clock starts when the operator pressed record, so each repeat of a task starts to move at
another time (qrg2019: the wrist's onset spreads over 1.11-1.57 s in ``single``, 1.37-2.70 s in ``cube``).
Averaging them as they are blurs every movement of the mean.  The ``aligned`` reference shifts each repeat
so that it lines up with the others first:

1. each repeat's motion onset (:func:`simtune.data.onset.motion_onset`) gives a first shift, onto the
   median onset of the task;
2. each shift is refined by matching the repeat's track (the wrist marker, or the joint angles of joint logs)
   against the mean of the other repeats: the lag within :data:`SEARCH_S` that minimises their mean squared
   difference (the peak of their cross-correlation), to a fraction of a sample, one repeat after the other;
   the shifts are re-centred on their median and the step repeated (within :data:`STEP_S`) until no shift
   moves by more than :data:`TOLERANCE_S`.

The ``mean`` reference is the seed paper's: every repeat on its own clock.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from simtune.data._table import display_name
from simtune.data.onset import motion_onset
from simtune.errors import RecordingWarning, check_choice

#: The reference kinds: ``aligned`` (repeats on one clock, then averaged) and ``mean`` (the paper's plain mean).
REFERENCES = ("aligned", "mean")
#: The reference of a new run.
DEFAULT_REFERENCE = "aligned"


def default_reference(paper_exact: bool) -> str:
    """The reference of a run that names none: the paper's plain mean for a paper-exact run, else the default."""
    return "mean" if paper_exact else DEFAULT_REFERENCE


#: How far [s] the first refinement step looks on either side of a repeat's shift from its onset.
SEARCH_S = 0.5
#: How far [s] each later step looks on either side of a repeat's current shift.
STEP_S = 0.1
#: The refinement stops once no shift moves by more than this [s] (a fiftieth of a 20 Hz sample).
TOLERANCE_S = 1e-3
#: ... or after this many steps.
MAX_STEPS = 50
#: How many times finer than the reference's rate the repeats are compared (20 Hz -> 100 Hz).
FINE = 5
#: A shift farther than this many scaled median absolute deviations from the median shift is an outlier ...
OUTLIER_MADS = 3.0
#: ... and farther than this [s] from it.  A robust scale alone flags a uniform start jitter among few repeats
#: (3 scaled MADs flag one of 5 uniform draws in a quarter of the cases, one of 10 in a tenth), and
#: ``simtune synth`` jitters every repeat's start by up to +-0.05 s by design: its shifts lie at most 0.1 s from
#: their median, so this floor keeps them unflagged with room for the alignment's error.  Real late starts stay
#: flagged: on qrg2019 ``cube`` the four outliers lie 0.30-0.74 s from the median (3 scaled MADs: 0.297 s).
OUTLIER_FLOOR_S = 0.2
#: The median absolute deviation of a normal distribution times this is its standard deviation.
MAD_SCALE = 1.4826
#: Fewer repeats than this tell no outlier: their median absolute deviation says too little.
OUTLIER_MIN_REPEATS = 5


def check_reference(value: object, where: str = "reference") -> str:
    """``value`` if it names a reference kind; else a one-line ConfigError naming ``where``."""
    return check_choice(value, REFERENCES, where, "repeats on one clock, or the paper's plain mean")


@dataclass(frozen=True)
class ClockAlignment:
    """How the repeats of a task were put on one clock: per repeat, in the order of the task's sources."""

    #: motion onset on the repeat's own clock [s]; None where the track never clearly moves
    onsets: list[float | None]
    #: what is added to the repeat's clock [s]: negative moves a late repeat earlier
    shifts: np.ndarray
    #: refinement steps taken
    steps: int


def read_later(times: np.ndarray, track: np.ndarray, seconds: float) -> np.ndarray:
    """``track`` (n, k), sampled at ``times``, read ``seconds`` later on its own clock: linear between samples, its
    first and last samples held outside them.

    Args:
        times: the track's sample times [s].
        track: the samples, one row per time.
        seconds: how much later (negative: earlier).
    Returns:
        The track read there, (n, k).
    """
    return _on_grid(times, track, np.array([-seconds]), times)[0]


def _on_grid(clock: np.ndarray, track: np.ndarray, shifts: np.ndarray, grid: np.ndarray) -> np.ndarray:
    """``track`` (m, k) on ``clock`` shifted by each of ``shifts`` (L,), sampled at ``grid`` (g,): (L, g, k).
    Outside the repeat its first and last samples are held."""
    at = grid[None, :] - shifts[:, None]
    return np.stack([np.interp(at, clock, track[:, j]) for j in range(track.shape[1])], axis=-1)


def _best_lag(costs: np.ndarray, lags: np.ndarray) -> float:
    """The lag of the lowest cost, refined between its neighbours by the vertex of a parabola through them."""
    k = int(np.argmin(costs))
    if 0 < k < len(costs) - 1:
        left, mid, right = costs[k - 1], costs[k], costs[k + 1]
        curve = left - 2 * mid + right
        if curve > 0:
            return float(lags[k] + 0.5 * (left - right) / curve * (lags[1] - lags[0]))
    return float(lags[k])


def _lags(step: float, reach_s: float) -> np.ndarray:
    """Lags from -``reach_s`` to ``reach_s`` in steps of ``step`` [s]."""
    count = round(reach_s / step)
    return np.arange(-count, count + 1) * step


def _refine(clocks: list[np.ndarray], tracks: list[np.ndarray], shifts: np.ndarray, grid: np.ndarray) -> int:
    """Move ``shifts`` (in place) to the fixed point of matching each repeat against the others' mean.

    One step moves each repeat in turn to its best lag against the mean of the others as they now are (the first
    step within :data:`SEARCH_S`, later ones within :data:`STEP_S`), then re-centres the shifts on their median.
    """
    step = float(grid[1] - grid[0])
    count = len(tracks)
    for steps in range(1, MAX_STEPS + 1):
        lags = _lags(step, SEARCH_S if steps == 1 else STEP_S)
        placed = np.stack([_on_grid(c, x, s[None], grid)[0] for c, x, s in zip(clocks, tracks, shifts)])
        total = placed.sum(axis=0)
        moves = np.empty(count)
        for i in range(count):
            others = (total - placed[i]) / (count - 1)
            candidates = _on_grid(clocks[i], tracks[i], shifts[i] + lags, grid)
            costs = ((candidates - others[None]) ** 2).sum(axis=2).mean(axis=1)
            moves[i] = _best_lag(costs, lags)
            shifts[i] += moves[i]
            moved = _on_grid(clocks[i], tracks[i], shifts[i : i + 1], grid)[0]
            total += moved - placed[i]
            placed[i] = moved
        shifts -= np.median(shifts)
        if np.max(np.abs(moves - np.median(moves))) < TOLERANCE_S:
            return steps
    return MAX_STEPS


def align_clocks(clocks: list[np.ndarray], tracks: list[np.ndarray], rate: float) -> ClockAlignment:
    """The shift of each repeat's clock that lines its ``tracks`` (m_i, k) up with the others'.

    ``clocks`` start at each repeat's first frame; the repeats are compared at ``rate`` x :data:`FINE` over the
    shortest repeat's length.  A single repeat has nothing to align with: shift 0.
    """
    onsets = [motion_onset(c, x) for c, x in zip(clocks, tracks)]
    shifts = np.zeros(len(tracks))
    if len(tracks) < 2:
        return ClockAlignment(onsets, shifts, 0)
    found = [o for o in onsets if o is not None]
    if found:
        median = float(np.median(found))
        shifts = np.array([0.0 if o is None else median - o for o in onsets])
    shortest = min(float(c[-1]) for c in clocks)
    grid = np.arange(int(np.floor(shortest * rate * FINE + 1e-9)) + 1) / (rate * FINE)
    steps = _refine(clocks, tracks, shifts, grid)
    return ClockAlignment(onsets, shifts, steps)


def outlier_limit(shifts: np.ndarray, floor_s: float = 0.0) -> float:
    """How far [s] a repeat's shift may lie from the median shift before it counts as an outlier.

    Args:
        shifts: each repeat's shift onto the task's clock [s].
        floor_s: the least limit the caller asks for (one sample of the reference, say) [s].

    Returns:
        :data:`OUTLIER_MADS` scaled MADs of ``shifts``, raised to ``floor_s`` and to :data:`OUTLIER_FLOOR_S`.
    """
    shifts = np.asarray(shifts, dtype=float)
    mad = MAD_SCALE * float(np.median(np.abs(shifts - np.median(shifts)))) if len(shifts) else 0.0
    return max(OUTLIER_MADS * mad, floor_s, OUTLIER_FLOOR_S)


def outlying_shifts(shifts: np.ndarray, floor_s: float = 0.0) -> list[int]:
    """The repeats whose shift lies farther than :func:`outlier_limit` from the median shift.

    Args:
        shifts: each repeat's shift onto the task's clock [s].
        floor_s: the least limit the caller asks for [s] (see :func:`outlier_limit`).

    Returns:
        Their indices, in order; none among fewer than :data:`OUTLIER_MIN_REPEATS` repeats.
    """
    shifts = np.asarray(shifts, dtype=float)
    if len(shifts) < OUTLIER_MIN_REPEATS:
        return []
    deviation = np.abs(shifts - np.median(shifts))
    return [int(i) for i in np.flatnonzero(deviation > outlier_limit(shifts, floor_s))]


def warn_outliers(sources: list[Path], shifts: np.ndarray, floor_s: float) -> None:
    """One RecordingWarning naming every repeat whose shift is an outlier (:func:`outlying_shifts`), with its
    shift, and saying what a user may do about them.

    The outliers stay in the reference: the alignment has already shifted them onto the task's clock, so a late
    start is handled; only a repeat of another motion needs the user, and the warning says how to find and drop one.

    Args:
        sources: the repeats' files, in the order of ``shifts``.
        shifts: each repeat's shift onto the task's clock [s].
        floor_s: the least limit [s] (:func:`outlier_limit`).
    """
    outliers = outlying_shifts(shifts, floor_s)
    if not outliers:
        return
    limit = outlier_limit(shifts, floor_s)
    task = Path(sources[0]).parent.name
    of_task = f" of {task}" if task else ""
    median = float(np.median(shifts))
    named = ", ".join(
        f"{display_name(sources[i])} {shifts[i]:+.3f} s ({'late' if shifts[i] < median else 'early'})" for i in outliers
    )
    check = f"`simtune check --task {task}`" if task else "`simtune check --task TASK`"
    warnings.warn(
        f"clock check: {len(outliers)} of {len(shifts)} repeats{of_task} started far from the others (shift onto "
        f"the task's clock more than {limit:.3f} s from the median: {OUTLIER_MADS:g} scaled MADs, at least "
        f"{OUTLIER_FLOOR_S:g} s): {named}. Kept: the aligned reference shifts them onto the task's clock, so a late "
        "or early start needs nothing; if one is another motion, take its file out of the task's recordings "
        f"({check} with the same data shows each repeat's distance from the mean).",
        RecordingWarning,
        stacklevel=5,  # at load_task_data's caller
    )


def spread_per_sample(repeats: np.ndarray) -> np.ndarray:
    """At each sample of repeats (r, n, k), the mean distance of a repeat from the repeats' mean (n,) [track units]."""
    return np.linalg.norm(repeats - repeats.mean(axis=0)[None], axis=2).mean(axis=0)


def spread(repeats: np.ndarray) -> float:
    """Mean over repeats (r, n, k) of the mean distance between a repeat and the repeats' mean [track units]."""
    return float(np.linalg.norm(repeats - repeats.mean(axis=0)[None], axis=2).mean(axis=1).mean())
