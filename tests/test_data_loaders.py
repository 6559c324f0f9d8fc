"""Loading the real qrg2019 recordings, the header example, and write/read round trips."""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from simtune.data import (
    QRG2019_BODIES,
    Recording,
    load_recording,
    load_task_data,
    write_csv,
    write_qualisys_tsv,
)

DATA = Path(__file__).resolve().parents[1].parent / "shared/datasets/qrg2019"
MOCAP = DATA / "mocap"
WRIST, CUBE = "RB1(Orange)", "PCube"


def real_files(task: str) -> list[Path]:
    if not DATA.exists():
        pytest.skip(f"real data not found at {DATA}")
    files = sorted((MOCAP / task).glob("*.tsv"))
    assert files, f"no files in {MOCAP / task}"
    return files


def make_recording(n: int = 30, rate: float = 100.0, lost: int | None = 4) -> Recording:
    """Three smoothly moving bodies; body 'b' is lost at frame ``lost``."""
    t = np.arange(n) / rate
    pos = {
        "a": np.c_[0.1 + t, 0.05 * np.sin(t), np.full(n, 0.8)],
        "b": np.c_[0.5 - 0.2 * t, 0.02 + 0.1 * t, 0.3 + 0.01 * t],
        "c": np.c_[np.full(n, 0.6), np.full(n, 0.007), np.full(n, 0.04)],
    }
    rot = {
        "a": Rotation.from_euler("XYZ", np.c_[170 + 5 * t, 3 * t, -40 * t], degrees=True).as_matrix(),
        "b": Rotation.from_rotvec(np.c_[0.3 * t, -0.2 * t, 1.0 + t]).as_matrix(),
        "c": np.tile(np.eye(3), (n, 1, 1)),
    }
    if lost is not None:
        pos["b"][lost] = np.nan
        rot["b"][lost] = np.nan
    return Recording(source=Path("synthetic"), time=t, positions=pos, rotations=rot)


def assert_same(a: Recording, b: Recording, pos_tol: float = 1e-5, rot_tol: float = 1e-4) -> None:
    assert a.bodies == b.bodies
    np.testing.assert_allclose(a.time, b.time, atol=1e-5)
    for name in a.bodies:
        np.testing.assert_array_equal(np.isnan(a.positions[name]), np.isnan(b.positions[name]))
        np.testing.assert_allclose(a.positions[name], b.positions[name], atol=pos_tol)
        np.testing.assert_allclose(a.rotations[name], b.rotations[name], atol=rot_tol)


# --- real data -----------------------------------------------------------------------


@pytest.mark.parametrize("task", ["cube", "single"])
def test_every_real_file_loads_cleanly(task: str) -> None:
    for path in real_files(task):
        with warnings.catch_warnings():
            warnings.simplefilter("error")  # the real files need no repair
            rec = load_recording(path)
        assert rec.bodies == QRG2019_BODIES
        n = len(rec)
        assert n > 700
        assert np.all(np.diff(rec.time) > 0) and abs(rec.time[0]) < 1e-9
        for name in rec.bodies:
            assert rec.positions[name].shape == (n, 3)
            assert rec.rotations[name].shape == (n, 3, 3)
        # The base marker sits at the origin (within a few cm), the cube on the floor.
        assert np.nanmax(np.abs(rec.positions["RB2(Black)"])) < 0.05
        assert np.nanmax(np.abs(rec.positions[CUBE][:, 2] - 0.04)) < 0.02


def test_cube_repeats_start_at_the_same_wrist_position() -> None:
    for path in real_files("cube"):
        first = load_recording(path).positions[WRIST][0]
        assert np.linalg.norm(first - np.array([0.0, 0.06, 0.87])) < 0.03, path.name


def test_every_real_file_loads() -> None:
    # (how fast they load is benchmarks/speed.py's business, not a test's: this host is shared and noisy)
    files = real_files("cube") + real_files("single")
    assert len(files) == 46
    for path in files:
        rec = load_recording(path)
        assert len(rec) > 100 and np.all(np.diff(rec.time) > 0), path.name


def test_real_rotation_convention() -> None:
    """Rot[] is column-major and Roll/Pitch/Yaw are intrinsic x-y-z: R = Rx Ry Rz."""
    path = real_files("cube")[0]
    raw = np.genfromtxt(path, delimiter="\t")[:, 2:]  # independent reader; drop frame, time
    rec = load_recording(path)
    for b, name in enumerate(QRG2019_BODIES):
        rpy = raw[:, 17 * b + 3 : 17 * b + 6]
        mine = Rotation.from_matrix(rec.rotations[name]).as_euler("XYZ", degrees=True)
        diff = (mine - rpy + 180.0) % 360.0 - 180.0
        assert np.abs(diff).max() < 0.05, name
        np.testing.assert_allclose(rec.positions[name], raw[:, 17 * b : 17 * b + 3] / 1000.0)


def test_task_data_cube() -> None:
    real_files("cube")
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        td = load_task_data(MOCAP / "cube", "cube", WRIST, CUBE)
    for w in caught:
        print("warning:", w.message)
    assert len(td.sources) + len(caught) >= 23
    assert len(td.sources) >= 20
    assert td.wrist_repeats.shape == (len(td.sources), td.times.size, 3)
    np.testing.assert_allclose(np.diff(td.times), 0.05)
    assert td.times[0] == 0.0 and 19.9 <= td.duration <= 20.0
    assert td.object_final is not None and td.object_start is not None
    assert np.all((td.object_final[:, 0] >= 0.58) & (td.object_final[:, 0] <= 0.61))
    # The cube starts 10 cm short of where it ends: the push moves it along +x.
    assert np.all(td.object_final[:, 0] - td.object_start[:, 0] > 0.05)
    assert td.object_final_mean is not None and td.object_final_mean.shape == (3,)
    assert td.repeat_spread < 0.03


