"""The ingest checks (simtune.data.ingest): each warns, one line naming file, episode and channel, on a recording with
its fault, and stays silent on the same recording without it and on the shipped reference; `simtune check DIR
--json` lists them (``data_checks``) and gives a task of one repeat no floor (null)."""

import json
import math
import subprocess
import sys
import warnings
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from simtune.check.project import _check_recordings, findings_json
from simtune.data import load_task_data, write_lerobot_dataset
from simtune.data.csvformat import write_csv
from simtune.data.ingest import CHECKS, NAMES, data_check_entry
from simtune.data.lerobot import STILL_SHARE, LeRobotReading
from simtune.data.recording import Recording
from simtune.data.sanity import declared_units_problem
from simtune.errors import RecordingWarning
from simtune.objective import joint_ranges, load_references
from simtune.project import load_project
from simtune.reference import REFERENCE_DIR
from simtune.reference.make import synthesize
from simtune.robot.mico import ARM_JOINTS
from simtune.tasks import get_task
from simtune.tasks.spec import Phase, TaskSpec

pytest.importorskip("pyarrow")

FPS = 30
#: every joint moves: the clean recording leaves no joint weakly excited
STEPS = [(0.5, [10, -50, 20, 30, -30, 40]), (1.5, [10, -40, 40, 0, 0, 0]), (2.0, [30, -50, 40, 20, 20, -20])]
PHASES = "\n".join(f"[[phases]]\nstart = {s}\ntargets_deg = {row}" for s, row in STEPS)
TASK_FILE = f"""\
name = "wave"
duration = 3.0

[recordings]
units = "deg"

[controller]
gain = 10.0
max_velocity_deg = 40.0

[mocap]
body = "hand"

{PHASES}
"""
NAMES_POS = [f"{j}.pos" for j in ARM_JOINTS]


def wave_task() -> TaskSpec:
    return TaskSpec(
        name="wave",
        description="",
        duration=3.0,
        phases=tuple(Phase(s, tuple(float(v) for v in row)) for s, row in STEPS),
        kp=10.0,
        max_velocity_deg=40.0,
        wrist_body="hand",
    )


@pytest.fixture(scope="module")
def logs() -> list[Recording]:
    """Two repeats of the task simulated by MuJoCo (0.2 s delay, 0.05 deg encoder noise) at 30 frames a second:
    joint logs alone (0.3 s)."""
    recordings = synthesize(
        "mujoco",
        wave_task(),
        {"command_delay": 0.2},
        repeats=2,
        noise_m=0.0,
        jitter_s=0.0,
        seed=3,
        rate=FPS,
        joint_names=ARM_JOINTS,
        joint_noise_rad=math.radians(0.05),
    )
    return [Recording(source=Path(r.source.name), time=r.time, joints=dict(r.joints)) for r in recordings]


def _targets(time: np.ndarray) -> np.ndarray:
    starts, table = wave_task().schedule
    return table[np.searchsorted(starts, time, side="right")]


def _dataset(root: Path, logs: list[Recording], change=None) -> Path:
    """``logs`` as a LeRobot dataset by simtune's writer (state and the targets in force as action, degrees);
    ``change(k, time, state, action)`` returns an episode's faulty version."""
    episodes = []
    for k, rec in enumerate(logs):
        state = np.degrees(np.column_stack([rec.joints[j] for j in ARM_JOINTS]))
        episode = (rec.time, state, _targets(rec.time))
        episodes.append(change(k, *episode) if change else episode)
    return write_lerobot_dataset(root, episodes, NAMES_POS, FPS)


def _csv(folder: Path, logs: list[Recording], change=None) -> Path:
    """``logs`` as simtune CSV joint logs; ``change(time, joints)`` returns a repeat's faulty (time, joints)."""
    folder.mkdir(parents=True)
    for k, rec in enumerate(logs):
        time, joints = change(rec.time, dict(rec.joints)) if change else (rec.time, rec.joints)
        write_csv(folder / f"wave{k:04d}.csv", Recording(source=folder, time=time, joints=joints))
    return folder


def _ranges(**joint_2):
    """The task's joint ranges, each with a velocity limit of 1 rad/s (the MICO's description gives none), and
    joint_2's fields replaced by ``joint_2``."""
    ranges = {j: replace(r, velocity=1.0) for j, r in joint_ranges(wave_task()).items()}
    ranges["joint_2"] = replace(ranges["joint_2"], **joint_2)
    return ranges


