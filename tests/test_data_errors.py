"""Malformed recordings: one-line RecordingError naming file and line, or a RecordingWarning."""

from __future__ import annotations

import gzip
import warnings
from pathlib import Path

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from simtune.data import Recording, load_recording, load_task_data, write_csv, write_qualisys_tsv
from simtune.errors import RecordingError, RecordingWarning, SimtuneError


def make_recording(n: int = 30, rate: float = 100.0) -> Recording:
    t = np.arange(n) / rate
    pos = {
        "RB2(Black)": np.c_[np.full(n, 0.0005), np.full(n, 0.002), np.full(n, 0.0006)],
        "RB1(Orange)": np.c_[0.1 + t, 0.05 * np.sin(t), np.full(n, 0.8)],
        "PCube": np.c_[np.full(n, 0.6), np.full(n, 0.007), np.full(n, 0.04)],
    }
    rot = {
        "RB2(Black)": np.tile(np.eye(3), (n, 1, 1)),
        "RB1(Orange)": Rotation.from_rotvec(np.c_[3.0 + t, 0.1 * t, -t]).as_matrix(),
        "PCube": Rotation.from_rotvec(np.c_[0 * t, 0 * t, 0.2 * t]).as_matrix(),
    }
    return Recording(source=Path("synthetic"), time=t, positions=pos, rotations=rot)


def tsv_lines(tmp_path: Path, n: int = 30) -> list[str]:
    """Lines (without CRLF) of a valid headerless 3-body TSV."""
    path = tmp_path / "valid.tsv"
    write_qualisys_tsv(path, make_recording(n))
    return path.read_bytes().decode().split("\r\n")[:-1]


def write_lines(path: Path, lines: list[str], end: str = "\r\n") -> Path:
    path.write_text(end.join(lines) + end)
    return path


def set_field(line: str, col: int, value: str) -> str:
    fields = line.split("\t")
    fields[col] = value
    return "\t".join(fields)


def error_of(path: Path, **kw) -> str:
    with pytest.raises(RecordingError) as info:
        load_recording(path, **kw)
    msg = str(info.value)
    assert "\n" not in msg
    assert path.name in msg
    return msg


def test_wrong_column_count(tmp_path: Path) -> None:
    lines = tsv_lines(tmp_path)
    lines[16] = "\t".join(lines[16].split("\t")[:40])
    msg = error_of(write_lines(tmp_path / "cols.tsv", lines))
    assert "line 17: expected 53 columns, found 40" in msg


def test_text_in_a_number(tmp_path: Path) -> None:
    lines = tsv_lines(tmp_path)
    lines[16] = set_field(lines[16], 4, "abc")
    msg = error_of(write_lines(tmp_path / "text.tsv", lines))
    assert "line 17, column 5: 'abc' is not a number" in msg


def test_infinite_value(tmp_path: Path) -> None:
    lines = tsv_lines(tmp_path)
    lines[3] = set_field(lines[3], 20, "inf")
    assert "line 4, column 21" in error_of(write_lines(tmp_path / "inf.tsv", lines))


@pytest.mark.parametrize("content", [b"", b"\r\n\r\n", b"   \n"])
def test_empty_file(tmp_path: Path, content: bytes) -> None:
    path = tmp_path / "empty.tsv"
    path.write_bytes(content)
    msg = error_of(path)
    assert "line 1" in msg and "empty" in msg


def test_empty_csv(tmp_path: Path) -> None:
    path = tmp_path / "empty.csv"
    path.write_text("# only a comment\n")
    assert "empty" in error_of(path)


def test_header_without_data(tmp_path: Path) -> None:
    src = tmp_path / "h.tsv"
    write_qualisys_tsv(src, make_recording(), header=True)
    lines = src.read_bytes().decode().split("\r\n")[:10]
    msg = error_of(write_lines(tmp_path / "headonly.tsv", lines))
    assert "line 11: no data lines after the header" in msg


@pytest.mark.parametrize("column", [1, 3])
@pytest.mark.parametrize("bad", ["nan", "", "inf"])
def test_time_not_finite(tmp_path: Path, column: int, bad: str) -> None:
    lines = tsv_lines(tmp_path)
    lines[7] = set_field(lines[7], 1, bad)
    msg = error_of(write_lines(tmp_path / "badtime.tsv", lines))
    assert "line 8" in msg


def test_time_going_backwards(tmp_path: Path) -> None:
    lines = tsv_lines(tmp_path)
    lines[9] = set_field(lines[9], 1, "0.05000")
    msg = error_of(write_lines(tmp_path / "back.tsv", lines))
    assert "line 10: time check: the time goes backwards" in msg


