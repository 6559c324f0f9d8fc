"""The aligned reference (issue 32): repeats shifted onto one clock before averaging, and the choice of reference."""

from __future__ import annotations

import subprocess
import sys
import warnings
from pathlib import Path

import numpy as np
import pytest

import simtune.api as st
from simtune.data import Recording, load_task_data, write_csv
from simtune.data.clock import align_clocks, check_reference, outlying_shifts
from simtune.errors import ConfigError, RecordingWarning
from simtune.run_plan import RunConfig
from simtune.runs import fingerprint_differences

RATE = 20.0
#: when each synthetic repeat starts to move on its own clock [s]
STARTS = [1.20, 1.43, 0.97, 1.61, 1.08, 1.30]


def _smooth_step(u: np.ndarray) -> np.ndarray:
    u = np.clip(u, 0.0, 1.0)
    return u**3 * (10 - 15 * u + 6 * u**2)  # minimum jerk


def _wrist(t: np.ndarray, start: float) -> np.ndarray:
    """A wrist at rest, then out 20 cm along x and up 10 cm, back half way, and at rest again."""
    out = _smooth_step((t - start) / 1.5)
    back = _smooth_step((t - start - 2.5) / 1.2)
    return np.c_[0.3 + 0.2 * out - 0.1 * back, 0.05 + 0.03 * back, 0.6 + 0.1 * out]


def _repeat(i: int, start: float, noise_m: float = 0.0005, duration: float = 6.0) -> Recording:
    rng = np.random.default_rng(i)
    t = np.arange(int(duration * 100) + 1) / 100.0
    wrist = _wrist(t, start) + rng.normal(0.0, noise_m, (len(t), 3))
    cube = np.tile([0.5, 0.0, 0.04], (len(t), 1))
    rot = np.tile(np.eye(3), (len(t), 1, 1))
    return Recording(
        source=Path(f"r{i}.csv"),
        time=t,
        positions={"wrist": wrist, "cube": cube},
        rotations={"wrist": rot, "cube": rot.copy()},
    )


def _folder(tmp_path: Path, starts: list[float], **more) -> Path:
    folder = tmp_path / "reach"
    folder.mkdir()
    for i, start in enumerate(starts):
        write_csv(folder / f"r{i:02d}.csv", _repeat(i, start, **more))
    return folder


def test_known_shifts_are_recovered_within_one_sample(tmp_path: Path) -> None:
    folder = _folder(tmp_path, STARTS)
    data = load_task_data(folder, "reach", "wrist", "cube", reference="aligned")
    assert data.reference == "aligned" and data.alignment is not None
    # each repeat moved so that its start sits where the others' do: shift = common start - own start
    truth = np.median(STARTS) - np.array(STARTS)
    shifts = data.alignment.shifts
    assert np.max(np.abs((shifts - np.median(shifts)) - truth)) < 1 / RATE
    # finer than a sample, in fact: the refinement interpolates between lags
    assert np.max(np.abs((shifts - np.median(shifts)) - truth)) < 0.01
    plain = load_task_data(folder, "reach", "wrist", "cube", reference="mean")
    assert plain.alignment is None and plain.reference == "mean"
    # the aligned repeats agree to their marker noise; on their own clocks they do not
    assert data.repeat_spread < 0.002
    assert plain.repeat_spread > 0.01
    assert data.unaligned_spread == pytest.approx(plain.repeat_spread)
    # the aligned mean is the track itself, moving at the median start, sharp: not the blurred plain mean
    clean = _wrist(data.times, float(np.median(STARTS)))
    assert np.linalg.norm(data.wrist_mean - clean, axis=1).max() < 0.004
    assert np.linalg.norm(plain.wrist_mean - clean, axis=1).max() > 0.01
    # objects travel with their repeat; the reference keeps its length
    assert len(data.times) == len(plain.times)
    np.testing.assert_array_equal(data.object_final, plain.object_final)


def test_the_mean_reference_is_the_loader_as_it_was(tmp_path: Path) -> None:
    folder = _folder(tmp_path, STARTS)
    default = load_task_data(folder, "reach", "wrist", "cube")
    mean = load_task_data(folder, "reach", "wrist", "cube", reference="mean")
    np.testing.assert_array_equal(default.wrist_mean, mean.wrist_mean)
    assert default.reference == "mean"


def test_an_outlying_shift_is_warned_about_by_name(tmp_path: Path) -> None:
    folder = _folder(tmp_path, [1.20, 1.25, 1.18, 1.22, 1.21, 1.19, 1.24, 2.10])
    with pytest.warns(RecordingWarning, match=r"clock check: 1 of \d+ repeats .*scaled MADs.*r07\.csv -0\.8\d\d s"):
        data = load_task_data(folder, "reach", "wrist", reference="aligned")
    assert outlying_shifts(data.alignment.shifts, 1 / RATE) == [7]


def test_joint_logs_align_on_their_joint_track(tmp_path: Path) -> None:
    folder = tmp_path / "reach"
    folder.mkdir()
    starts = [1.0, 1.35, 0.8, 1.2]
    for i, start in enumerate(starts):
        t = np.arange(601) / 100.0
        angles = _wrist(t, start)
        write_csv(
            folder / f"j{i}.csv",
            Recording(source=Path("j"), time=t, joints={f"joint_{k}": angles[:, k] for k in range(3)}),
        )
    data = load_task_data(folder, "reach", "wrist", reference="aligned")
    assert data.wrist_mean is None and data.joint_mean is not None
    shifts = data.alignment.shifts
    truth = np.median(starts) - np.array(starts)
    assert np.max(np.abs((shifts - np.median(shifts)) - truth)) < 1 / RATE


