"""simtune's plain CSV recording format: marker poses (metres, scalar-last quaternions), joint angles, or both.

::

    # comment lines start with '#'
    time,<body>.x,<body>.y,<body>.z,<body>.qx,<body>.qy,<body>.qz,<body>.qw,...,<joint>,<joint> [deg],...
    0.000000,0.012000,0.057000,0.874000,0.99900000,0.02000000,0.02000000,0.00100000,...,0.52359878,30.0,...

Seven columns ``<body>.x .. <body>.qw`` make a body; every other column is a
joint angle named by its joint, in radians unless its name declares
``[deg]`` (or ``[rad]``).  An empty field marks a lost marker (empty x/y/z:
position lost; empty quaternion: orientation lost); a joint angle is never
missing.  See docs/recordings.md.
"""

from __future__ import annotations

import math
import re
from collections.abc import Collection
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from simtune.data._table import (
    check_columns,
    display_name,
    format_column,
    parse_numbers,
    read_bytes,
    shorten,
    split_lines,
    write_bytes,
)
from simtune.data.recording import (
    DEGREES_HINT,
    MAX_ABS_JOINT_RAD,
    Recording,
    check_for_writing,
    check_units,
    finish_recording,
    lost_positions,
)
from simtune.errors import RecordingError

SUFFIXES = ["x", "y", "z", "qx", "qy", "qz", "qw"]
#: the angle units a joint column may declare, and the factor to radians
JOINT_UNITS = {"rad": 1.0, "deg": math.pi / 180.0}
_UNIT = re.compile(r"^(?P<name>.*?)\s*\[(?P<unit>[^\]]*)\]$")


@dataclass
class _JointColumn:
    name: str
    column: int  # 0-based
    to_rad: float
    unit: str
    declared: bool  # the header (or the task) says the unit; else radians by the format


def _is_marker_column(name: str) -> bool:
    return any(name.endswith("." + suffix) for suffix in SUFFIXES)


def _parse_header(
    fields: list[str], display: str, line: int, known_joints: Collection[str] | None, unit: str | None = None
) -> tuple[list[str], list[_JointColumn]]:
    """Body names (from ``<body>.x`` .. ``.qw`` runs) and joint columns of the header; errors name the column."""
    if not fields or fields[0].strip().lower() != "time":
        raise RecordingError(
            f"{display} line {line}: expected a header starting with 'time', "
            f"found {shorten(fields[0] if fields else '')!r}"
        )
    if len(fields) == 1:
        raise RecordingError(
            f"{display} line {line}: header has only 'time'; expected 7 columns per body "
            f"(<body>.x,.y,.z,.qx,.qy,.qz,.qw) and/or one column per joint"
        )
    names: list[str] = []
    joints: list[_JointColumn] = []
    col = 1
    while col < len(fields):
        got = fields[col].strip()
        if not _is_marker_column(got):
            joints.append(_joint_column(got, col, display, line, known_joints, [j.name for j in joints], unit))
            col += 1
            continue
        body = got.rpartition(".")[0] if got.endswith(".x") else ""
        for k, suffix in enumerate(SUFFIXES):
            got = fields[col + k].strip() if col + k < len(fields) else ""
            if not body or got != f"{body}.{suffix}":
                want = f"{body or '<body>'}.{suffix}"
                raise RecordingError(
                    f"{display} line {line}, column {col + k + 1}: expected {want!r}, found {shorten(got)!r}"
                )
        if body in names:
            raise RecordingError(f"{display} line {line}: body {body!r} appears twice")
        names.append(body)
        col += len(SUFFIXES)
    return names, joints


def _joint_column(
    text: str, col: int, display: str, line: int, known: Collection[str] | None, seen: list[str], stated: str | None
) -> _JointColumn:
    """One joint column of the header: its name and unit (``[deg]`` after the name, else ``stated``, the task's
    unit, else radians)."""
    where = f"{display} line {line}, column {col + 1}"
    name, unit = text, stated or "rad"
    match = _UNIT.match(text)
    if match:
        name, unit = match["name"].strip(), match["unit"].strip().lower()
        if unit not in JOINT_UNITS:
            raise RecordingError(
                f"{where}: unknown angle unit {match['unit']!r} for joint {name!r} (use [rad] or [deg])"
            )
    if not name:
        raise RecordingError(f"{where}: empty column name (expected a joint name or <body>.x)")
    if known is not None and name not in known:
        raise RecordingError(f"{where}: unknown joint {shorten(name)!r} (the arm's joints: {', '.join(known)})")
    if name in seen:
        raise RecordingError(f"{where}: joint {name!r} appears twice")
    return _JointColumn(name, col, JOINT_UNITS[unit], unit, bool(match) or stated is not None)


