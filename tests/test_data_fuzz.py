"""Property: damaged files give a Recording or a RecordingError, never another exception."""

from __future__ import annotations

import tempfile
import warnings
from pathlib import Path

import numpy as np
import pytest
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


# Starts of content that the encoding check acts on: compressions, byte-order marks, archives.
MAGIC = [b"", b"\x1f\x8b", b"BZh", b"\xfd7zXZ\x00", b"\xef\xbb\xbf", b"\xff\xfe", b"\xfe\xff", b"PK\x03\x04"]


@settings(max_examples=150, deadline=None)
@given(st.sampled_from(MAGIC), st.binary(max_size=300), st.sampled_from(["x.tsv", "x.csv", "x.tsv.gz"]))
def test_random_bytes_never_crash(magic: bytes, data: bytes, name: str) -> None:
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / name
        path.write_bytes(magic + data)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            try:
                load_recording(path)
            except RecordingError:
                pass


# --- the sanity stage of load_task_data: units and durations -------------------------------

WRIST, BASE = "RB1(Orange)", "RB2(Black)"
RATE = 20.0


def _repeat(duration: float, scale: float = 1.0) -> Recording:
    """A wrist circling the base 0.5 m out and 0.4 m up (inside the MICO's workspace), positions x ``scale``."""
    n = int(round(duration * RATE)) + 1
    t = np.arange(n) / RATE
    wrist = np.c_[0.5 * np.cos(0.3 * t), 0.5 * np.sin(0.3 * t), 0.4 + 0.05 * np.sin(t)]
    base = np.tile([0.0005, 0.002, 0.0003], (n, 1))
    rot = np.tile(np.eye(3), (n, 1, 1))
    return Recording(Path("x"), t, {BASE: base * scale, WRIST: wrist * scale}, {BASE: rot, WRIST: rot.copy()})


def _write(folder: Path, name: str, rec: Recording, kind: str) -> None:
    if kind == "csv":
        write_csv(folder / f"{name}.csv", rec)
    else:
        write_qualisys_tsv(folder / f"{name}.tsv", rec, header=True)


def _load(folder: Path, duration_s: float | None = None):
    """The folder's recordings as the units and duration checks see them (every repeat kept: the repeat check, which
    would leave a half-scale repeat out as far from the others, has its own tests in test_repeat_check.py)."""
    from simtune.data import load_task_data
    from simtune.robot.mico import WRIST_REACH_M

    return load_task_data(
        folder, "t", WRIST, duration_s=duration_s, reach_m=WRIST_REACH_M, base_body=BASE, keep_repeats=True
    )


# Factors a file's positions may be off by: near 1 (never flagged), centimetres/inches
# (caught against the other repeats) and metres/millimetres (caught against the arm's reach).
NEAR, MID, FAR = [0.5, 0.8, 1.0, 1.25, 2.0], [0.1, 1 / 3.5, 3.5], [1e-3, 1e-2, 10.0, 25.4, 1e3]


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(
    count=st.integers(1, 5),
    odd=st.integers(0, 4),
    factor=st.sampled_from(NEAR + MID + FAR),
    everyone=st.booleans(),
    kind=st.sampled_from(["csv", "tsv"]),
)
def test_units_of_a_folder(count: int, odd: int, factor: float, everyone: bool, kind: str) -> None:
    """Far-off units are an error naming the odd file; near-1 factors are never flagged."""
    odd %= count
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        for i in range(count):
            _write(folder, f"r{i}", _repeat(3.0, factor if everyone or i == odd else 1.0), kind)
        named = "r0" if everyone else f"r{odd}"
        # 3.5x too large is beyond the reach anyway; 10x or 3.5x too small only stands out among good repeats.
        caught = factor in FAR or (factor in MID and (factor > 1 or (not everyone and count > 1)))
        if caught:
            with pytest.raises(RecordingError) as info:
                _load(folder)
            msg = str(info.value)
            assert "units check" in msg and f"{named}.{kind}" in msg and "\n" not in msg
        else:
            with warnings.catch_warnings():
                warnings.simplefilter("error")
                assert len(_load(folder).sources) == count


@settings(max_examples=80, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(
    task_s=st.sampled_from([1.0, 2.5, 6.0]),
    shares=st.lists(st.floats(0.02, 1.6), min_size=1, max_size=5),
    runaway=st.one_of(st.none(), st.integers(0, 4)),
)
def test_durations_against_the_task(task_s: float, shares: list[float], runaway: int | None) -> None:
    """Cut-off repeats are left out by name, never cutting the reference; a runaway time is an error."""
    frames = [max(2, int(round(s * task_s * RATE)) + 1) for s in shares]
    durations = [(n - 1) / RATE for n in frames]
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        for i, d in enumerate(durations):
            rec = _repeat(d)
            if runaway is not None and i == runaway % len(durations):
                rec.time[-1] = 12.0 * task_s  # a damaged last frame far past the task
            write_csv(folder / f"r{i}.csv", rec)
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            try:
                td = _load(folder, duration_s=task_s)
            except RecordingError as exc:
                msg = str(exc)
                assert "\n" not in msg
                if runaway is not None:
                    assert f"/r{runaway % len(durations)}.csv line " in msg and ": time check: " in msg
                    return
                td = None
        assert runaway is None
        floor = 0.9 * max(task_s, float(np.median(durations)))
        short = [f"r{i}.csv" for i, d in enumerate(durations) if d < floor]
        left_out = [str(w.message) for w in caught if "duration check: left out" in str(w.message)]
        assert len(left_out) == len(short) and all(name in m for name, m in zip(short, left_out))
        if len(short) == len(durations):
            assert td is None and "no usable repeats" in msg
            return
        assert td is not None
        assert [p.name for p in td.sources] == [f"r{i}.csv" for i, d in enumerate(durations) if d >= floor]
        # The reference is as long as the shortest kept repeat: never under 90 % of the task.
        assert td.duration == pytest.approx(min(d for d in durations if d >= floor))
        assert td.duration >= 0.9 * task_s - 1e-9
        assert np.isfinite(td.wrist_repeats).all()
