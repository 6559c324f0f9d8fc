"""Held-out repeats: which of a task's repeats build its reference (all, even or odd), chosen before alignment."""

from __future__ import annotations

import json
import shutil
import subprocess
import sys
import warnings
from pathlib import Path

import numpy as np
import pytest

import simtune.api as st
from simtune.check.task import task_quality
from simtune.data import Recording, load_task_data, write_csv
from simtune.data.task import check_repeats
from simtune.errors import ConfigError, RecordingError, RecordingWarning
from simtune.project import get_project
from simtune.reference import REFERENCE_DIR
from simtune.run_plan import RunConfig, plan_run
from simtune.runs import fingerprint_differences, run_fingerprint

#: when each synthetic repeat starts to move on its own clock [s]
STARTS = [1.20, 1.43, 0.97, 1.61, 1.08, 1.30, 1.15]


def _smooth_step(u: np.ndarray) -> np.ndarray:
    u = np.clip(u, 0.0, 1.0)
    return u**3 * (10 - 15 * u + 6 * u**2)


def _repeat(i: int, start: float) -> Recording:
    """A wrist at rest, out 20 cm and up 10 cm from ``start`` on, a cube at rest where repeat ``i`` leaves it."""
    rng = np.random.default_rng(i)
    t = np.arange(601) / 100.0
    out = _smooth_step((t - start) / 1.5)
    wrist = np.c_[0.3 + 0.2 * out, 0.05 + 0 * out, 0.6 + 0.1 * out] + rng.normal(0.0, 0.0005, (len(t), 3))
    cube = np.tile([0.5 + 0.01 * i, 0.0, 0.04], (len(t), 1))
    rot = np.tile(np.eye(3), (len(t), 1, 1))
    return Recording(Path(f"r{i}.csv"), t, {"wrist": wrist, "cube": cube}, {"wrist": rot, "cube": rot.copy()})


def _folder(root: Path, starts: list[float], name: str = "reach") -> Path:
    folder = root / name
    folder.mkdir(parents=True)
    for i, start in enumerate(starts):
        write_csv(folder / f"r{i:02d}.csv", _repeat(i, start))
    return folder


def _names(paths) -> list[str]:
    return [Path(p).name for p in paths]


def test_even_and_odd_take_every_other_repeat_and_partition_them(tmp_path: Path) -> None:
    folder = _folder(tmp_path, STARTS)
    every = _names(load_task_data(folder, "reach", "wrist", "cube").sources)
    even = load_task_data(folder, "reach", "wrist", "cube", repeats="even")
    odd = load_task_data(folder, "reach", "wrist", "cube", repeats="odd")
    assert _names(even.sources) == ["r00.csv", "r02.csv", "r04.csv", "r06.csv"] == every[0::2]
    assert _names(odd.sources) == ["r01.csv", "r03.csv", "r05.csv"] == every[1::2]
    assert (even.repeats, odd.repeats) == ("even", "odd")
    assert _names(even.held_out) == _names(odd.sources) and _names(odd.held_out) == _names(even.sources)
    assert sorted(_names(even.sources) + _names(odd.sources)) == every
    # the reference is made of the selected repeats alone: their count, their objects
    assert even.wrist_repeats.shape[0] == 4 and odd.wrist_repeats.shape[0] == 3
    np.testing.assert_allclose(even.object_final[:, 0], [0.50, 0.52, 0.54, 0.56])


def test_all_is_the_reference_as_it_was(tmp_path: Path) -> None:
    folder = _folder(tmp_path, STARTS)
    for reference in ("mean", "aligned"):
        before = load_task_data(folder, "reach", "wrist", "cube", reference=reference)  # no selection: today's
        now = load_task_data(folder, "reach", "wrist", "cube", reference=reference, repeats="all")
        for key in ("times", "wrist_mean", "wrist_repeats", "object_final", "object_start", "object_rest"):
            np.testing.assert_array_equal(getattr(now, key), getattr(before, key))
        assert now.sources == before.sources and now.held_out == [] and now.repeats == "all"
        if reference == "aligned":
            np.testing.assert_array_equal(now.alignment.shifts, before.alignment.shifts)