def _joint_angles(
    values: np.ndarray, columns: list[_JointColumn], linenos: np.ndarray, display: str
) -> dict[str, np.ndarray]:
    """Each joint column in radians; a missing angle or degrees in a radian column is an error naming the cell."""
    joints: dict[str, np.ndarray] = {}
    for jc in columns:
        raw = values[:, jc.column]
        missing = np.flatnonzero(np.isnan(raw))
        if missing.size:
            i = int(missing[0])
            raise RecordingError(
                f"{display} line {int(linenos[i])}, column {jc.column + 1}: joint {jc.name!r} has no angle "
                "(a joint log needs a value in every line)"
            )
        angles = raw * jc.to_rad
        beyond = np.flatnonzero(np.abs(angles) > MAX_ABS_JOINT_RAD)
        if beyond.size:
            i = int(beyond[0])
            value = f"{raw[i]:.6g} rad" if jc.unit == "rad" else f"{raw[i]:.6g} deg ({angles[i]:.4g} rad)"
            if jc.unit == "rad":
                hint = f"looks like degrees: declare the unit in the header as '{jc.name} [deg]' ({DEGREES_HINT})"
            else:
                hint = "more than two turns, not a joint angle"
            raise RecordingError(
                f"{display} line {int(linenos[i])}, column {jc.column + 1}: units check: joint {jc.name!r} is "
                f"{value}: {hint}"
            )
        joints[jc.name] = angles
    return joints


def read_csv(path: Path, joint_names: Collection[str] | None = None, joint_units: str | None = None) -> Recording:
    """Read a simtune CSV recording (optionally gzipped); ``joint_names``: the joints a column may name;
    ``joint_units``: the unit of joint columns that declare none (the task's; default radians)."""
    display = display_name(path)
    raw = split_lines(read_bytes(path, display))
    # Comments and blank lines carry no data; remember real line numbers for messages.
    kept = [(i + 1, line) for i, line in enumerate(raw) if line.strip() and not line.lstrip().startswith(b"#")]
    if not kept:
        raise RecordingError(f"{display} line 1: file is empty (no header and no data lines)")
    head_line, head = kept[0]
    names, joint_columns = _parse_header(
        head.decode("utf-8", errors="replace").split(","), display, head_line, joint_names, joint_units
    )
    if len(kept) == 1:
        raise RecordingError(f"{display} line {head_line}: no data lines after the header")
    linenos = np.array([ln for ln, _ in kept[1:]])
    data = [line for _, line in kept[1:]]
    data, linenos, ncols = check_columns(data, linenos, b",", display)
    expected = 1 + len(SUFFIXES) * len(names) + len(joint_columns)
    if ncols != expected:
        raise RecordingError(
            f"{display} line {int(linenos[0])}: expected {expected} columns (as in the header), found {ncols}"
        )
    values = parse_numbers(data, linenos, b",", ncols, list(range(ncols)), display)
    n = values.shape[0]
    positions: dict[str, np.ndarray] = {}
    rotations: dict[str, np.ndarray] = {}
    starts = [c for c in range(1, ncols) if c not in {jc.column for jc in joint_columns}][:: len(SUFFIXES)]
    for name, base in zip(names, starts):
        xyz = values[:, base : base + 3].copy()
        xyz[lost_positions(xyz, zero_is_lost=False)] = np.nan
        positions[name] = xyz
        quat = values[:, base + 3 : base + 7]
        norm = np.linalg.norm(quat, axis=1)
        ok = np.isfinite(norm) & (norm > 1e-9)
        rot = np.full((n, 3, 3), np.nan)
        if ok.any():
            # scipy normalises, so slightly rounded quaternions are fine.
            from scipy.spatial.transform import Rotation  # on use: SciPy's spatial costs every command 0.5 s

            rot[ok] = Rotation.from_quat(quat[ok]).as_matrix()
        rotations[name] = rot
    check_units(
        positions,
        linenos,
        display,
        "has values up to {peak:.4g} — looks like millimetres; this format expects metres",
    )
    joints = _joint_angles(values, joint_columns, linenos, display)
    rec = finish_recording(Path(path), display, values[:, 0].copy(), linenos, positions, rotations, joints)
    rec.joint_units = {jc.name: jc.unit for jc in joint_columns if jc.declared}
    return rec


def write_csv(path: Path | str, rec: Recording) -> None:
    """Write ``rec`` in simtune's CSV format (gzip if the name ends in ``.gz``); joint angles in radians."""
    path = Path(path)
    display = display_name(path)
    n = check_for_writing(rec, display, forbidden=",\r\n")
    header = ["time"]
    columns: list[list[str]] = [format_column(np.asarray(rec.time, dtype=float), ".6f")]
    for name in rec.positions:
        header.extend(f"{name}.{s}" for s in SUFFIXES)
        xyz = np.asarray(rec.positions[name], dtype=float).copy()
        xyz[~np.isfinite(xyz).all(axis=1)] = np.nan
        rot = np.asarray(rec.rotations[name], dtype=float)
        valid = np.isfinite(rot).all(axis=(1, 2))
        quat = np.full((n, 4), np.nan)
        if valid.any():
            from scipy.spatial.transform import Rotation

            quat[valid] = Rotation.from_matrix(rot[valid]).as_quat()
        for k in range(3):
            columns.append(format_column(xyz[:, k], ".6f"))
        for k in range(4):
            columns.append(format_column(quat[:, k], ".8f"))
    for name, angles in rec.joints.items():
        header.append(name)
        columns.append(format_column(np.asarray(angles, dtype=float), ".8f"))
    out = [
        "# simtune recording: time [s], position [m], quaternion x y z w, joint angles [rad]; empty = marker lost",
        ",".join(header),
    ]
    out.extend(",".join(row) for row in zip(*columns))
    write_bytes(path, ("\n".join(out) + "\n").encode("utf-8"), display)
