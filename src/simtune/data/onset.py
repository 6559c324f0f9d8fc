"""When a recorded (or simulated) wrist starts to move: the motion onset of a track.

The onset is the first time the wrist is more than :data:`ONSET_M` from where it rested
at the start (the median of its first :data:`REST_S` seconds), so marker jitter of a few
millimetres never counts as motion.  A recording's clock starts when the operator
pressed record, not when the arm was commanded; the difference between a recording's
onset and a simulation's onset is the recording's command delay.
"""

from __future__ import annotations

import numpy as np

#: Distance [m] from the rest position that counts as motion (well above marker jitter).
ONSET_M = 0.005
#: A departure of this many thresholds is motion for sure; the onset is where it last left the rest threshold.
CLEAR = 4.0
#: The first seconds of a track taken as the arm at rest.
REST_S = 0.5


def motion_onset(times: np.ndarray, track: np.ndarray, threshold: float = ONSET_M) -> float | None:
    """When ``track`` (n, 3) leaves its rest position for good [s]; None if it never moves clearly.

    The time it last crossed ``threshold`` before its first departure beyond :data:`CLEAR` x
    ``threshold``.  Between the two samples around the crossing the time is interpolated linearly, so the
    onset is not tied to the sampling grid.
    """
    times = np.asarray(times, dtype=float)
    track = np.asarray(track, dtype=float)
    ok = np.isfinite(track).all(axis=1)
    if not ok.any():
        return None
    times, track = times[ok], track[ok]
    rest = np.median(track[times - times[0] <= REST_S], axis=0)
    distance = np.linalg.norm(track - rest, axis=1)
    # the first clear departure, then back to the last sample still at rest: a single stray sample
    # (a marker glitch) never counts as motion
    moving = np.flatnonzero(distance > CLEAR * threshold)
    if moving.size == 0:
        return None
    resting = np.flatnonzero(distance[: moving[0]] <= threshold)
    if resting.size == 0:
        return float(times[0])
    k = int(resting[-1]) + 1
    d0, d1 = distance[k - 1], distance[k]
    share = (threshold - d0) / (d1 - d0) if d1 > d0 else 1.0
    return float(times[k - 1] + share * (times[k] - times[k - 1]))
