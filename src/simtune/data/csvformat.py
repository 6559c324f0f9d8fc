"""simtune's plain CSV recording format (metres, seconds, scalar-last quaternions).

::

    # comment lines start with '#'
    time,<body>.x,<body>.y,<body>.z,<body>.qx,<body>.qy,<body>.qz,<body>.qw,...
    0.000000,0.012000,0.057000,0.874000,0.99900000,0.02000000,0.02000000,0.00100000,...

An empty field marks a lost marker (empty x/y/z: position lost; empty
quaternion: orientation lost).  See docs/recordings.md.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from scipy.spatial.transform import Rotation

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
    Recording,
    check_for_writing,
    check_units,
    finish_recording,
    lost_positions,
)
from simtune.errors import RecordingError

SUFFIXES = ["x", "y", "z", "qx", "qy", "qz", "qw"]


def _parse_header(fields: list[str], display: str, line: int) -> list[str]:
    """Body names from ``time,<body>.x,...``; any deviation is an error naming the column."""
    if not fields or fields[0].strip().lower() != "time":
        raise RecordingError(
            f"{display} line {line}: expected a header starting with 'time', "
            f"found {shorten(fields[0] if fields else '')!r}"
        )
    if len(fields) == 1 or (len(fields) - 1) % len(SUFFIXES):
        raise RecordingError(
            f"{display} line {line}: header has {len(fields)} columns; expected 'time' and "
            f"7 per body (<body>.x,.y,.z,.qx,.qy,.qz,.qw)"
        )
    names: list[str] = []
    for b in range((len(fields) - 1) // len(SUFFIXES)):
        col0 = 1 + b * len(SUFFIXES)
        body = fields[col0].strip().rpartition(".")[0]
        for k, suffix in enumerate(SUFFIXES):
            got = fields[col0 + k].strip()
            if not body or got != f"{body}.{suffix}":
                want = f"{body or '<body>'}.{suffix}"
                raise RecordingError(
                    f"{display} line {line}, column {col0 + k + 1}: expected {want!r}, found {shorten(got)!r}"
                )
        if body in names:
            raise RecordingError(f"{display} line {line}: body {body!r} appears twice")
        names.append(body)
    return names


def read_csv(path: Path) -> Recording:
    """Read a simtune CSV recording (optionally gzipped)."""
    display = display_name(path)
    raw = split_lines(read_bytes(path, display))
    # Comments and blank lines carry no data; remember real line numbers for messages.
    kept = [(i + 1, line) for i, line in enumerate(raw) if line.strip() and not line.lstrip().startswith(b"#")]
    if not kept:
        raise RecordingError(f"{display} line 1: file is empty (no header and no data lines)")
    head_line, head = kept[0]
    names = _parse_header(head.decode("utf-8", errors="replace").split(","), display, head_line)
    if len(kept) == 1:
        raise RecordingError(f"{display} line {head_line}: no data lines after the header")
    linenos = np.array([ln for ln, _ in kept[1:]])
    data = [line for _, line in kept[1:]]
    data, linenos, ncols = check_columns(data, linenos, b",", display)
    expected = 1 + len(SUFFIXES) * len(names)
    if ncols != expected:
        raise RecordingError(
            f"{display} line {int(linenos[0])}: expected {expected} columns (as in the header), found {ncols}"
        )
    values = parse_numbers(data, linenos, b",", ncols, list(range(ncols)), display)
    n = values.shape[0]
    positions: dict[str, np.ndarray] = {}
    rotations: dict[str, np.ndarray] = {}
    for b, name in enumerate(names):
        base = 1 + b * len(SUFFIXES)
        xyz = values[:, base : base + 3].copy()
        xyz[lost_positions(xyz, zero_is_lost=False)] = np.nan
        positions[name] = xyz
        quat = values[:, base + 3 : base + 7]
        norm = np.linalg.norm(quat, axis=1)
        ok = np.isfinite(norm) & (norm > 1e-9)
        rot = np.full((n, 3, 3), np.nan)
        if ok.any():
            # scipy normalises, so slightly rounded quaternions are fine.
            rot[ok] = Rotation.from_quat(quat[ok]).as_matrix()
        rotations[name] = rot
    check_units(
        positions,
        linenos,
        display,
        "has values up to {peak:.4g} — looks like millimetres; this format expects metres",
    )
    return finish_recording(Path(path), display, values[:, 0].copy(), linenos, positions, rotations)


def write_csv(path: Path | str, rec: Recording) -> None:
    """Write ``rec`` in simtune's CSV format (gzip if the name ends in ``.gz``)."""
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
            quat[valid] = Rotation.from_matrix(rot[valid]).as_quat()
        for k in range(3):
            columns.append(format_column(xyz[:, k], ".6f"))
        for k in range(4):
            columns.append(format_column(quat[:, k], ".8f"))
    out = [
        "# simtune recording: time [s], position [m], quaternion x y z w; empty = marker lost",
        ",".join(header),
    ]
    out.extend(",".join(row) for row in zip(*columns))
    write_bytes(path, ("\n".join(out) + "\n").encode("utf-8"), display)