def test_the_selection_comes_before_the_clocks_are_aligned(tmp_path: Path) -> None:
    """An aligned reference of the even repeats is the aligned reference of a folder holding just those."""
    folder = _folder(tmp_path, STARTS)
    only_even = tmp_path / "only" / "reach"
    only_even.mkdir(parents=True)
    for name in ("r00.csv", "r02.csv", "r04.csv", "r06.csv"):
        shutil.copy(folder / name, only_even / name)
    even = load_task_data(folder, "reach", "wrist", "cube", reference="aligned", repeats="even")
    alone = load_task_data(only_even, "reach", "wrist", "cube", reference="aligned")
    assert len(even.alignment.shifts) == 4
    np.testing.assert_array_equal(even.alignment.shifts, alone.alignment.shifts)
    np.testing.assert_array_equal(even.wrist_mean, alone.wrist_mean)


def test_a_selection_of_none_is_one_line_naming_the_folder_and_the_choice(tmp_path: Path) -> None:
    folder = _folder(tmp_path, [1.2])
    with pytest.raises(RecordingError, match=r"reach: repeats 'odd' selects none of its 1 usable repeat") as info:
        load_task_data(folder, "reach", "wrist", repeats="odd")
    assert str(folder) in str(info.value) and "\n" not in str(info.value)
    assert _names(load_task_data(folder, "reach", "wrist", repeats="even").sources) == ["r00.csv"]


@pytest.mark.parametrize("bad", ["Even", "median", "", None, 2])
def test_a_bad_selection_is_one_line(bad) -> None:
    with pytest.raises(ConfigError, match=r"^repeats: expected all, even or odd .*got"):
        check_repeats(bad)


def test_api_repeats_are_checked_where_they_enter() -> None:
    with pytest.raises(ConfigError, match=r"^repeats: expected all, even or odd.*got 'half'$"):
        st.evaluate("mujoco", "cube", repeats="half")
    assert st.run_config("mujoco", "cube").repeats == "all"
    assert st.run_config("mujoco", "cube", repeats="odd").repeats == "odd"
    assert st.grid_spec("mujoco", "cube", "shared", repeat_set="even").repeat_set == "even"
    assert st.grid_spec("mujoco", "cube", "shared").repeat_set == "all"


# --- runs: their stores and fingerprints ----------------------------------------------------------------------------
def test_the_stored_configuration_names_repeats_only_when_not_all() -> None:
    base = {"engine": "mujoco", "tasks": "cube", "space": "shared", "data": None}
    assert "repeats" not in RunConfig(**base).record()
    assert "repeats" not in RunConfig(**base, repeats="all").record()
    assert RunConfig(**base, repeats="even").record()["repeats"] == "even"
    stored = RunConfig(**base).record()  # a default run, or one stored before the choice: all
    assert RunConfig.from_stored(stored, "run.sqlite").repeats == "all"
    assert RunConfig.from_stored({**stored, "repeats": "odd"}, "run.sqlite").repeats == "odd"
    with pytest.raises(ConfigError, match=r"^run.sqlite: repeats: expected all, even or odd"):
        RunConfig.from_stored({**stored, "repeats": "half"}, "run.sqlite")


def test_the_run_fingerprint_holds_the_repeats_when_not_all() -> None:
    config = st.run_config("mujoco", "cube", space="shared")
    assert "repeats" not in run_fingerprint(plan_run(config))
    config.repeats = "even"
    assert run_fingerprint(plan_run(config))["repeats"] == "even"
    now = {"data": {}, "tasks": {}, "engine": "mujoco 3", "reference": "aligned"}
    assert fingerprint_differences(now, now) == []
    # resumed with another selection: the same kind of message as a changed reference
    assert fingerprint_differences(now, {**now, "repeats": "odd"}) == ["the repeats changed from all to odd"]
    assert fingerprint_differences({**now, "repeats": "even"}, {**now, "repeats": "odd"}) == [
        "the repeats changed from even to odd"
    ]
    assert fingerprint_differences({**now, "reference": "mean"}, {**now, "repeats": "even"}) == [
        "the reference changed from mean to aligned",
        "the repeats changed from all to even",
    ]


