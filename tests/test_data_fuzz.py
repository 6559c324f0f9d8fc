"""Property: damaged files give a Recording or a RecordingError, never another exception."""

from __future__ import annotations

import tempfile
import warnings
from pathlib import Path

import numpy as np
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from scipy.spatial.transform import Rotation

from simtune.data import Recording, load_recording, write_csv, write_qualisys_tsv
from simtune.errors import RecordingError

N = 8
BAD_CELLS = [
    "abc",
    "nan",
    "NaN",
    "inf",
    "-inf",
    "",
    "1e999",
    "-",
    ".",
    "1.2.3",
    "--1",
    " 5 ",
    "0",
    "0.00000",
    "1e5",
    "99999999999",
    "1_0",
    "\x00",
    "é",
    "\t",
    "\r\n",
    "+-3",
]


def _valid_recording() -> Recording:
    t = np.arange(N) / 100.0
    rot = Rotation.from_rotvec(np.c_[0.1 * t, 2.0 + t, -t]).as_matrix()
    pos = {
        "RB2(Black)": np.c_[np.full(N, 0.0005), np.full(N, 0.001), np.full(N, -0.0003)],
        "RB1(Orange)": np.c_[t, 0.06 + t, 0.87 - t],
        "PCube": np.c_[0.5 + t, np.full(N, 0.006), np.full(N, 0.04)],
    }
    return Recording(Path("x"), t, pos, {k: rot.copy() for k in pos})


def _file_bytes(kind: str) -> bytes:
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / f"v.{kind}"
        if kind == "csv":
            write_csv(path, _valid_recording())
        else:
            write_qualisys_tsv(path, _valid_recording(), header=(kind == "hdr.tsv"))
        return path.read_bytes()


VALID = {kind: _file_bytes(kind) for kind in ["tsv", "hdr.tsv", "csv"]}


@st.composite
def mutation(draw: st.DrawFn, data: bytes, sep: bytes) -> bytes:
    """One random damage: cut, replace a field, drop/duplicate/swap lines, insert bytes."""
    kind = draw(st.sampled_from(["cut", "field", "field", "line", "insert"]))
    if kind == "cut":
        return data[: draw(st.integers(0, len(data)))]
    if kind == "insert":
        at = draw(st.integers(0, len(data)))
        return data[:at] + draw(st.binary(min_size=1, max_size=8)) + data[at:]
    lines = data.split(b"\n")
    i = draw(st.integers(0, len(lines) - 1))
    if kind == "line":
        j = draw(st.integers(0, len(lines) - 1))
        op = draw(st.sampled_from(["drop", "dup", "swap"]))
        if op == "drop":
            del lines[i]
        elif op == "dup":
            lines.insert(i, lines[i])
        else:
            lines[i], lines[j] = lines[j], lines[i]
        return b"\n".join(lines)
    fields = lines[i].split(sep)
    c = draw(st.integers(0, len(fields) - 1))
    cell = draw(st.one_of(st.sampled_from(BAD_CELLS), st.text(max_size=6)))
    fields[c] = cell.encode("utf-8")
    lines[i] = sep.join(fields)
    return b"\n".join(lines)


@st.composite
def damaged(draw: st.DrawFn) -> tuple[str, bytes]:
    kind = draw(st.sampled_from(sorted(VALID)))
    data = VALID[kind]
    sep = b"," if kind == "csv" else b"\t"
    for _ in range(draw(st.integers(1, 3))):
        data = draw(mutation(data, sep))
    return kind, data


@settings(max_examples=300, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(damaged())
def test_damaged_file_loads_or_raises_recording_error(case: tuple[str, bytes]) -> None:
    kind, data = case
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / f"damaged.{kind.split('.')[-1]}"
        path.write_bytes(data)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            try:
                rec = load_recording(path)
            except RecordingError as exc:
                msg = str(exc)
                assert "damaged" in msg and "\n" not in msg
                return
    n = len(rec)
    assert n >= 2 and rec.time.shape == (n,)
    assert np.all(np.isfinite(rec.time)) and np.all(np.diff(rec.time) > 0)
    for name in rec.bodies:
        pos, rot = rec.positions[name], rec.rotations[name]
        assert pos.shape == (n, 3) and rot.shape == (n, 3, 3)
        assert not np.any(np.isinf(pos)) and not np.any(np.isinf(rot))
        assert np.nanmax(np.abs(pos), initial=0.0) <= 10.0
        # A frame's position is all there or all lost.
        assert np.all(np.isnan(pos).all(axis=1) == np.isnan(pos).any(axis=1))


@settings(max_examples=100, deadline=None)
@given(st.binary(max_size=300), st.sampled_from(["x.tsv", "x.csv", "x.tsv.gz"]))
def test_random_bytes_never_crash(data: bytes, name: str) -> None:
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / name
        path.write_bytes(data)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            try:
                load_recording(path)
            except RecordingError:
                pass
