"""Marker positions from C3D files (the biomechanics labs' motion-capture format), through the `c3d` library.

A C3D file holds labelled 3-D points per frame at ``POINT:RATE`` Hz in
``POINT:UNITS`` (mm, cm or m); each point label becomes a body with a
position and no orientation (its rotations are NaN).  A point whose residual
is negative was not seen at that frame: NaN there, like a lost marker.
``pip install 'simtune[c3d]'``.  See docs/recordings.md.
"""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np

from simtune.data._table import display_name
from simtune.data.recording import Recording, check_units, finish_recording
from simtune.errors import RecordingError

#: POINT:UNITS values understood, and their factor to metres
UNITS_TO_M = {"mm": 1e-3, "cm": 1e-2, "m": 1.0}


def read_c3d(path: Path | str) -> Recording:
    """The labelled points of a C3D file as bodies with positions [m] (rotations NaN)."""
    path = Path(path)
    display = display_name(path)
    try:
        import c3d
    except ImportError:
        raise RecordingError(
            f"{display}: reading C3D files needs the c3d library: pip install 'simtune[c3d]'"
        ) from None
    if not path.is_file():
        raise RecordingError(f"{display}: no such file ({path})")
    try:
        with open(path, "rb") as handle, warnings.catch_warnings():
            warnings.simplefilter("ignore")  # the library warns about files without analog channels
            reader = c3d.Reader(handle)
            labels = [str(label).strip() for label in reader.point_labels]
            units = reader.get("POINT:UNITS").string_value.strip().lower()
            rate = float(reader.point_rate)
            first = int(reader.first_frame)
            frames = [(int(i), np.array(points[:, :4], dtype=float)) for i, points, _ in reader.read_frames()]
    except RecordingError:
        raise
    except Exception as exc:  # the library's errors on damaged or foreign files have no common base class
        text = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
        raise RecordingError(f"{display}: cannot read as a C3D file ({text})") from None
    if units not in UNITS_TO_M:
        raise RecordingError(f"{display}: POINT:UNITS is {units!r}; expected one of {', '.join(UNITS_TO_M)}")
    if not (np.isfinite(rate) and rate > 0):
        raise RecordingError(f"{display}: POINT:RATE is {rate:g}; expected a positive frame rate")
    if not frames:
        raise RecordingError(f"{display}: no frames")
    for k, label in enumerate(labels):
        if not label:
            raise RecordingError(f"{display}: point {k + 1} has no label")
        if label in labels[:k]:
            raise RecordingError(f"{display}: point label {label!r} appears twice")
    numbers = np.array([i for i, _ in frames])
    data = np.stack([points for _, points in frames])  # (frames, points, x y z residual)
    xyz = data[:, :, :3] * UNITS_TO_M[units]
    xyz[data[:, :, 3] < 0] = np.nan
    positions = {label: xyz[:, k].copy() for k, label in enumerate(labels)}
    rotations = {label: np.full((len(frames), 3, 3), np.nan) for label in labels}
    message = "is {peak:.4g} m away, beyond any table-top set-up: check POINT:UNITS"
    check_units(positions, numbers, display, message, line_word="frame")
    time = (numbers - first) / rate
    return finish_recording(path, display, time, numbers, positions, rotations, line_word="frame")