def test_duplicate_frames_are_dropped(tmp_path: Path) -> None:
    lines = tsv_lines(tmp_path)
    lines.insert(5, lines[4])
    lines.insert(5, lines[4])
    with pytest.warns(RecordingWarning, match=r"dup\.tsv: time check: dropped 2 duplicate.*lines 6, 7"):
        rec = load_recording(write_lines(tmp_path / "dup.tsv", lines))
    assert len(rec) == 30 and np.all(np.diff(rec.time) > 0)


def test_too_few_frames(tmp_path: Path) -> None:
    lines = tsv_lines(tmp_path)[:1]
    assert "at least 2" in error_of(write_lines(tmp_path / "one.tsv", lines))
    lines = tsv_lines(tmp_path)[:3]
    lines[1] = lines[0]
    lines[2] = lines[0]
    with pytest.warns(RecordingWarning):
        assert "line 1" in error_of(write_lines(tmp_path / "same.tsv", lines))


@pytest.mark.parametrize("cut", [25, 200, 400])
def test_truncated_last_line_is_dropped(tmp_path: Path, cut: int) -> None:
    lines = tsv_lines(tmp_path)
    path = tmp_path / "cut.tsv"
    data = ("\r\n".join(lines) + "\r\n").encode()
    last = data.rstrip(b"\r\n").rfind(b"\n") + 1
    path.write_bytes(data[: last + cut])  # an export interrupted mid-line
    with pytest.warns(RecordingWarning, match=r"cut\.tsv line 30: last line is truncated"):
        rec = load_recording(path)
    assert len(rec) == 29


def test_truncated_line_in_the_middle_is_an_error(tmp_path: Path) -> None:
    lines = tsv_lines(tmp_path)
    lines[10] = lines[10][:100]
    assert "line 11: expected 53 columns" in error_of(write_lines(tmp_path / "mid.tsv", lines))


def test_metres_in_tsv(tmp_path: Path) -> None:
    lines = tsv_lines(tmp_path)
    # Wrist x written as 1000x too large (metres exported as if millimetres were km).
    lines[12] = set_field(lines[12], 19, "12000000.0")
    msg = error_of(write_lines(tmp_path / "km.tsv", lines))
    assert "line 13" in msg and "not in millimetres" in msg and "RB1(Orange)" in msg


def test_millimetres_in_csv(tmp_path: Path) -> None:
    rec = make_recording()
    rec.positions["RB1(Orange)"] = rec.positions["RB1(Orange)"] * 1000.0
    write_csv(tmp_path / "mm.csv", rec)
    msg = error_of(tmp_path / "mm.csv")
    assert "line 3" in msg  # first data line after comment and header
    assert "looks like millimetres; this format expects metres" in msg
    assert "values up to 800" in msg


def test_lost_marker_as_zeros_and_empty(tmp_path: Path) -> None:
    lines = tsv_lines(tmp_path)
    for col in range(36, 52):  # PCube all zero, as Qualisys writes a lost body
        lines[3] = set_field(lines[3], col, "0.00000")
    for col in range(19, 35):  # wrist empty
        lines[4] = set_field(lines[4], col, "")
    rec = load_recording(write_lines(tmp_path / "lost.tsv", lines))
    assert np.isnan(rec.positions["PCube"][3]).all() and np.isnan(rec.rotations["PCube"][3]).all()
    assert np.isnan(rec.positions["RB1(Orange)"][4]).all()
    assert np.isnan(rec.rotations["RB1(Orange)"][4]).all()
    assert np.isfinite(rec.positions["PCube"][4]).all()


def test_garbage_rotation_becomes_nan_with_warning(tmp_path: Path) -> None:
    lines = tsv_lines(tmp_path)
    lines[6] = set_field(lines[6], 27, "7.00000")
    with pytest.warns(RecordingWarning, match=r"rot\.tsv: rotation of 'RB1\(Orange\)'.*frames 7"):
        rec = load_recording(write_lines(tmp_path / "rot.tsv", lines))
    assert np.isnan(rec.rotations["RB1(Orange)"][6]).all()
    assert np.isfinite(rec.positions["RB1(Orange)"][6]).all()


def test_layout_that_fits_no_body_count(tmp_path: Path) -> None:
    lines = ["\t".join(line.split("\t")[:30]) for line in tsv_lines(tmp_path)]
    msg = error_of(write_lines(tmp_path / "layout.tsv", lines))
    assert "line 1: 30 columns do not fit" in msg


def test_wrong_number_of_body_names(tmp_path: Path) -> None:
    lines = tsv_lines(tmp_path)
    msg = error_of(write_lines(tmp_path / "names.tsv", lines), body_names=["a", "b"])
    assert "line 1" in msg and "3 bodies" in msg


