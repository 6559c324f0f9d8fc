"""Issue "probe 4's defects", items 6 and 7: what a task file states about a LeRobot dataset is checked, not taken
as given.

6. A stated unit is checked against the joints' limits and the task's commands, as an undeclared log's is: radians
   stated as degrees (the data moves 57 times too little) and degrees stated as radians (within two turns, but
   outside the joints' limits) were scored; now one line names the file, row, entry and the unit the data looks like.
7. A schedule from a dataset's episode (``schedule_lerobot``) is checked as a recording of the task is: timestamps in
   milliseconds, a one-frame episode or one of half the task collapsed the schedule or held its last action; now
   one line names the task file, the dataset and the episode.

The datasets are written with pyarrow alone (tests/test_lerobot.py's ``write_raw``), their motion an arm following
the schedule with the controller's clamped P law (no simulation: every case fails before one).
"""

import math
from pathlib import Path

import numpy as np
import pytest
from test_joint_logs import cli  # the CLI in this process: exit status and stderr
from test_lerobot import FPS, STEPS, make_project, write_raw

import simtune.api as st
from simtune.data import Recording, write_csv
from simtune.errors import ProjectError, RecordingError
from simtune.objective import load_task_recordings
from simtune.project import load_project
from simtune.robot.mico import ARM_JOINTS

#: a task that moves little: in degrees its every angle stays within two turns' number (4 pi = 12.6), which the
#: readers' degrees check let through when the task file states radians
SMALL_STEPS = [
    (0.0, [0, 0, 0, 0, 0, 0]),
    (0.5, [0, -10, 0, 0, 0, 0]),
    (1.5, [0, -10, 8, 0, 0, 0]),
]
DATASET = "wave/data/chunk-000/file-000.parquet"


def followed(steps=STEPS, duration: float = 4.0, fps: float = FPS) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Times [s], the measured angles [deg] (n, 6) of an arm following ``steps`` with the task's clamped P law
    (gain 10, 40 deg/s), and the targets [deg] (n, 6) in force, at ``fps`` frames per second."""
    starts = np.array([s for s, _ in steps])
    table = np.array([row for _, row in steps], dtype=float)
    dt = 1e-3
    q = table[0].copy()
    fine = np.empty((int(round(duration / dt)) + 1, 6))
    for k in range(len(fine)):
        fine[k] = q
        q = q + np.clip(10.0 * (table[np.searchsorted(starts, k * dt, side="right") - 1] - q), -40.0, 40.0) * dt
    time = np.arange(int(round(duration * fps)) + 1) / fps
    targets = table[np.searchsorted(starts, time, side="right") - 1]
    return time, fine[np.round(time / dt).astype(int)], targets


def episode(unit: str = "deg", steps=STEPS, duration: float = 4.0, time_scale: float = 1.0):
    """One episode (time, state, action) in ``unit``, with the gripper's opening (35 %, not an angle) beside the
    joints; ``time_scale`` 1000 stores milliseconds."""
    time, state, action = followed(steps, duration)
    to_unit = np.radians if unit == "rad" else np.asarray
    gripper = np.full((len(time), 1), 35.0)
    return time * time_scale, np.hstack([to_unit(state), gripper]), np.hstack([to_unit(action), gripper])


def phases(steps) -> str:
    return "\n".join(f"[[phases]]\nstart = {s}\ntargets_deg = {row}" for s, row in steps[1:])


def project(root: Path, schedule: str, units: str, episodes) -> Path:
    """tests/test_lerobot.py's MICO project `wave`, its task file stating ``units``, its recordings a v3.0 dataset
    of ``episodes`` in ``recordings/wave`` (none: no dataset)."""
    make_project(root, schedule=schedule)
    task_file = root / "tasks" / "wave.toml"
    task_file.write_text(task_file.read_text().replace('units = "deg"', f'units = "{units}"'))
    if episodes:
        write_raw(root / "recordings" / "wave", "v3.0", episodes)
    return root


def one_line(message: str, *fragments: str) -> None:
    assert "\n" not in message and "Traceback" not in message, message
    for fragment in fragments:
        assert fragment in message, message


# --- 6. a stated unit is checked ------------------------------------------------------------------------------------


def test_radians_stated_as_degrees_are_refused_naming_row_entry_and_unit(tmp_path, capsys):
    """The schedule's phases command joint_2 over 50 deg; the dataset, in radians, read as degrees moves it 0.9 deg."""
    root = project(tmp_path / "p", phases(STEPS), "deg", [episode("rad"), episode("rad")])
    task = load_project(root).task("wave")
    with pytest.raises(RecordingError) as info:
        load_task_recordings(root / "recordings" / "wave", task)
    one_line(
        str(info.value),
        f"{DATASET} row ",
        "units check: observation.state[1] ('joint_2.pos', joint 'joint_2') in episode 0, stated \"deg\"",
        "it looks like radians",
        'units = "rad" in the task file\'s [recordings] table',
    )
    code, err = cli("evaluate", "--project", str(root), "--task", "wave", capsys=capsys)
    assert code == 2 and err.startswith("error: ") and err.count("\n") == 1, err
    one_line(err.rstrip("\n"), DATASET, "looks like radians")


