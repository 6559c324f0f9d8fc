"""Qualisys Track Manager "6D" TSV files: reading (with or without header block) and writing.

Layout of a data line: frame, time [s], then per rigid body 16 values
(X Y Z [mm], Roll Pitch Yaw [deg], Residual [mm], Rot[0..8]) and one empty
column.  Rot[0..8] is the body-to-world rotation matrix stored column by
column (checked against the real files: reading it row-major gives the
transpose), and Roll/Pitch/Yaw are intrinsic x-y-z angles, R = Rx Ry Rz.
"""

from __future__ import annotations

import re
import warnings
from pathlib import Path

import numpy as np

from simtune.data._table import (
    check_columns,
    display_name,
    format_column,
    parse_numbers,
    read_bytes,
    split_lines,
    write_bytes,
)
from simtune.data.recording import (
    QRG2019_BODIES,
    Recording,
    check_for_writing,
    check_units,
    clean_rotations,
    finish_recording,
    lost_positions,
)
from simtune.errors import RecordingError, RecordingWarning

#: Euler sequence of Qualisys Roll/Pitch/Yaw for scipy (upper case = intrinsic).
EULER_SEQ = "XYZ"
VALUES_PER_BODY = 16
COLUMNS_PER_BODY = VALUES_PER_BODY + 1  # the values plus one empty separator column
_COLUMN_LABELS = ["X", "Y", "Z", "Roll", "Pitch", "Yaw", "Residual"] + [f"Rot[{i}]" for i in range(9)]
_KEYWORD = re.compile(rb"^[A-Z][A-Z0-9_]*$")


def _is_number(text: bytes) -> bool:
    try:
        float(text)
    except ValueError:
        return False
    return True


def _bodies_for(ncols: int) -> int | None:
    """Bodies in ``ncols`` body columns (last separator optional), or None if it does not fit."""
    if ncols >= VALUES_PER_BODY and ncols % COLUMNS_PER_BODY in (0, VALUES_PER_BODY):
        return (ncols + 1) // COLUMNS_PER_BODY
    return None


class _Header:
    """The Qualisys header block: ``KEY<TAB>value...`` lines, then a column-name line."""

    def __init__(self) -> None:
        self.keys: dict[str, list[str]] = {}
        self.lines: dict[str, int] = {}
        self.columns: list[str] | None = None
        self.size = 0  # number of lines the header occupies

    def __bool__(self) -> bool:
        return self.size > 0


def _read_header(lines: list[bytes]) -> _Header:
    head = _Header()
    i = 0
    while i < len(lines):
        fields = lines[i].split(b"\t")
        first = fields[0].strip()
        if not first or _is_number(first):
            break
        text = [f.decode("utf-8", errors="replace").strip() for f in fields]
        if _KEYWORD.match(first):
            head.keys[text[0]] = text[1:]
            head.lines[text[0]] = i + 1
            i += 1
            continue
        if first == b"Frame" or first.endswith(b" X"):
            head.columns = text
            i += 1
        break
    head.size = i
    if i and "BODY_NAMES" not in head.keys and head.columns is None:
        # Capitalised text on line 1 of a headerless file is bad data, not a header.
        return _Header()
    return head


def read_qualisys_tsv(path: Path, body_names: list[str] | None = None) -> Recording:
    """Read a Qualisys 6D TSV (optionally gzipped) into a Recording in metres."""
    display = display_name(path)
    lines = split_lines(read_bytes(path, display))
    head = _read_header(lines)
    data = lines[head.size :]
    while data and not data[-1].strip():
        data.pop()
    if not data:
        if head:
            raise RecordingError(f"{display} line {head.size + 1}: no data lines after the header")
        raise RecordingError(f"{display} line 1: file is empty (no data lines)")
    linenos = np.arange(head.size + 1, head.size + 1 + len(data))
    data, linenos, ncols = check_columns(data, linenos, b"\t", display)
    first_line = int(linenos[0])

    # Which layout: frame+time columns first (headerless files always), or bodies only.
    layout_msg = (
        f"{display} line {first_line}: {ncols} columns do not fit the 6D layout "
        f"(frame, time, then 16 values and an empty column per body)"
    )
    if head.columns is not None:
        has_time = head.columns[0].lower() == "frame"
        nbodies = _bodies_for(ncols - 2 if has_time else ncols)
    elif head and _bodies_for(ncols - 2) is None:
        has_time, nbodies = False, _bodies_for(ncols)
    else:
        has_time, nbodies = True, _bodies_for(ncols - 2)
    if nbodies is None:
        raise RecordingError(layout_msg)
    names = _body_names(head, nbodies, body_names, display, first_line)

    offset = 2 if has_time else 0
    numeric = ([0, 1] if has_time else []) + [
        offset + COLUMNS_PER_BODY * b + k for b in range(nbodies) for k in range(VALUES_PER_BODY)
    ]
    values = parse_numbers(data, linenos, b"\t", ncols, numeric, display)
    n = values.shape[0]
    _check_frame_count(head, n, display)

    if has_time:
        time = values[:, 1].copy()
    else:
        time = np.arange(n) / _frequency(head, display)

    positions: dict[str, np.ndarray] = {}
    rotations: dict[str, np.ndarray] = {}
    for b, name in enumerate(names):
        base = offset + COLUMNS_PER_BODY * b
        xyz = values[:, base : base + 3] / 1000.0  # mm -> m
        lost = lost_positions(xyz, zero_is_lost=True)
        xyz[lost] = np.nan
        positions[name] = xyz
        # Stored column-major: the row-major reshape is R^T.
        rot = values[:, base + 7 : base + 16].reshape(n, 3, 3).transpose(0, 2, 1).copy()
        rot[lost] = np.nan  # a body without a position was not tracked at all
        rotations[name] = clean_rotations(rot, name, display)
    check_units(
        positions,
        linenos,
        display,
        "reaches {peak:.4g} m after dividing by 1000 — looks like it is not in millimetres",
    )
    return finish_recording(Path(path), display, time, linenos, positions, rotations)


