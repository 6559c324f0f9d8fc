"""Recording sanity (issue 23): units, duration, time and encoding checks, on folders built from real files.

Each folder is made by the test from the qrg2019 recordings (skipped without
them) or from the shipped reference `cube`, damaged the way a careless or
unlucky user would: positions in metres, a cut-off repeat, a huge time, a file
saved as UTF-16 or gzipped under a `.tsv` name, a macOS `._` companion.
"""

from __future__ import annotations

import bz2
import gzip
import json
import lzma
import re
import shutil
import subprocess
import sys
import warnings
import zipfile
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest

from simtune.data import load_recording, load_task_data, task_files, write_csv
from simtune.errors import RecordingError, RecordingWarning
from simtune.objective import load_references
from simtune.reference import REFERENCE_DIR
from simtune.robot.mico import WRIST_REACH_M, forward_kinematics
from simtune.tasks import get_task

SINGLE = get_task("single")
CUBE = get_task("cube")
WRIST, BASE = "RB1(Orange)", "RB2(Black)"

Fields = list[list[bytes]]


def rewrite(src: Path, dst: Path, change: Callable[[Fields], Fields]) -> Path:
    """Copy a Qualisys TSV (plain or gzipped), letting ``change`` edit its data lines split into fields."""
    raw = src.read_bytes()
    text = gzip.decompress(raw) if raw[:2] == b"\x1f\x8b" else raw
    lines = text.replace(b"\r\n", b"\n").split(b"\n")
    if lines[-1] == b"":
        lines.pop()
    head = [ln for ln in lines if not ln[:1].isdigit()]
    data = change([ln.split(b"\t") for ln in lines[len(head) :]])
    out = b"\r\n".join(head + [b"\t".join(f) for f in data]) + b"\r\n"
    dst.write_bytes(gzip.compress(out) if dst.name.endswith(".gz") else out)
    return dst