def test_degrees_stated_as_radians_within_two_turns_are_refused(tmp_path):
    """joint_2 logged at -10 deg reads -10 rad: within two turns (the readers' degrees check), outside its limits."""
    root = project(tmp_path / "p", phases(SMALL_STEPS), "rad", [episode("deg", SMALL_STEPS)])
    with pytest.raises(RecordingError) as info:
        st.evaluate("mujoco", "wave", project=root)
    one_line(
        str(info.value),
        f"{DATASET} row ",
        "observation.state[1] ('joint_2.pos', joint 'joint_2') in episode 0, stated \"rad\"",
        "outside its limits [-2.35, 2.35] rad",
        "it looks like degrees",
        'units = "deg"',
    )


@pytest.mark.parametrize("unit", ["deg", "rad"])
def test_a_dataset_in_its_stated_unit_is_read(tmp_path, unit):
    """The checks refuse no dataset in the unit stated, from the task's phases or from its own actions."""
    for steps in (STEPS, SMALL_STEPS):
        root = project(tmp_path / f"{unit}{len(steps)}", phases(steps), unit, [episode(unit, steps)])
        task = load_project(root).task("wave")
        data = load_task_recordings(root / "recordings" / "wave", task)
        assert data.joint_mean is not None
        expected = np.radians(followed(steps)[1][:, 1])
        assert np.abs(data.joint_mean[:, 1] - np.interp(data.times, followed(steps)[0], expected)).max() < 1e-3
        own = project(
            tmp_path / f"own{unit}{len(steps)}", 'schedule_lerobot = "../recordings/wave"', unit, [episode(unit, steps)]
        )
        own_task = load_project(own).task("wave")
        assert own_task.phases[-1].targets_deg[1] == pytest.approx(steps[-1][1][1], abs=1e-4)
        assert load_task_recordings(own / "recordings" / "wave", own_task).joint_mean is not None


def test_a_schedule_from_radians_stated_as_degrees_is_refused(tmp_path, capsys):
    """The same dataset as schedule and recordings (as docs/task-files.md suggests): nothing to compare it with but
    what angles look like. Read as degrees every action lies within 1 deg of 0; read as radians they move 0.87 rad."""
    root = project(tmp_path / "p", 'schedule_lerobot = "../recordings/wave"', "deg", [episode("rad")])
    with pytest.raises(ProjectError) as info:
        load_project(root)
    one_line(
        str(info.value),
        "wave.toml: schedule_lerobot: ",
        f"{DATASET} row ",
        "units check: action[1] ('joint_2.pos', joint 'joint_2') in episode 0, stated \"deg\"",
        "it looks like radians",
        'units = "rad"',
    )
    code, err = cli("check", str(root), capsys=capsys)  # a problem of the project, no longer "start within 0.00 deg"
    assert code == 2 and err.count("\n") == 1 and "Traceback" not in err and "looks like radians" in err, err


def test_a_schedule_from_degrees_stated_as_radians_names_the_dataset_and_the_unit(tmp_path):
    root = project(tmp_path / "p", 'schedule_lerobot = "../recordings/wave"', "rad", [episode("deg", SMALL_STEPS)])
    with pytest.raises(ProjectError) as info:
        load_project(root)
    one_line(
        str(info.value),
        f"wave.toml: schedule_lerobot: {DATASET} row ",
        "action[1] ('joint_2.pos', joint 'joint_2') in episode 0, stated \"rad\"",
        "outside its limits",
        "it looks like degrees",
        'units = "deg"',
    )


