"""load_task_data: gap repair, dropped repeats, common clock; resample."""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np
import pytest

from simtune.data import (
    Recording,
    TaskData,
    load_task_data,
    resample,
    write_csv,
    write_qualisys_tsv,
)
from simtune.errors import ConfigError, RecordingError, RecordingWarning


def repeat(duration: float, rate: float = 100.0, offset: float = 0.0, t0: float = 0.0) -> Recording:
    """Wrist moving linearly along x, object pushed from x=0.5 to 0.6."""
    n = int(round(duration * rate)) + 1
    t = np.arange(n) / rate
    wrist = np.c_[0.1 + 0.2 * t + offset, np.full(n, 0.06), 0.87 - 0.1 * t]
    obj = np.c_[np.linspace(0.5, 0.6, n), np.full(n, 0.007), np.full(n, 0.04)]
    rot = np.tile(np.eye(3), (n, 1, 1))
    return Recording(
        source=Path("synthetic"),
        time=t + t0,
        positions={"wrist": wrist, "obj": obj},
        rotations={"wrist": rot.copy(), "obj": rot.copy()},
    )


def test_resample_reproduces_linear_motion() -> None:
    t = np.array([0.0, 0.3, 0.35, 1.0, 2.0])
    values = np.c_[2 * t + 1, -t, t * 0 + 5]
    out = resample(t, values, rate=20.0, n=41)
    grid = np.arange(41) / 20.0
    np.testing.assert_allclose(out, np.c_[2 * grid + 1, -grid, grid * 0 + 5])
    np.testing.assert_allclose(resample(t, 3 * t, 10.0, 5), 3 * np.arange(5) / 10.0)


def test_resample_rejects_bad_rate() -> None:
    with pytest.raises(ConfigError):
        resample(np.arange(3.0), np.arange(3.0), 0.0, 3)


def test_common_clock_and_statistics(tmp_path: Path) -> None:
    write_csv(tmp_path / "b.csv", repeat(1.05, offset=0.01))
    write_csv(tmp_path / "a.csv", repeat(1.0, t0=5.0))  # time shifted: clock restarts at 0
    write_qualisys_tsv(tmp_path / "c.tsv.gz", repeat(1.08, rate=120.0, offset=-0.01), header=True)
    (tmp_path / "notes.txt").write_text("ignored")
    td = load_task_data(tmp_path, "push", "wrist", "obj", rate=20.0)
    assert isinstance(td, TaskData) and td.task == "push" and td.rate == 20.0
    assert [p.name for p in td.sources] == ["a.csv", "b.csv", "c.tsv.gz"]
    assert td.times.size == 21 and td.duration == pytest.approx(1.0)
    np.testing.assert_allclose(td.times, np.arange(21) / 20.0)
    assert td.wrist_repeats.shape == (3, 21, 3)
    expected = 0.1 + 0.2 * td.times
    np.testing.assert_allclose(td.wrist_repeats[0, :, 0], expected, atol=1e-9)
    np.testing.assert_allclose(td.wrist_mean[:, 0], expected, atol=1e-6)
    # Offsets +1 cm, 0, -1 cm around the mean: spread = 2/3 cm.
    assert td.repeat_spread == pytest.approx(0.02 / 3, abs=1e-6)
    assert td.object_final is not None and td.object_start is not None
    np.testing.assert_allclose(td.object_final[:, 0], 0.6, atol=1e-6)
    np.testing.assert_allclose(td.object_start[:, 0], 0.5, atol=1e-6)
    np.testing.assert_allclose(td.object_final_mean, [0.6, 0.007, 0.04], atol=1e-6)


def test_without_object(tmp_path: Path) -> None:
    write_csv(tmp_path / "a.csv", repeat(0.5))
    td = load_task_data(tmp_path, "reach", "wrist")
    assert td.object_final is None and td.object_start is None and td.object_final_mean is None
    assert td.repeat_spread == 0.0