def test_two_bodies_with_names(tmp_path: Path) -> None:
    # Frame, time and two bodies; the last body's empty column is optional.
    lines = ["\t".join(line.split("\t")[: 2 + 17 + 16]) for line in tsv_lines(tmp_path)]
    rec = load_recording(write_lines(tmp_path / "two.tsv", lines), body_names=["base", "wrist"])
    assert rec.bodies == ["base", "wrist"]


def test_csv_bad_header(tmp_path: Path) -> None:
    path = tmp_path / "hdr.csv"
    path.write_text("time,w.x,w.y,w.z,w.qx,w.qy,w.qw,w.qz\n0,1,2,3,0,0,0,1\n")
    assert "line 1, column 7: expected 'w.qz', found 'w.qw'" in error_of(path)
    path.write_text("t,w.x\n")
    assert "line 1" in error_of(path)


def test_csv_wrong_column_count(tmp_path: Path) -> None:
    path = tmp_path / "cols.csv"
    path.write_text("#c\ntime,w.x,w.y,w.z,w.qx,w.qy,w.qz,w.qw\n0,1,2,3,0,0,0,1\n1,1,2,3,0,0\n2,1,2,3,0,0,0,1\n")
    assert "line 4: expected 8 columns, found 6" in error_of(path)


def test_csv_text_in_number(tmp_path: Path) -> None:
    path = tmp_path / "txt.csv"
    path.write_text("time,w.x,w.y,w.z,w.qx,w.qy,w.qz,w.qw\n0,1,2,3,0,0,0,1\n1,1,2,x3,0,0,0,1\n")
    assert "line 3, column 4: 'x3' is not a number" in error_of(path)


def test_corrupt_gzip(tmp_path: Path) -> None:
    path = tmp_path / "bad.tsv.gz"
    # Content decides, not the name: plain text named .gz is read as text.
    path.write_bytes(b"this is not gzip")
    assert "line 1" in error_of(path)
    full = gzip.compress(b"1\t0.0\t" * 1000)
    path.write_bytes(full[: len(full) // 2])
    assert "encoding check: cannot read its gzip-compressed content" in error_of(path)


def test_missing_file_and_unknown_suffix(tmp_path: Path) -> None:
    assert "no such file" in error_of(tmp_path / "nothere.tsv")
    (tmp_path / "data.txt").write_text("1\t2\n")
    assert "unknown recording format" in error_of(tmp_path / "data.txt")


def test_capitalised_text_on_line_one_is_not_a_header(tmp_path: Path) -> None:
    lines = tsv_lines(tmp_path)
    lines[0] = set_field(lines[0], 0, "ABC")
    msg = error_of(write_lines(tmp_path / "cap.tsv", lines))
    assert "line 1, column 1: 'ABC' is not a number" in msg


def test_header_frame_count_mismatch_warns(tmp_path: Path) -> None:
    src = tmp_path / "h.tsv"
    write_qualisys_tsv(src, make_recording(), header=True)
    lines = src.read_bytes().decode().split("\r\n")[:-1][:-5]
    with pytest.warns(RecordingWarning, match=r"short\.tsv line 1: header says 30 frames"):
        rec = load_recording(write_lines(tmp_path / "short.tsv", lines))
    assert len(rec) == 25


# --- folders -----------------------------------------------------------------------


def test_empty_folder(tmp_path: Path) -> None:
    (tmp_path / "notes.txt").write_text("nothing here")
    with pytest.raises(RecordingError, match="no recordings") as info:
        load_task_data(tmp_path, "cube", "RB1(Orange)")
    assert str(tmp_path) in str(info.value)
    with pytest.raises(RecordingError, match="no recordings"):
        load_task_data(tmp_path / "missing", "cube", "RB1(Orange)")


def test_unknown_body(tmp_path: Path) -> None:
    write_qualisys_tsv(tmp_path / "r1.tsv", make_recording())
    with pytest.raises(RecordingError) as info:
        load_task_data(tmp_path, "cube", "RB1(Orange)", "Ball")
    msg = str(info.value)
    assert "r1.tsv: no body 'Ball' (bodies: RB2(Black), RB1(Orange), PCube)" in msg


def test_errors_are_simtune_errors() -> None:
    assert issubclass(RecordingError, SimtuneError)


def test_messages_stay_on_one_line_for_odd_cells(tmp_path: Path) -> None:
    lines = tsv_lines(tmp_path)
    lines[2] = set_field(lines[2], 6, "x" * 500 + "\x0b")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        msg = error_of(write_lines(tmp_path / "long.tsv", lines))
    assert len(msg) < 200