def test_a_csv_column_declaring_radians_that_are_degrees_is_refused(tmp_path):
    """The same check for a CSV column's own declaration (``joint_2 [rad]``), which the units check skipped."""
    root = project(tmp_path / "p", phases(SMALL_STEPS), "deg", [])
    text = (root / "tasks" / "wave.toml").read_text().replace('[recordings]\nunits = "deg"\n', "")
    (root / "tasks" / "wave.toml").write_text(text)
    time, state, _ = followed(SMALL_STEPS)
    folder = root / "recordings" / "wave"
    folder.mkdir(parents=True)
    rec = Recording(folder / "wave0001.csv", time, joints={j: state[:, k] for k, j in enumerate(ARM_JOINTS)})
    write_csv(folder / "wave0001.csv", rec)  # degrees, written as they are
    lines = (folder / "wave0001.csv").read_text().splitlines()
    head = next(k for k, line in enumerate(lines) if line.startswith("time,"))  # after write_csv's comment
    lines[head] = ",".join(f"{name} [rad]" if name in ARM_JOINTS else name for name in lines[head].split(","))
    (folder / "wave0001.csv").write_text("\n".join(lines) + "\n")
    with pytest.raises(RecordingError) as info:
        load_task_recordings(folder, load_project(root).task("wave"))
    one_line(
        str(info.value),
        "wave/wave0001.csv line ",
        "units check: joint 'joint_2', declared [rad], reads -10 rad, outside its limits",
        "it looks like degrees: declare 'joint_2 [deg]' in its header if so",
    )


def test_the_declared_units_rules_on_their_own():
    """docs/recordings.md's rules for a stated unit, on plain numbers: commanded 0 to 60 deg, limits +-2.35 rad."""
    from simtune.data.sanity import JointRange, declared_units_problem, schedule_units_problem

    joint = JointRange(0.0, 0.0, math.radians(60), -2.35, 2.35)
    motion = np.radians(np.linspace(0, 58, 50))  # [rad]: what the arm did
    assert declared_units_problem({"j": np.degrees(motion)}, {"j": joint}, "deg") is None
    assert declared_units_problem({"j": motion}, {"j": joint}, "rad") is None
    as_degrees = declared_units_problem({"j": motion}, {"j": joint}, "deg")  # radians stated as degrees
    assert as_degrees is not None and as_degrees.other == "rad" and "1.7% of the 60 deg" in as_degrees.text
    as_radians = declared_units_problem({"j": np.degrees(motion) / 10}, {"j": joint}, "rad")  # 5.8 "rad"
    assert as_radians is not None and as_radians.other == "deg" and "outside its limits" in as_radians.text
    # beyond the limits in either unit: refused, no unit to suggest
    neither = declared_units_problem({"j": np.full(5, 1000.0)}, {"j": joint}, "deg")
    assert neither is not None and neither.other is None and "neither unit fits" in neither.text
    # a schedule stated in degrees within 6.28 of 0, moving 0.9 "deg": radians; one that moves 40 deg is degrees
    limits = {"j": (-2.35, 2.35)}
    radians = schedule_units_problem({"j": np.radians([0.0, 50.0])}, limits, "deg")
    assert radians is not None and radians.other == "rad"
    assert schedule_units_problem({"j": np.array([0.0, 40.0])}, limits, "deg") is None
    assert schedule_units_problem({"j": np.array([0.0, 0.05])}, limits, "deg") is None  # too still to tell


# --- 7. a schedule from a dataset is checked as recordings are ------------------------------------------------------

SCHEDULES = {
    "timestamps in milliseconds": (
        lambda: [episode(time_scale=1000.0)],
        # meta/info.json's fps names it first (probe 5 #15)
        "wave/data/chunk-000/file-000.parquet: timestamp: episode 0 steps 33.3333 s a frame (0.03 frames per "
        "second), but meta/info.json says fps 30",
    ),
    "one frame": (
        lambda: [tuple(part[:1] for part in episode())],
        "wave/episode_000000 frame 1: only 1 valid frame; need at least 2",
    ),
    "half the task": (
        lambda: [episode(duration=2.0)],
        "wave/episode_000000: duration check: lasts 2 s (61 frames), less than 90% of the task's 4 s",
    ),
}


@pytest.mark.parametrize("case", sorted(SCHEDULES))
def test_a_schedule_episode_is_checked_as_a_recording(tmp_path, capsys, case):
    make, message = SCHEDULES[case]
    root = project(tmp_path / "p", 'schedule_lerobot = "../recordings/wave"', "deg", make())
    with pytest.raises(ProjectError) as info:
        load_project(root)
    one_line(str(info.value), "wave.toml: schedule_lerobot: " + message)
    code, err = cli("evaluate", "--project", str(root), "--task", "wave", capsys=capsys)
    assert code == 2 and err.startswith("error: ") and err.count("\n") == 1 and message in err, err


def test_a_schedule_from_a_later_episode_is_named_by_its_number(tmp_path):
    """``schedule_episode`` picks a short episode among full ones: the message names that one."""
    root = project(
        tmp_path / "p",
        'schedule_lerobot = "../recordings/wave"\nschedule_episode = 1',
        "deg",
        [episode(), episode(duration=1.0)],
    )
    with pytest.raises(ProjectError, match=r"schedule_lerobot: wave/episode_000001: duration check: lasts 1 s"):
        load_project(root)