def test_a_single_repeat_has_nothing_to_align(tmp_path: Path) -> None:
    folder = _folder(tmp_path, [1.3])
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        data = load_task_data(folder, "reach", "wrist", reference="aligned")
    np.testing.assert_array_equal(data.alignment.shifts, [0.0])
    plain = load_task_data(folder, "reach", "wrist")
    np.testing.assert_array_equal(data.wrist_mean, plain.wrist_mean)


def test_align_clocks_without_a_clear_onset_still_refines() -> None:
    t = np.arange(501) / 100.0
    tracks = [_wrist(t, s) for s in (1.0, 1.2, 1.4)]
    tracks[1][:5] += 0.03  # a glitch at the start: the onset seen at 0 s, the refinement puts it right
    result = align_clocks([t, t, t], tracks, RATE)
    assert np.max(np.abs(result.shifts - np.array([0.2, 0.0, -0.2]))) < 1 / RATE


@pytest.mark.parametrize("bad", ["Aligned", "median", "", None, 1])
def test_a_bad_reference_is_one_line(bad) -> None:
    with pytest.raises(ConfigError, match=r"^reference: expected aligned or mean"):
        check_reference(bad)


# --- the choice of reference: runs, their stores, the API and the command line -----------------------------------
def test_new_runs_align_paper_exact_runs_and_old_stores_take_the_mean() -> None:
    base = {"engine": "mujoco", "tasks": "cube", "space": "shared", "data": None}
    assert RunConfig(**base).reference == "aligned"
    assert RunConfig(**base, paper_exact=True).reference == "mean"
    assert RunConfig(**base).record()["reference"] == "aligned"
    stored = RunConfig(**base).record()
    del stored["reference"]  # a run stored before the choice
    assert RunConfig.from_stored(stored, "run.sqlite").reference == "mean"
    with pytest.raises(ConfigError, match=r"^run.sqlite: --paper-exact scores against the plain mean.*aligned$"):
        RunConfig.from_stored({**stored, "paper_exact": True, "reference": "aligned"}, "run.sqlite")
    with pytest.raises(ConfigError, match=r"^run.sqlite: reference: expected aligned or mean"):
        RunConfig.from_stored({**stored, "reference": "median"}, "run.sqlite")


def test_the_run_fingerprint_holds_the_reference() -> None:
    now = {"data": {}, "tasks": {}, "engine": "mujoco 3", "reference": "aligned"}
    assert fingerprint_differences({**now}, now) == []
    assert fingerprint_differences({**now, "reference": "mean"}, now) == ["the reference changed from mean to aligned"]
    old = {k: v for k, v in now.items() if k != "reference"}  # stored before the choice: the mean
    assert fingerprint_differences(old, {**now, "reference": "mean"}) == []


def test_api_reference_is_checked_where_it_enters() -> None:
    with pytest.raises(ConfigError, match=r"^reference: expected aligned or mean.*got 'plain'$"):
        st.evaluate("mujoco", "cube", reference="plain")
    assert st.run_config("mujoco", "cube").reference == "aligned"
    assert st.run_config("mujoco", "cube", space="shared", paper_exact=True).reference == "mean"
    assert st.grid_spec("mujoco", "cube", "shared", reference="mean").reference == "mean"


def test_evaluate_scores_against_the_reference_asked_for() -> None:
    aligned = st.evaluate("mujoco", "cube")
    mean = st.evaluate("mujoco", "cube", reference="mean")
    assert (aligned.reference, mean.reference) == ("aligned", "mean")
    assert aligned.fitness != mean.fitness
    # the object's final position does not depend on the clock
    assert aligned.object_error == mean.object_error


def test_the_command_line_refuses_another_reference_in_one_line() -> None:
    proc = subprocess.run(
        [sys.executable, "-m", "simtune.cli", "evaluate", "--task", "cube", "--reference", "median"],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert proc.returncode == 2 and proc.stderr.startswith("error:") and "--reference" in proc.stderr
    assert len(proc.stderr.strip().splitlines()) == 1


def test_real_repeats_line_up_once_their_clocks_are_aligned(mocap_root: Path) -> None:
    """The figures docs/recordings.md gives for qrg2019: the spread on the repeats' own clocks and aligned."""
    expected = {"single": (0.0135, 0.0015, 0.26), "cube": (0.0121, 0.0019, 0.75)}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RecordingWarning)  # cube's four outlying shifts
        for task, (plain, aligned, largest) in expected.items():
            data = load_task_data(mocap_root / task, task, "RB1(Orange)", "PCube", reference="aligned")
            assert data.unaligned_spread == pytest.approx(plain, abs=0.0005)
            assert data.repeat_spread == pytest.approx(aligned, abs=0.0003)
            assert np.abs(data.alignment.shifts).max() == pytest.approx(largest, abs=0.02)


@pytest.mark.slow  # about 15 s: the check's Jacobian
def test_check_prints_the_floor_of_the_real_recordings(mocap_root: Path) -> None:
    result = st.check("mujoco", "single", data=mocap_root, space="shared")
    (single,) = result["data_quality"]
    assert single["repeat_spread_unaligned_m"] == pytest.approx(0.0135, abs=0.0005)
    assert single["repeat_spread_aligned_m"] == single["repeat_spread_m"] == pytest.approx(0.0015, abs=0.0003)
    assert single["floor_fitness"] == pytest.approx(single["repeat_spread_aligned_m"])  # no object in `single`
    shifts = [r["shift_s"] for r in single["repeats"]]
    assert single["shift_range_s"] == [min(shifts), max(shifts)] and single["shift_outliers"] == []
    mean = st.check("mujoco", "single", data=mocap_root, space="shared", reference="mean")["data_quality"][0]
    assert mean["repeat_spread_m"] == single["repeat_spread_unaligned_m"]