def _body_names(head: _Header, nbodies: int, given: list[str] | None, display: str, line: int) -> list[str]:
    """Header BODY_NAMES win; else names from the column-name line; else ``given``/defaults."""
    if "BODY_NAMES" in head.keys:
        names = [x for x in head.keys["BODY_NAMES"] if x]
        where = head.lines["BODY_NAMES"]
        source = "BODY_NAMES"
    elif head.columns is not None:
        names = [c[:-2].strip() for c in head.columns if c.endswith(" X")]
        where = head.size
        source = "the column names"
    else:
        names = list(QRG2019_BODIES if given is None else given)
        if len(names) != nbodies:
            raise RecordingError(
                f"{display} line {line}: the file has {nbodies} bodies but "
                f"{len(names)} body names were given ({', '.join(names)})"
            )
        where, source = line, "body_names"
    if len(names) != nbodies:
        raise RecordingError(f"{display} line {where}: {source} lists {len(names)} bodies but the data has {nbodies}")
    if len(set(names)) != len(names):
        raise RecordingError(f"{display} line {where}: {source} repeats a body name ({', '.join(names)})")
    return names


def _frequency(head: _Header, display: str) -> float:
    """Frame rate from the header, for files that have no time column."""
    where = head.lines.get("FREQUENCY", 1)
    try:
        freq = float(head.keys.get("FREQUENCY", [""])[0])
    except (ValueError, IndexError):
        freq = float("nan")
    if not (np.isfinite(freq) and freq > 0):
        raise RecordingError(f"{display} line {where}: no time column and no valid FREQUENCY in the header")
    return freq


def _check_frame_count(head: _Header, n: int, display: str) -> None:
    """Warn when NO_OF_FRAMES disagrees with the data (a cut-off export)."""
    try:
        expected = int(head.keys["NO_OF_FRAMES"][0])
    except (KeyError, IndexError, ValueError):
        return
    if expected != n:
        warnings.warn(
            f"{display} line {head.lines['NO_OF_FRAMES']}: header says {expected} frames, the file holds {n}",
            RecordingWarning,
            stacklevel=4,
        )


def write_qualisys_tsv(path: Path | str, rec: Recording, header: bool = False) -> None:
    """Write ``rec`` as a Qualisys 6D TSV (mm, 5 decimals, CRLF; gzip if ``.gz``).

    Lost markers become empty fields, the residual is 0.  With ``header`` the
    Qualisys header block (with BODY_NAMES and a Frame/Time column-name line)
    comes first; without it the body names are not stored, so pass them back
    as ``body_names`` when reading.
    """
    path = Path(path)
    display = display_name(path)
    n = check_for_writing(rec, display, forbidden="\t\r\n")
    time = np.asarray(rec.time, dtype=float)
    columns: list[list[str]] = [[str(i + 1) for i in range(n)], format_column(time, ".5f")]
    for name in rec.positions:
        xyz = np.asarray(rec.positions[name], dtype=float) * 1000.0
        rot = np.asarray(rec.rotations[name], dtype=float)
        seen = np.isfinite(xyz).all(axis=1)
        xyz[~seen] = np.nan
        valid = np.isfinite(rot).all(axis=(1, 2))
        rpy = np.full((n, 3), np.nan)
        if valid.any():
            with warnings.catch_warnings():
                # Gimbal lock only makes the split between roll and yaw arbitrary.
                warnings.simplefilter("ignore", UserWarning)
                from scipy.spatial.transform import Rotation  # on use: SciPy's spatial costs every command 0.4 s

                rpy[valid] = Rotation.from_matrix(rot[valid]).as_euler(EULER_SEQ, degrees=True)
        flat = rot.transpose(0, 2, 1).reshape(n, 9)  # column-major, as Qualisys stores it
        flat[~valid] = np.nan
        residual = np.where(seen, 0.0, np.nan)
        for k in range(3):
            columns.append(format_column(xyz[:, k], ".5f"))
        for k in range(3):
            columns.append(format_column(rpy[:, k], ".5f"))
        columns.append(format_column(residual, ".5f"))
        for k in range(9):
            columns.append(format_column(flat[:, k], ".5f"))
        columns.append([""] * n)
    out: list[str] = []
    if header:
        out.extend(_header_lines(rec, n, time))
    out.extend("\t".join(row) for row in zip(*columns))
    write_bytes(path, ("\r\n".join(out) + "\r\n").encode("utf-8"), display)


def _header_lines(rec: Recording, n: int, time: np.ndarray) -> list[str]:
    step = np.median(np.diff(time)) if n > 1 else 0.0
    freq = 1.0 / step if step > 0 else 0.0
    names = list(rec.positions)
    column_names = ["Frame", "Time"]
    for name in names:
        column_names.extend([f"{name} X"] + _COLUMN_LABELS[1:] + [""])
    return [
        f"NO_OF_FRAMES\t{n}",
        "NO_OF_CAMERAS\t0",
        f"NO_OF_BODIES\t{len(names)}",
        f"FREQUENCY\t{freq:.6g}",
        "NO_OF_ANALOG\t0",
        "ANALOG_FREQUENCY\t0",
        "DESCRIPTION\twritten by simtune",
        "DATA_INCLUDED\t6D",
        "BODY_NAMES\t" + "\t".join(names),
        "\t".join(column_names),
    ]