def _checks(folder: Path, ranges=None, lerobot: bool = False) -> list[dict]:
    """The ingest checks' warnings of loading ``folder`` as the task's recordings, each read into its parts."""
    ranges = ranges or _ranges()
    reading = LeRobotReading(units="deg", ranges=tuple(ranges.items())) if lerobot else None
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        load_task_data(folder, "wave", "hand", joint_names=ARM_JOINTS, lerobot=reading, joint_ranges=ranges)
    entries = [data_check_entry(str(w.message)) for w in caught if issubclass(w.category, RecordingWarning)]
    return [e for e in entries if e is not None and e["check"] in NAMES]


def _held(k, time, state, action):
    state = state.copy()
    if k == 1:
        for i in (30, 35, 40, 45):  # the arm moves then (1.0-1.5 s): the loop logged those frames twice
            state[i] = state[i - 1]
    return time, state, action


def _still_joint_6(time, joints):
    joints["joint_6"] = joints["joint_6"][0] + math.radians(0.2) * np.sin(time)
    return time, joints


def _barely_joint_1(k, time, state, action):
    # commanded over 30 deg, it moves 0.8: above the still-joint warning's 2 % (0.6 deg), below 1 deg
    state = state.copy()
    state[:, 0] = 0.8 * np.sin(time)  # [deg]: time runs 0-3 s, sin spans 1
    return time, state, action


#: fault -> (format, how, the joint ranges, the check and channel that name it, its source)
FAULTS = {
    "weak excitation in a dataset": (
        "lerobot",
        _barely_joint_1,
        {},
        "excitation check",
        "joint 'joint_1'",
        "ds/episode_000000 (and 1",
    ),
    "weak excitation": ("csv", _still_joint_6, {}, "excitation check", "joint 'joint_6'", "ds/wave0000.csv (and 1"),
    "commands logged as the state": (
        "lerobot",
        lambda k, time, state, action: (time, state, state.copy()),
        {},
        "command check",
        "action vs observation.state",
        "ds/episode_000000 (and 1 other episode)",
    ),
    "frames logged twice": ("lerobot", _held, {}, "clock check", "every joint", "ds/episode_000001"),
    "a clock three times too fast": (
        "csv",
        lambda time, joints: (time / 3, joints),
        {},
        "clock check",
        "joint 'joint_2'",
        "ds/wave0000.csv",
    ),
    "limits the log passes": ("csv", None, {"lower": -0.85}, "offset check", "joint 'joint_2'", "ds/wave000"),
}


@pytest.mark.parametrize("fault", FAULTS)
def test_each_check_names_its_fault_and_not_the_clean_recording(tmp_path, logs, fault):
    fmt, change, joint_2, check, channel, source = FAULTS[fault]
    write = _dataset if fmt == "lerobot" else _csv
    assert _checks(write(tmp_path / "clean" / "ds", logs), lerobot=fmt == "lerobot") == []
    found = _checks(write(tmp_path / "bad" / "ds", logs, change), _ranges(**joint_2), fmt == "lerobot")
    named = [(e["check"], e["channel"]) for e in found]
    assert (check, channel) in named, found
    entry = next(e for e in found if e["check"] == check)
    assert entry["source"].startswith(source), entry
    assert entry["episode"] == (int(source.split("_")[1][:6]) if fmt == "lerobot" else None)


def test_the_offset_check_says_the_calibration_tunes_a_small_offset(tmp_path, logs):
    # joint_2 reaches -0.873 rad (-50 deg): a lower limit 1.5 deg above it, inside the 3 deg joint_offset_<n> tunes
    found = _checks(_csv(tmp_path / "ds", logs), _ranges(lower=-0.873 + math.radians(1.5)))
    (entry,) = [e for e in found if e["check"] == "offset check"]
    assert "a zero offset, not a unit" in entry["message"] and "joint_offset_<n>" in entry["message"]