# --- the command line and the check --------------------------------------------------------------------------------
def _cli(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run(
        [sys.executable, "-m", "simtune.cli", *args], capture_output=True, text=True, timeout=120, check=False
    )


def test_the_command_line_refuses_another_selection_in_one_line() -> None:
    proc = _cli("evaluate", "--task", "cube", "--repeats", "half")
    assert proc.returncode == 2 and proc.stderr.startswith("error:")
    assert "--repeats" in proc.stderr and "all, even or odd" in proc.stderr
    assert len(proc.stderr.strip().splitlines()) == 1


def test_the_command_line_says_when_a_selection_leaves_none(tmp_path: Path) -> None:
    (tmp_path / "cube").mkdir()
    shutil.copy(REFERENCE_DIR / "cube" / "cube0001.tsv.gz", tmp_path / "cube")
    proc = _cli("evaluate", "--task", "cube", "--data", str(tmp_path), "--repeats", "odd")
    assert proc.returncode == 2 and proc.stderr.startswith("error:") and "Traceback" not in proc.stderr
    assert "repeats 'odd' selects none" in proc.stderr and str(tmp_path / "cube") in proc.stderr
    assert len(proc.stderr.strip().splitlines()) == 1


def test_evaluate_json_names_the_repeats_it_scored_against() -> None:
    proc = _cli("evaluate", "--task", "cube", "--repeats", "even", "--json")
    assert proc.returncode == 0, proc.stderr
    data = json.loads(proc.stdout)
    files = sorted(p.name for p in (REFERENCE_DIR / "cube").iterdir())
    assert data["repeats"] == "even" and data["repeat_files"] == {"cube": files[0::2]}


def test_evaluate_scores_against_the_repeats_asked_for() -> None:
    every = st.evaluate("mujoco", "cube")
    same = st.evaluate("mujoco", "cube", repeats="all")
    odd = st.evaluate("mujoco", "cube", repeats="odd")
    assert same.fitness == every.fitness and every.repeats == "all"
    files = sorted(p.name for p in (REFERENCE_DIR / "cube").iterdir())
    assert every.repeat_files == {"cube": files} and odd.repeat_files == {"cube": files[1::2]}
    assert odd.fitness != every.fitness


def test_check_says_which_repeats_it_used(capsys) -> None:
    from simtune.cli.check_output import print_data_quality

    task = get_project(None).parse_tasks("cube")[0]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RecordingWarning)
        summary, data = task_quality("mujoco", task, REFERENCE_DIR, "aligned", "even")
    assert _names(data.sources) == summary["repeat_files"]
    files = sorted(p.name for p in (REFERENCE_DIR / "cube").iterdir())
    assert summary["repeat_selection"] == "even" and summary["repeat_files"] == files[0::2]
    assert [r["file"] for r in summary["repeats"]] == files[0::2] and summary["held_out"] == files[1::2]
    print_data_quality([summary])
    printed = capsys.readouterr().out
    assert "repeats even" in printed and f"held out: {files[1]}" in printed
    plain, _ = task_quality("mujoco", task, REFERENCE_DIR)
    assert "repeat_selection" not in plain and "held_out" not in plain


# --- the real recordings ------------------------------------------------------------------------------------------
def test_real_cube_splits_into_12_even_and_11_odd_repeats(mocap_root: Path) -> None:
    folder = mocap_root / "cube"
    files = sorted(p.name for p in folder.glob("*.tsv"))
    assert len(files) == 23
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RecordingWarning)  # cube's outlying shifts
        even = load_task_data(folder, "cube", "RB1(Orange)", "PCube", repeats="even")
        odd = load_task_data(folder, "cube", "RB1(Orange)", "PCube", reference="aligned", repeats="odd")
    assert _names(even.sources) == files[0::2] and len(even.sources) == 12
    assert _names(odd.sources) == files[1::2] and len(odd.sources) == 11 and len(odd.alignment.shifts) == 11
    assert _names(even.held_out) == _names(odd.sources)


def test_the_report_rescores_against_each_runs_repeats_or_those_asked_for() -> None:
    from types import SimpleNamespace

    from simtune.report.simulate import References

    even_run = SimpleNamespace(config=SimpleNamespace(reference="aligned", repeats="even"))
    # the defaults of a run stored before the choices
    old_run = SimpleNamespace(config=SimpleNamespace(reference="mean", repeats="all"))
    own, odd = References(), References(None, "odd")
    assert (own.selection(even_run), own.label(even_run)) == ("even", "aligned of the even repeats")
    assert (own.selection(old_run), own.label(old_run)) == ("all", "mean")
    assert (odd.selection(old_run), odd.label(old_run)) == ("odd", "mean of the odd repeats")
    task = get_project(None).parse_tasks("cube")[0]
    files = sorted(p.name for p in (REFERENCE_DIR / "cube").iterdir())
    data = own.get(str(REFERENCE_DIR), task, "mean", "odd")
    assert _names(data.sources) == files[1::2]