def test_task_data_single() -> None:
    real_files("single")
    td = load_task_data(MOCAP / "single", "single", WRIST, CUBE)
    assert len(td.sources) == 23
    np.testing.assert_allclose(np.diff(td.times), 0.05)
    assert np.linalg.norm(td.wrist_mean[-1] - np.array([0.539, 0.070, 0.227])) < 0.02
    assert td.repeat_spread < 0.03
    # In `single` the cube stands still at x = 0.6 m.
    assert td.object_final is not None
    np.testing.assert_allclose(td.object_final[:, 0], 0.6, atol=0.005)


def test_header_example_gives_body_names_from_header() -> None:
    if not DATA.exists():
        pytest.skip(f"real data not found at {DATA}")
    path = MOCAP / "FORMAT_EXAMPLE_with_headers.tsv"
    line = next(x for x in path.read_text().splitlines() if x.startswith("BODY_NAMES"))
    names = [x for x in line.split("\t")[1:] if x]
    # body_names passed in must lose against the header.
    rec = load_recording(path, body_names=["x", "y", "z"])
    assert rec.bodies == names == QRG2019_BODIES
    assert len(rec) == 2280
    np.testing.assert_allclose(np.diff(rec.time), 0.01)  # from FREQUENCY: no time column
    np.testing.assert_allclose(rec.positions[CUBE][0], [0.50108185, 0.00615862, 0.0412039])


def test_real_file_round_trips(tmp_path: Path) -> None:
    rec = load_recording(real_files("single")[0])
    write_qualisys_tsv(tmp_path / "copy.tsv.gz", rec, header=True)
    assert_same(rec, load_recording(tmp_path / "copy.tsv.gz"), rot_tol=2e-5)
    write_csv(tmp_path / "copy.csv", rec)
    # CSV stores normalised quaternions; Qualisys matrices are rounded to 5 decimals.
    assert_same(rec, load_recording(tmp_path / "copy.csv"), rot_tol=1e-4)


# --- round trips -----------------------------------------------------------------------


@pytest.mark.parametrize("name", ["r.tsv", "r.tsv.gz", "r.TSV"])
@pytest.mark.parametrize("header", [False, True])
def test_tsv_round_trip(tmp_path: Path, name: str, header: bool) -> None:
    rec = make_recording()
    write_qualisys_tsv(tmp_path / name, rec, header=header)
    back = load_recording(tmp_path / name, body_names=None if header else ["a", "b", "c"])
    assert_same(rec, back)
    assert np.isnan(back.rotations["b"][4]).all()


def test_tsv_without_header_uses_default_body_names(tmp_path: Path) -> None:
    rec = make_recording()
    write_qualisys_tsv(tmp_path / "r.tsv", rec)
    assert load_recording(tmp_path / "r.tsv").bodies == QRG2019_BODIES
    text = (tmp_path / "r.tsv").read_bytes()
    assert text.count(b"\r\n") == len(rec)  # CRLF, like Qualisys
    assert text.split(b"\r\n")[0].count(b"\t") + 1 == 2 + 17 * 3


def test_tsv_writer_angles_follow_qualisys_convention(tmp_path: Path) -> None:
    rec = make_recording()
    write_qualisys_tsv(tmp_path / "r.tsv", rec)
    raw = np.genfromtxt(tmp_path / "r.tsv", delimiter="\t")
    expected = Rotation.from_matrix(rec.rotations["a"]).as_euler("XYZ", degrees=True)
    np.testing.assert_allclose(raw[:, 5:8], expected, atol=1e-5)
    stored = raw[:, 9:18].reshape(-1, 3, 3)  # row-major reading of Rot[0..8] gives R^T
    np.testing.assert_allclose(stored, rec.rotations["a"].transpose(0, 2, 1), atol=1e-5)


@pytest.mark.parametrize("name", ["r.csv", "r.csv.gz"])
def test_csv_round_trip(tmp_path: Path, name: str) -> None:
    rec = make_recording()
    write_csv(tmp_path / name, rec)
    assert_same(rec, load_recording(tmp_path / name), rot_tol=1e-7)


def test_csv_comments_and_blank_lines_are_ignored(tmp_path: Path) -> None:
    path = tmp_path / "c.csv"
    path.write_text(
        "# made by hand\n\ntime,w.x,w.y,w.z,w.qx,w.qy,w.qz,w.qw\n"
        "0.0,0.1,0.2,0.3,0,0,0,1\n# halfway\n0.5,0.2,0.2,0.3,,,,\n\n1.0,,,,0,0,0,1\n"
    )
    rec = load_recording(path)
    np.testing.assert_allclose(rec.time, [0.0, 0.5, 1.0])
    np.testing.assert_allclose(rec.positions["w"][1], [0.2, 0.2, 0.3])
    assert np.isnan(rec.rotations["w"][1]).all() and np.isnan(rec.positions["w"][2]).all()
    np.testing.assert_allclose(rec.rotations["w"][0], np.eye(3))