def test_a_unit_error_past_the_limits_says_when_it_is_a_zero_offset():
    # a LeRobot dataset in degrees whose zero is 100 deg from the model's: no unit fits, its motion fits the limits
    values = {"joint_2": np.linspace(-150.0, -120.0, 50)}
    (name, limits) = next((j, r) for j, r in _ranges().items() if j == "joint_2")
    problem = declared_units_problem(values, {name: limits}, "deg")
    assert problem is not None and problem.other is None
    assert "a zero offset, not a unit" in problem.text and "middle of the calibrated range" in problem.text
    assert "more than the +-3 deg the calibration tunes" in problem.text


def test_an_episode_too_short_for_the_task_is_the_duration_checks(tmp_path, logs):
    # the ingest owes no check of its own here: the sanity stage leaves it out, naming the episode
    short = [
        *logs,
        Recording(source=Path("cut"), time=logs[0].time[:45], joints={j: q[:45] for j, q in logs[0].joints.items()}),
    ]
    ranges = _ranges()
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        data = load_task_data(
            _dataset(tmp_path / "ds", short),
            "wave",
            "hand",
            joint_names=ARM_JOINTS,
            duration_s=3.0,
            lerobot=LeRobotReading(units="deg", ranges=tuple(ranges.items())),
            joint_ranges=ranges,
        )
    (entry,) = [e for e in (data_check_entry(str(w.message)) for w in caught) if e is not None]
    assert entry["check"] == "duration check" and entry["episode"] == 2 and "left out" in entry["message"]
    assert len(data.sources) == 2


def test_the_shipped_reference_passes_every_ingest_check():
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        load_references(None, [get_task("cube")])  # the bundled reference: REFERENCE_DIR / "cube"
    assert REFERENCE_DIR.is_dir()
    said = [data_check_entry(str(w.message)) for w in caught]
    assert not [e for e in said if e is not None and e["check"] in NAMES]


def test_check_dir_json_names_the_checks_and_gives_one_repeat_no_floor(tmp_path, logs):
    root = tmp_path / "proj"
    (root / "tasks").mkdir(parents=True)
    (root / "simtune.toml").write_text('robot = "mico"\ntasks = ["tasks/wave.toml"]\ndata = "recordings"\n')
    (root / "tasks" / "wave.toml").write_text(TASK_FILE)
    _dataset(root / "recordings" / "wave", logs[:1], lambda k, time, state, action: (time, state, state.copy()))
    result = findings_json(_check_recordings(load_project(root), "wave"))
    assert result["floors"] == {"wave": {"repeats": 1, "floor_fitness": None}}
    (entry,) = result["data_checks"]
    assert entry["task"] == "wave" and entry["check"] == "command check" and entry["episode"] == 0
    assert any("no floor: one repeat" in f["message"] for f in result["findings"])
    assert not any("floor (the aligned mean" in f["message"] for f in result["findings"])


@pytest.mark.slow  # 5 s: the engines load the robot
def test_check_dir_json_on_the_command_line(tmp_path, logs):
    root = tmp_path / "proj"
    (root / "tasks").mkdir(parents=True)
    (root / "simtune.toml").write_text('robot = "mico"\ntasks = ["tasks/wave.toml"]\ndata = "recordings"\n')
    (root / "tasks" / "wave.toml").write_text(TASK_FILE)
    _dataset(root / "recordings" / "wave", logs[:1])  # one clean episode: no floor, no warning
    proc = subprocess.run(
        [sys.executable, "-m", "simtune.cli", "check", str(root), "--json"], capture_output=True, text=True, timeout=600
    )
    assert proc.returncode == 0, proc.stderr
    result = json.loads(proc.stdout)
    assert result["problems"] == 0 and result["data_checks"] == []
    assert result["floors"]["wave"]["floor_fitness"] is None


def test_every_check_is_listed_in_the_docs():
    docs = (Path(__file__).resolve().parents[1] / "docs" / "recordings.md").read_text()
    for check in CHECKS:
        assert f"| {check.name} | {check.finds} | {check.rule} |" in docs, check.name  # docs match the table
    assert f"under {STILL_SHARE:.0%} of it" in CHECKS[0].rule  # the still-joint warning's share, as it is
    assert data_check_entry("wave/episode_000002: duration check: left out: holds 1 frame") == {
        "check": "duration check",
        "source": "wave/episode_000002",
        "episode": 2,
        "channel": None,
        "message": "wave/episode_000002: duration check: left out: holds 1 frame",
    }
