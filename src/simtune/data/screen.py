"""Repeat check: a repeat far from the others by the aligned floor is left out, named, before the reference is made.

One physically wrong repeat among good ones (a marker glitch, a mirrored or body-swapped take, an object the arm
never touched) passes every per-file check, yet moves the reference and the floor of the fitness by 5-12x.  The
repeat check judges each repeat by its *own floor*: what the fitness of a perfect simulation would be against it
(:func:`simtune.fitness.repeat_floor`'s parts with the default weights: the wrist's mean distance, the final
object position's distance, :data:`JOINT_WEIGHT` x the joints' mean angle difference), measured on the repeats
put on one clock (the aligned reference) and from their per-sample *median* rather than their mean, so that the
damaged repeat does not drag the centre it is judged from.

A repeat whose floor is more than :data:`FAR_FACTOR` times the median floor of the other repeats (and at least
:data:`FAR_MIN` above it), or whose largest distance from the median track at one sample is more than
:data:`PEAK_FACTOR` times the others' median (and at least :data:`PEAK_MIN` above it: a short marker glitch), is
far.  The farthest one is left out with a warning naming its file, and the check runs again on the others (a
far repeat drags the alignment of the rest), until none is far or half of them would be gone
(``--keep-repeats`` keeps them all).  On the 23 + 23 real qrg2019 repeats (``single``, ``cube``) the largest
ratios are 2.2 (floor) and 3.2 (peak): none is left out; a mirrored, body-swapped, glitched or untouched-object
repeat lies 13 to several hundred times out.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

#: A repeat's floor more than this many times the median floor of the other repeats is far.  The real qrg2019
#: repeats reach 2.2 x (cube) and 1.9 x (single).
FAR_FACTOR = 5.0
#: ... and it must lie at least this far [fitness units: m] above that median: repeats that agree to a tenth of
#: a millimetre (synthetic ones without noise) are not told apart by their ratio alone.
FAR_MIN = 0.002
#: A repeat whose largest distance from the median at one sample (its peak) is more than this many times the
#: median peak of the others is far too: a marker glitch of half a second in a 20-s take barely moves the floor.
#: The real repeats' peaks reach 3.2 x (cube: 31 mm against 9.8 mm); a 20-cm glitch lies 28-32 x out.
PEAK_FACTOR = 8.0
#: ... and at least this far [m] above that median peak.
PEAK_MIN = 0.05
#: Fewer repeats than this cannot tell which one is wrong.
FAR_MIN_REPEATS = 3
#: Weight of a joint error [m per rad], here and as the fitness's default (:data:`simtune.fitness.JOINT_WEIGHT`,
#: defined here, below it): an angle error of 1 rad counts as 0.5 m, about the lever from a table-top arm's
#: shoulder to its wrist, so a joint error and the wrist displacement it causes weigh about alike when a recording
#: holds both.
JOINT_WEIGHT = 0.5


@dataclass(frozen=True)
class FarRepeat:
    """A repeat far from the others: its index, what tells it (``floor`` or ``peak``), its value and the median
    value of the other repeats [m]."""

    index: int
    measure: str
    own: float
    others: float

    @property
    def excess(self) -> float:
        """How far past its limit the repeat lies (above 1: far), to rank the far repeats."""
        factor = FAR_FACTOR if self.measure == "floor" else PEAK_FACTOR
        return self.own / (factor * max(self.others, 1e-12))

    def describe(self) -> str:
        """``its own floor 0.1322 m is 89.3 x the others' median 0.0015 m; more than 5 x is far``"""
        factor = FAR_FACTOR if self.measure == "floor" else PEAK_FACTOR
        what = "own floor" if self.measure == "floor" else "largest distance from the median track"
        ratio = self.own / max(self.others, 1e-12)
        return (
            f"its {what} {self.own:.4f} m is {ratio:.1f} x the others' median {self.others:.4f} m; "
            f"more than {factor:g} x is far"
        )


def _per_sample(wrists: np.ndarray | None, joints: np.ndarray | None) -> np.ndarray | None:
    """Each repeat's distance from the repeats' per-sample median at every sample (r, n) [m], or None."""
    distance = None
    if wrists is not None:
        distance = np.linalg.norm(wrists - np.median(wrists, axis=0)[None], axis=2)
    if joints is not None:
        angles = JOINT_WEIGHT * np.abs(joints - np.median(joints, axis=0)[None]).mean(axis=2)
        distance = angles if distance is None else distance + angles
    return distance


def _far(values: np.ndarray, measure: str, factor: float, least: float) -> list[FarRepeat]:
    far = []
    for i, own in enumerate(values):
        others = float(np.median(np.delete(values, i)))
        if own > factor * others and own - others > least:
            far.append(FarRepeat(i, measure, float(own), others))
    return far


def far_repeats(
    wrists: np.ndarray | None, object_finals: np.ndarray | None, joints: np.ndarray | None
) -> list[FarRepeat]:
    """The repeats far from the others, by their own floor or their peak (see the module's notes).

    Args:
        wrists: the aligned wrist tracks (r, n, 3) [m], or None.
        object_finals: the final object positions (r, 3) [m], or None.
        joints: the aligned joint angles (r, n, J) [rad], or None.

    Returns:
        One :class:`FarRepeat` per far repeat (by its floor where both tell it), in order; none among fewer than
        :data:`FAR_MIN_REPEATS` repeats, and none where half of them or more would be far (no majority agrees).
    """
    counts = [len(a) for a in (wrists, object_finals, joints) if a is not None]
    if not counts or counts[0] < FAR_MIN_REPEATS:
        return []
    floors = np.zeros(counts[0])
    peaks = np.zeros(counts[0])
    distance = _per_sample(wrists, joints)
    if distance is not None:
        floors += distance.mean(axis=1)
        peaks = distance.max(axis=1)
    if object_finals is not None:
        floors += np.linalg.norm(object_finals - np.median(object_finals, axis=0)[None], axis=1)
    by_floor = _far(floors, "floor", FAR_FACTOR, FAR_MIN)
    named = {f.index for f in by_floor}
    far = sorted(
        by_floor + [f for f in _far(peaks, "peak", PEAK_FACTOR, PEAK_MIN) if f.index not in named],
        key=lambda f: f.index,
    )
    return far if len(far) < counts[0] / 2 else []