def test_short_gap_is_interpolated(tmp_path: Path) -> None:
    rec = repeat(1.0)
    truth = rec.positions["wrist"].copy()
    rec.positions["wrist"][40:60] = np.nan  # 0.20 s lost, within max_gap_s = 0.25
    rec.positions["wrist"][40:60, 1] = np.nan
    rec.positions["obj"][:10] = np.nan  # leading drop-out: held at first valid sample
    write_csv(tmp_path / "gap.csv", rec)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        td = load_task_data(tmp_path, "t", "wrist", "obj", rate=100.0)
    np.testing.assert_allclose(td.wrist_repeats[0], truth, atol=1e-6)
    assert td.object_start is not None
    np.testing.assert_allclose(td.object_start[0, 0], 0.5 + 0.1 * 10 / 100, atol=1e-6)


def test_short_gap_on_a_curve_matches_linear_interpolation(tmp_path: Path) -> None:
    rec = repeat(1.0)
    rec.positions["wrist"][:, 1] = np.sin(rec.time * 3)
    before, after = rec.positions["wrist"][29].copy(), rec.positions["wrist"][41].copy()
    rec.positions["wrist"][30:41] = np.nan
    write_csv(tmp_path / "gap.csv", rec)
    td = load_task_data(tmp_path, "t", "wrist", rate=100.0)
    w = (np.arange(30, 41) - 29) / 12.0
    expected = before + w[:, None] * (after - before)
    np.testing.assert_allclose(td.wrist_repeats[0, 30:41], expected, atol=1e-6)


@pytest.mark.parametrize("body", ["wrist", "obj"])
def test_long_gap_drops_the_repeat(tmp_path: Path, body: str) -> None:
    write_csv(tmp_path / "a.csv", repeat(1.0))
    bad = repeat(1.0)
    bad.positions[body][50:80] = np.nan  # 0.30 s
    write_csv(tmp_path / "b_lost.csv", bad)
    write_csv(tmp_path / "c.csv", repeat(1.0))
    pattern = rf"b_lost\.csv: gap check: left out: '{body}' lost for 0\.30 s \(frames 51-80"
    with pytest.warns(RecordingWarning, match=pattern):
        td = load_task_data(tmp_path, "t", "wrist", "obj")
    assert [p.name for p in td.sources] == ["a.csv", "c.csv"]


def test_trailing_object_loss_too_long(tmp_path: Path) -> None:
    write_csv(tmp_path / "a.csv", repeat(1.0))
    bad = repeat(1.0)
    bad.positions["obj"][60:] = np.nan
    write_csv(tmp_path / "b.csv", bad)
    with pytest.warns(RecordingWarning, match=r"b\.csv: gap check: left out"):
        td = load_task_data(tmp_path, "t", "wrist", "obj")
    assert len(td.sources) == 1


def test_max_gap_is_configurable(tmp_path: Path) -> None:
    rec = repeat(1.0)
    rec.positions["wrist"][50:80] = np.nan
    write_csv(tmp_path / "a.csv", rec)
    td = load_task_data(tmp_path, "t", "wrist", max_gap_s=0.5)
    assert len(td.sources) == 1


def test_every_repeat_dropped_is_an_error(tmp_path: Path) -> None:
    for name in ["a.csv", "b.csv"]:
        rec = repeat(1.0)
        rec.positions["wrist"][:] = np.nan
        write_csv(tmp_path / name, rec)
    with pytest.warns(RecordingWarning), pytest.raises(RecordingError, match="no usable repeats"):
        load_task_data(tmp_path, "t", "wrist")


def test_headerless_tsv_with_body_names(tmp_path: Path) -> None:
    write_qualisys_tsv(tmp_path / "a.tsv", repeat(1.0))
    td = load_task_data(tmp_path, "t", "wrist", "obj", body_names=["wrist", "obj"])
    assert len(td.sources) == 1
    with pytest.raises(RecordingError, match=r"a\.tsv line 1: the file has 2 bodies"):
        load_task_data(tmp_path, "t", "wrist")


def test_bad_rate(tmp_path: Path) -> None:
    with pytest.raises(ConfigError):
        load_task_data(tmp_path, "t", "wrist", rate=-1.0)