def scaled(factor: float) -> Callable[[Fields], Fields]:
    """Multiply every body's X, Y, Z by ``factor`` (a file in other units)."""

    def change(rows: Fields) -> Fields:
        for row in rows:
            for b in range((len(row) - 1) // 17):
                for c in range(2 + 17 * b, 5 + 17 * b):
                    if row[c].strip():
                        row[c] = f"{float(row[c]) * factor:.8g}".encode()
        return rows

    return change


def first(frames: int) -> Callable[[Fields], Fields]:
    """Keep the first ``frames`` frames (a take stopped early)."""
    return lambda rows: rows[:frames]


def last_time(value: str) -> Callable[[Fields], Fields]:
    """Replace the time of the last frame."""

    def change(rows: Fields) -> Fields:
        rows[-1][1] = value.encode()
        return rows

    return change


def lost_at_start(frames: int, columns: range) -> Callable[[Fields], Fields]:
    """Empty ``columns`` in the first ``frames`` frames (markers not yet tracked)."""

    def change(rows: Fields) -> Fields:
        for row in rows[:frames]:
            for c in columns:
                row[c] = b""
        return rows

    return change


def real_folder(mocap_root: Path, dst: Path, task: str = "single", count: int = 4) -> list[Path]:
    """``dst/<task>/`` with the first ``count`` real repeats of ``task``; their new paths."""
    folder = dst / task
    folder.mkdir(parents=True)
    return [Path(shutil.copy(p, folder)) for p in task_files(mocap_root / task)[:count]]


def shipped_cube(dst: Path) -> list[Path]:
    """``dst/cube/`` with the shipped reference repeats of `cube`; their new paths."""
    shutil.copytree(REFERENCE_DIR / "cube", dst / "cube")
    return task_files(dst / "cube")


def load(root: Path, task=SINGLE):
    return load_references(root, [task])[task.name]


def error_of(root: Path, task=SINGLE) -> str:
    with pytest.raises(RecordingError) as info:
        load(root, task)
    msg = str(info.value)
    assert "\n" not in msg
    return msg


# --- units ----------------------------------------------------------------------------


def test_reach_bounds_every_pose() -> None:
    """WRIST_REACH_M, which the units check trusts, is no less than any pose's wrist distance."""
    rng = np.random.default_rng(0)
    poses = rng.uniform(-np.pi, np.pi, (2000, 6))
    farthest = max(float(np.linalg.norm(forward_kinematics(q)[0])) for q in poses)
    assert farthest <= WRIST_REACH_M < 1.05 * farthest
    assert 0.88 < WRIST_REACH_M < 0.9


def test_folder_in_metres_is_an_error(mocap_root: Path, tmp_path: Path) -> None:
    for path in real_folder(mocap_root, tmp_path, count=3):
        rewrite(path, path, scaled(1e-3))
    msg = error_of(tmp_path)
    assert msg.startswith("single/Single0001_6D.tsv: units check: the wrist 'RB1(Orange)' stays ")
    assert "metres in a millimetre file?" in msg


def test_one_repeat_in_metres_among_good_ones_is_named(mocap_root: Path, tmp_path: Path) -> None:
    paths = real_folder(mocap_root, tmp_path)
    rewrite(paths[2], paths[2], scaled(1e-3))
    msg = error_of(tmp_path)
    assert msg.startswith(f"single/{paths[2].name}: units check")


def test_one_repeat_in_centimetres_among_good_ones_is_named(mocap_root: Path, tmp_path: Path) -> None:
    """10x too small still fits the arm's workspace; the other repeats tell it apart."""
    paths = real_folder(mocap_root, tmp_path)
    rewrite(paths[1], paths[1], scaled(0.1))
    msg = error_of(tmp_path)
    assert msg.startswith(f"single/{paths[1].name}: units check")
    assert re.search(r"stays 0\.0\d+ m from the base \(median\), (9\.\d+|1\d\.\d) x smaller than in the other", msg)
    assert msg.endswith("this repeat is in other units than the rest")


def test_two_repeats_in_different_units_name_both(tmp_path: Path) -> None:
    """With no majority to go by, the message names the two files that disagree."""
    paths = shipped_cube(tmp_path)
    for extra in paths[2:]:
        extra.unlink()
    rewrite(paths[1], paths[1], scaled(0.1))
    msg = error_of(tmp_path, CUBE)
    assert msg.startswith(f"cube/{paths[1].name}: units check") and f"cube/{paths[0].name}" in msg
    assert "the repeats are in different units" in msg


def test_csv_in_centimetres_is_too_large(tmp_path: Path) -> None:
    """A metre-format file 10x too large stays under the readers' 10 m bound; the arm's reach catches it."""
    rec = load_recording(REFERENCE_DIR / "cube" / "cube0001.tsv.gz")
    rec.positions = {name: xyz * 10.0 for name, xyz in rec.positions.items()}
    (tmp_path / "cube").mkdir()
    write_csv(tmp_path / "cube" / "cm.csv", rec)
    msg = error_of(tmp_path, CUBE)
    assert msg.startswith("cube/cm.csv: units check")
    assert "millimetres in a metre file?" in msg


def test_shipped_reference_in_metres_is_an_error(tmp_path: Path) -> None:
    paths = shipped_cube(tmp_path)
    rewrite(paths[-1], paths[-1], scaled(1e-3))
    assert error_of(tmp_path, CUBE).startswith(f"cube/{paths[-1].name}: units check")


def test_generic_reach_without_a_task(mocap_root: Path, tmp_path: Path) -> None:
    """load_task_data alone (no reach given) still refuses metres in a millimetre format."""
    paths = real_folder(mocap_root, tmp_path, count=2)
    rewrite(paths[0], paths[0], scaled(1e-3))
    with pytest.raises(RecordingError, match=r"Single0001_6D\.tsv: units check"):
        load_task_data(tmp_path / "single", "single", WRIST)


# --- duration -------------------------------------------------------------------------


def same_reference(a, b) -> None:
    assert a.times.shape == b.times.shape
    np.testing.assert_array_equal(a.wrist_repeats, b.wrist_repeats)
    np.testing.assert_array_equal(a.object_final, b.object_final)


@pytest.mark.parametrize(("frames", "lasts"), [(3, "0.02 s (3 frames)"), (201, "2.00 s (201 frames)")])
def test_short_repeat_is_left_out_with_a_warning(mocap_root: Path, tmp_path: Path, frames: int, lasts: str) -> None:
    paths = real_folder(mocap_root, tmp_path / "good")
    good = load(tmp_path / "good")
    shutil.copytree(tmp_path / "good", tmp_path / "bad")
    rewrite(paths[0], tmp_path / "bad" / "single" / "Single0000_cut.tsv", first(frames))
    with pytest.warns(RecordingWarning) as caught:
        bad = load(tmp_path / "bad")
    durations = [load_recording(p).time[-1] for p in task_files(tmp_path / "bad" / "single")]
    assert 0.9 * np.median(durations) > 0.9 * SINGLE.duration  # the median sets the floor here
    assert [str(w.message) for w in caught] == [
        f"single/Single0000_cut.tsv: duration check: left out: lasts {lasts}, "
        f"less than 90 % of the median repeat's {np.median(durations):.2f} s"
    ]
    assert [p.name for p in bad.sources] == [p.name for p in good.sources]
    same_reference(bad, good)


def test_threshold_is_90_percent_of_the_longer_of_task_and_median(mocap_root: Path, tmp_path: Path) -> None:
    paths = real_folder(mocap_root, tmp_path)
    durations = [float(load_recording(p).time[-1]) for p in paths]  # 100 Hz frames from t = 0
    # The two repeats added below are shorter than all four, so the median of the six is this:
    median_s = float(np.median([*durations, 0.0, 0.0]))
    floor = 0.9 * max(median_s, SINGLE.duration)
    keep = int(np.ceil(floor * 100)) + 1  # frames of a repeat just long enough
    rewrite(paths[0], tmp_path / "single" / "a_long_enough.tsv", first(keep))
    rewrite(paths[0], tmp_path / "single" / "b_too_short.tsv", first(keep - 2))
    with pytest.warns(RecordingWarning, match=r"b_too_short\.tsv: duration check: left out") as caught:
        td = load(tmp_path)
    assert len(caught) == 1
    assert sorted(p.name for p in td.sources) == sorted([*(p.name for p in paths), "a_long_enough.tsv"])
    # Kept, the just-long-enough repeat sets the reference: cut by at most 10 %.
    assert td.duration == pytest.approx(np.floor((keep - 1) / 100 * 20) / 20)
    assert td.duration >= 0.9 * median_s - 0.05


def test_all_repeats_short_is_an_error(mocap_root: Path, tmp_path: Path) -> None:
    for path in real_folder(mocap_root, tmp_path, count=3):
        rewrite(path, path, first(201))
    with pytest.warns(RecordingWarning, match="duration check") as caught:
        msg = error_of(tmp_path)
    assert len(caught) == 3
    assert msg.startswith("no usable repeats in ")
    assert "all 3 left out (3 shorter than 90 % of the task's 6 s; see the warnings)" in msg


def test_task_duration_alone_catches_a_folder_of_cut_off_takes(tmp_path: Path) -> None:
    paths = shipped_cube(tmp_path)
    for path in paths:
        rewrite(path, path, first(1001))  # 10 s of the task's 20
    with pytest.warns(RecordingWarning) as caught:
        assert "no usable repeats" in error_of(tmp_path, CUBE)
    cut = [str(w.message) for w in caught if "duration check" in str(w.message)]
    assert cut == [
        f"cube/{p.name}: duration check: left out: lasts 10.00 s (1001 frames), less than 90 % of the task's 20 s"
        for p in paths
    ]
    # The header's frame count, left as it was, is reported too.
    assert sum("header says 2001 frames, the file holds 1001" in str(w.message) for w in caught) == len(paths)


# --- time -----------------------------------------------------------------------------


@pytest.mark.parametrize("value", ["1e30", "100000"])
def test_huge_last_time_names_file_and_line(mocap_root: Path, tmp_path: Path, value: str) -> None:
    paths = real_folder(mocap_root, tmp_path)
    rewrite(paths[1], paths[1], last_time(value))
    frames = paths[1].read_bytes().count(b"\n")  # no header: the last frame is the last line
    msg = error_of(tmp_path)
    assert msg.startswith(
        f"single/{paths[1].name} line {frames}: time check: the time {float(value):.6g} s is more than "
        "10 x the task's 6 s after the first frame's 0 s"
    )


def test_time_in_milliseconds_is_an_error(tmp_path: Path) -> None:
    paths = shipped_cube(tmp_path)

    def millis(rows: Fields) -> Fields:
        for row in rows:
            row[1] = f"{float(row[1]) * 1000:.3f}".encode()
        return rows

    rewrite(paths[0], paths[0], millis)
    msg = error_of(tmp_path, CUBE)
    assert msg.startswith(f"cube/{paths[0].name} line ") and "time check" in msg


# --- encodings ------------------------------------------------------------------------


SHIPPED = REFERENCE_DIR / "cube" / "cube0001.tsv.gz"


def encoded(kind: str, text: bytes) -> bytes:
    """``text`` (UTF-8) saved the way another program might have saved it."""
    return {
        "utf-8-bom": lambda: b"\xef\xbb\xbf" + text,
        "utf-16": lambda: text.decode().encode("utf-16"),  # with a byte-order mark
        "utf-16-le": lambda: text.decode().encode("utf-16-le"),
        "utf-16-be": lambda: text.decode().encode("utf-16-be"),
        "utf-32": lambda: text.decode().encode("utf-32"),
        "gzip": lambda: gzip.compress(text),
        "gzip-utf-16": lambda: gzip.compress(text.decode().encode("utf-16")),
        "bzip2": lambda: bz2.compress(text),
        "xz": lambda: lzma.compress(text),
    }[kind]()


def same_recording(a, b) -> None:
    np.testing.assert_array_equal(a.time, b.time)
    assert a.bodies == b.bodies
    for name in a.bodies:
        np.testing.assert_array_equal(a.positions[name], b.positions[name])
        np.testing.assert_array_equal(a.rotations[name], b.rotations[name])


@pytest.mark.parametrize(
    "kind", ["utf-8-bom", "utf-16", "utf-16-le", "utf-16-be", "utf-32", "gzip", "gzip-utf-16", "bzip2", "xz"]
)
@pytest.mark.parametrize("name", ["x.tsv", "x.tsv.gz"])
def test_encodings_are_read_by_content(tmp_path: Path, kind: str, name: str) -> None:
    text = gzip.decompress(SHIPPED.read_bytes())
    path = tmp_path / name
    path.write_bytes(encoded(kind, text))
    same_recording(load_recording(path), load_recording(SHIPPED))


def test_csv_with_a_bom_from_a_spreadsheet(tmp_path: Path) -> None:
    write_csv(tmp_path / "plain.csv", load_recording(SHIPPED))
    (tmp_path / "excel.csv").write_bytes(encoded("utf-8-bom", (tmp_path / "plain.csv").read_bytes()))
    same_recording(load_recording(tmp_path / "excel.csv"), load_recording(tmp_path / "plain.csv"))


def test_content_that_is_no_recording_says_what_it_is(tmp_path: Path) -> None:
    with zipfile.ZipFile(tmp_path / "book.tsv", "w") as zf:
        zf.writestr("sheet.xml", "<x/>")
    with pytest.raises(RecordingError, match=r"book\.tsv: encoding check: the file is a zip archive"):
        load_recording(tmp_path / "book.tsv")
    (tmp_path / "._x.tsv").write_bytes(b"\x00\x05\x16\x07\x00\x02\x00\x00Mac OS X        " + b"\x00" * 40)
    with pytest.raises(RecordingError, match=r"\._x\.tsv: encoding check: the file is a macOS AppleDouble"):
        load_recording(tmp_path / "._x.tsv")
    (tmp_path / "odd.tsv").write_bytes(b"\xff\xfe" + b"1\x00\t\x00\x00\xd8\x31")  # a lone surrogate
    with pytest.raises(RecordingError, match=r"odd\.tsv: encoding check: looks like UTF-16-LE text"):
        load_recording(tmp_path / "odd.tsv")
    whole = gzip.compress(np.random.default_rng(0).bytes(2000))
    (tmp_path / "cut.tsv").write_bytes(whole[: len(whole) // 2])
    with pytest.raises(RecordingError, match=r"cut\.tsv: encoding check: cannot read its gzip-compressed content"):
        load_recording(tmp_path / "cut.tsv")


def test_appledouble_companions_are_ignored(tmp_path: Path) -> None:
    paths = shipped_cube(tmp_path)
    for path in paths:
        (path.parent / f"._{path.name}").write_bytes(b"\x00\x05\x16\x07\x00\x02\x00\x00" + b"\x00" * 80)
    assert task_files(tmp_path / "cube") == paths
    assert [p.name for p in load(tmp_path, CUBE).sources] == [p.name for p in paths]


# --- NaN in the first sample ----------------------------------------------------------


def test_markers_lost_in_the_first_frames_leave_no_nan(mocap_root: Path, tmp_path: Path) -> None:
    paths = real_folder(mocap_root, tmp_path, "cube", count=2)
    truth = load_recording(paths[0])
    # Wrist (columns 19-35) and cube (36-52) untracked in the first 5 frames (0.05 s).
    rewrite(paths[0], paths[0], lost_at_start(5, range(19, 53)))
    raw = load_recording(paths[0])
    assert np.isnan(raw.positions[WRIST][0]).all()  # the raw recording says what was seen
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        td = load(tmp_path, CUBE)
    assert np.isfinite(td.wrist_repeats).all() and np.isfinite(td.wrist_mean).all()
    assert td.object_start is not None and td.object_final is not None
    assert np.isfinite(td.object_start).all() and np.isfinite(td.object_final).all()
    np.testing.assert_array_equal(td.object_start[0], truth.positions["PCube"][5])
    np.testing.assert_allclose(td.wrist_repeats[0, 0], truth.positions[WRIST][5])


def test_markers_lost_too_long_at_the_start_leave_the_repeat_out(mocap_root: Path, tmp_path: Path) -> None:
    paths = real_folder(mocap_root, tmp_path, "cube", count=2)
    rewrite(paths[0], paths[0], lost_at_start(40, range(36, 53)))  # the cube, 0.40 s
    with pytest.warns(RecordingWarning, match=rf"{paths[0].name}: gap check: left out: 'PCube' lost for 0\.40 s"):
        td = load(tmp_path, CUBE)
    assert [p.name for p in td.sources] == [paths[1].name]


# --- the command line -----------------------------------------------------------------


def evaluate(root: Path, *extra: str) -> subprocess.CompletedProcess:
    cmd = [sys.executable, "-m", "simtune.cli", "evaluate", "--task", "single", "--data", str(root), *extra]
    return subprocess.run(cmd, capture_output=True, text=True, timeout=120)


@pytest.mark.parametrize("damage", ["metres", "huge time"])
def test_cli_refuses_with_one_line_naming_the_file(mocap_root: Path, tmp_path: Path, damage: str) -> None:
    paths = real_folder(mocap_root, tmp_path)
    rewrite(paths[2], paths[2], scaled(1e-3) if damage == "metres" else last_time("1e30"))
    result = evaluate(tmp_path)
    assert result.returncode == 2, result.stderr
    assert "Traceback" not in result.stderr and result.stdout == ""
    [line] = result.stderr.strip().splitlines()
    check = "units check" if damage == "metres" else "time check"
    assert line.startswith(f"error: single/{paths[2].name}") and check in line


def test_cli_warns_and_scores_the_good_repeats(mocap_root: Path, tmp_path: Path) -> None:
    """A cut-off take, a macOS companion, and files saved gzipped, as UTF-16 or with a BOM: same fitness."""
    good = tmp_path / "good"
    paths = real_folder(mocap_root, good)
    messy = tmp_path / "messy" / "single"
    messy.mkdir(parents=True)
    kinds = ["gzip", "utf-16", "utf-8-bom", "utf-16-be"]
    for path, kind in zip(paths, kinds):
        (messy / path.name).write_bytes(encoded(kind, path.read_bytes()))
        (messy / f"._{path.name}").write_bytes(b"\x00\x05\x16\x07" + b"\x00" * 60)
    rewrite(paths[0], messy / "Single0000_cut.tsv", first(3))
    expected = evaluate(good, "--json")
    result = evaluate(messy.parent, "--json")
    assert expected.returncode == 0 and result.returncode == 0, result.stderr
    assert json.loads(result.stdout)["fitness"] == json.loads(expected.stdout)["fitness"]
    [line] = result.stderr.strip().splitlines()
    assert line.startswith("warning: single/Single0000_cut.tsv: duration check: left out: lasts 0.02 s")
