"""Issue 71 ("probe 5"): LeRobot datasets and `simtune synth`.

- synth's LeRobot actions are the command in force at each frame's (float32) timestamp, never one frame late: on a
  dataset built from them the truth scores at least as well as a delay one frame off;
- each repeat's start jitter is recorded in its task's truth file;
- the task file's messages name the key they are about (``schedule_episode``; an empty ``episodes`` list);
- a truth file that is not simtune's is named so and kept.

The datasets are written with pyarrow alone (tests/test_lerobot.py's ``write_raw``) or by synth itself; the motion
is MuJoCo's (synth) or the controller's clamped P law (tests/test_lerobot_units.py's ``followed``).
"""

import json
import warnings
from pathlib import Path

import numpy as np
import pytest
from test_lerobot import FPS, STEPS, make_project, write_raw
from test_lerobot_units import episode, one_line, phases, project

import simtune
import simtune.api as st
from simtune.errors import ProjectError, RecordingError, RecordingWarning, SimtuneError
from simtune.objective import load_task_recordings
from simtune.project import load_project
from simtune.studies.synth import make_synthetic

pq = pytest.importorskip("pyarrow.parquet")

DURATION = 4.0


def waving_episode(duration: float = DURATION) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """One episode (time, state [deg], action [deg], each with a gripper column) whose joint_1 target moves every
    frame (a sine of 20 deg at 0.5 Hz) and joint_2 steps to -30 deg at 0.5 s: as a schedule, one phase per frame,
    each starting at a float32 timestamp."""
    time = np.arange(int(round(duration * FPS)) + 1) / FPS
    action = np.zeros((len(time), 7))
    action[:, 0] = 20.0 * np.sin(2 * np.pi * 0.5 * time)
    action[time >= 0.5, 1] = -30.0
    action[:, 6] = 35.0  # the gripper's opening, not an angle
    state = action.copy()
    state[:, :6] = 0.0
    return time, state, action


def frames(dataset: Path) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A written dataset's timestamps, episode indices and actions, row by row."""
    table = pq.read_table(next((dataset / "data").rglob("*.parquet")))
    return (
        np.asarray(table.column("timestamp").to_numpy(), dtype=float),
        np.asarray(table.column("episode_index").to_numpy()),
        np.array(table.column("action").to_pylist(), dtype=float),
    )


@pytest.fixture(scope="module")
def synthesised(tmp_path_factory):
    """A project whose task `wave` is driven by a waving episode's actions, synthesised by synth as a LeRobot
    dataset (2 repeats, delay 0.6 s, no jitter or noise); and a second project whose task is driven by that
    dataset's own actions and tuned on its states."""
    tmp = tmp_path_factory.mktemp("synth")
    source = make_project(tmp / "source", schedule='schedule_lerobot = "../dataset"')
    write_raw(source / "dataset", "v3.0", [waving_episode()])
    make_synthetic(
        "mujoco",
        "wave",
        source / "recordings",
        truth={"command_delay": 0.6},
        repeats=2,
        jitter_s=0.0,
        noise_m=0.0,
        joint_noise_rad=0.0,
        fmt="lerobot",
        project=source,
    )
    again = make_project(tmp / "again", schedule='schedule_lerobot = "../recordings/wave"')
    (again / "recordings").symlink_to(source / "recordings")
    return source, again


def test_synths_actions_are_the_command_in_force_at_each_frames_timestamp(synthesised):
    source, _ = synthesised
    starts, table = load_project(source).task("wave").schedule
    time, episode, action = frames(source / "recordings" / "wave")
    for k in (0, 1):
        rows = episode == k
        # the schedule's phases start at the source's frame times (index / fps, not its float32 timestamps);
        # the writer compares them in float32, the written timestamps' type, so a frame's own phase is in force there
        in_force = table[np.searchsorted(np.float32(starts), np.float32(time[rows]), side="right")]
        late = np.flatnonzero(np.any(np.abs(action[rows, :6] - in_force) > 1e-4, axis=1))
        assert late.size == 0, f"episode {k}: {late.size} of {rows.sum()} frames' actions are not in force there"


def test_on_a_dataset_built_from_synths_actions_the_truth_scores_best(synthesised):
    """The truth (0.6 s) scores at least as well as a delay one frame (33 ms) either side: one-frame-late actions
    made the truth score worse than a tuned model and moved the delay 14 ms."""
    _, again = synthesised
    at = {
        d: st.evaluate("mujoco", "wave", project=again, params={"command_delay": d}).fitness
        for d in (0.6, 0.6 - 1 / FPS, 0.6 + 1 / FPS)
    }
    assert at[0.6] <= min(at.values()) + 1e-12, at


def test_each_repeats_start_jitter_is_in_its_tasks_truth_file(tmp_path):
    make_synthetic("mujoco", "single", tmp_path, truth={"command_delay": 1.2}, repeats=3, seed=4, jitter_s=0.05)
    own = json.loads((tmp_path / "truth-single.json").read_text())
    starts = own["repeat_starts"]
    assert [s["repeat"] for s in starts] == ["single0001.tsv", "single0002.tsv", "single0003.tsv"]
    jitters = [s["start_jitter_s"] for s in starts]
    assert all(abs(j) <= 0.05 for j in jitters) and len(set(jitters)) == 3  # drawn per repeat, within +-0.05 s
    for s in starts:
        assert s["command_delay"] == pytest.approx(1.2 + s["start_jitter_s"], abs=1e-8)
    # the truth file stays a parameter file, and truth.json (shared by tasks) holds no one task's repeats
    assert st.evaluate("mujoco", "single", data=tmp_path, params=tmp_path / "truth-single.json").fitness < 0.01
    assert "repeat_starts" not in json.loads((tmp_path / "truth.json").read_text())


def test_a_truth_file_simtune_did_not_write_is_named_so_and_kept(tmp_path):
    (tmp_path / "truth-single.json").write_text("user\n")
    with pytest.raises(SimtuneError) as info:
        make_synthetic("mujoco", "single", tmp_path, truth={"command_delay": 1.2}, repeats=1)
    message = str(info.value)
    assert "truth-single.json is not a truth file simtune synth wrote" in message and "earlier synth" not in message
    assert "--force" in message and "\n" not in message
    assert (tmp_path / "truth-single.json").read_text() == "user\n"
    assert not (tmp_path / "single").exists()  # refused before anything is simulated


TASK_KEYS = {
    "an episode the dataset lacks names schedule_episode": (
        'schedule_lerobot = "../dataset"\nschedule_episode = 5',
        "",
        "wave.toml: schedule_lerobot: dataset: schedule_episode: no episode 5 (the dataset's episodes: 0)",
    ),
    "an empty episodes list is said to be empty": (
        'schedule_lerobot = "../dataset"',
        "episodes = []",
        "wave.toml: recordings.episodes: the list is empty: it names no episode to read",
    ),
}


@pytest.mark.parametrize("case", sorted(TASK_KEYS))
def test_task_file_messages_name_the_key_the_file_sets(tmp_path, case):
    schedule, extra, message = TASK_KEYS[case]
    root = make_project(tmp_path / "proj", schedule=schedule, extra=extra)
    write_raw(root / "dataset", "v3.0", [waving_episode()])
    with pytest.raises(ProjectError) as info:
        load_project(root)
    assert message in str(info.value) and "\n" not in str(info.value)
    assert "recordings.episodes: no episode" not in str(info.value)
    assert "expected a list of episode numbers" not in str(info.value)


# --- what a LeRobot dataset's states say about themselves ----------------------------------------------------------

#: a small arm's schedule [deg]: targets of 1.6 and -1.2 deg, no joint commanded over 10 deg (the refusing units
#: check's least span)
TINY_STEPS = [
    (0.0, [0, 0, 0, 0, 0, 0]),
    (0.5, [0, 1.6, 0, 0, 0, 0]),
    (1.5, [0, 1.6, -1.2, 0, 0, 0]),
]


def recording_warnings(root: Path) -> list[str]:
    """The RecordingWarnings that reading the project's task `wave`'s recordings raises."""
    task = load_project(root).task("wave")
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        load_task_recordings(root / "recordings" / "wave", task)
    return [str(w.message) for w in caught if issubclass(w.category, RecordingWarning)]


def test_a_state_that_never_moves_under_moving_commands_is_warned_of(tmp_path):
    """All zeros (the gripper's opening aside) while the task commands joint_1 30 deg, joint_2 50 and joint_3 40."""
    time, state, action = episode()
    still = state.copy()
    still[:, :6] = 0.0
    root = project(tmp_path / "p", phases(STEPS), "deg", [(time, still, action), (time, still, action)])
    said = recording_warnings(root)
    joint_2 = [m for m in said if "joint 'joint_2'" in m]
    assert len(joint_2) == 1, said
    one_line(
        joint_2[0],
        "wave: observation.state[1] ('joint_2.pos', joint 'joint_2') never moves in episodes 0-1",
        "while the task commands it over 50 deg",
        "[recordings.joints]",
    )
    assert not [m for m in said if "joint 'joint_4'" in m]  # held at 0: not commanded, not doubted
    # an arm that follows its commands is not warned of
    assert not [
        m for m in recording_warnings(project(tmp_path / "q", phases(STEPS), "deg", [episode()])) if "never moves" in m
    ]


def test_a_small_arms_radians_stated_as_degrees_are_warned_of_naming_the_units_key(tmp_path):
    root = project(tmp_path / "p", phases(TINY_STEPS), "deg", [episode("rad", TINY_STEPS)] * 2)
    said = [m for m in recording_warnings(root) if "units check" in m]
    assert len(said) == 1, said
    one_line(
        said[0],
        "observation.state[1] ('joint_2.pos', joint 'joint_2'), stated \"deg\"",
        "of the 1.6 deg the task commands it over",
        "looks like radians",
        'units = "rad" in the task file\'s [recordings] table',
    )
    # in degrees as stated, or in radians stated so: no doubt
    for unit in ("deg", "rad"):
        right = project(tmp_path / unit, phases(TINY_STEPS), unit, [episode(unit, TINY_STEPS)])
        assert not [m for m in recording_warnings(right) if "units check" in m]


def test_a_one_frame_episode_beside_good_ones_is_left_out_with_a_warning(tmp_path):
    good = episode()
    single = tuple(column[:1] for column in good)
    root = project(tmp_path / "p", phases(STEPS), "deg", [good, good, single])
    said = recording_warnings(root)
    assert [m for m in said if "episode_000002: duration check: left out: holds 1 frame" in m], said
    with pytest.warns(RecordingWarning, match="left out: holds 1 frame"):
        data = load_task_recordings(root / "recordings" / "wave", load_project(root).task("wave"))
    assert data.joint_repeats is not None and data.joint_repeats.shape[0] == 2
    alone = project(tmp_path / "alone", phases(STEPS), "deg", [single])
    with pytest.raises(RecordingError, match="episode_000000 frame 1: only 1 valid frame"):
        load_task_recordings(alone / "recordings" / "wave", load_project(alone).task("wave"))


# --- the task check's journey on recordings a task file names ------------------------------------------------------


def test_the_task_check_on_a_task_files_lerobot_folder_says_what_it_reads_the_first_time(tmp_path):
    """No data root in simtune.toml; the task file's [recordings] folder is a LeRobot dataset: the check said the
    project 'names no data root' (it needs none), then, given --data, that it reads marker tracks only."""
    root = make_project(tmp_path / "proj", schedule="phases", extra='folder = "lerobot/wave"')
    (root / "simtune.toml").write_text('robot = "mico"\ntasks = ["tasks/wave.toml"]\n')
    write_raw(root / "lerobot" / "wave", "v3.0", [episode(), episode()])
    with pytest.raises(SimtuneError) as info:
        st.check("mujoco", "wave", project=root, space="calibrated")
    one_line(
        str(info.value),
        f"check --task wave: its recordings ({root / 'lerobot' / 'wave'}) hold joint angles and no wrist marker",
        "`simtune check` on the project folder checks joint logs",
    )
    assert "data root" not in str(info.value)


@pytest.mark.slow  # the default tier's 4 minutes
def test_the_task_check_reads_a_task_files_own_marker_folder_without_a_data_root(tmp_path):
    make_synthetic("mujoco", "single", tmp_path / "data", truth={"command_delay": 1.2}, repeats=2, noise_m=0.001)
    root = tmp_path / "proj"
    (root / "tasks").mkdir(parents=True)
    (root / "simtune.toml").write_text('robot = "mico"\ntasks = ["tasks/single.toml"]\n')
    bundled = (Path(simtune.__file__).parent / "projects" / "mico" / "tasks" / "single.toml").read_text()
    (root / "tasks" / "single.toml").write_text(
        bundled.replace("public_recordings = true", 'recordings = "../data/single"')
    )
    result = st.check("mujoco", "single", project=root, space="calibrated")
    assert result["data"] is None  # each task's own folder
    (quality,) = result["data_quality"]
    assert len(quality["repeats"]) == 2 and quality["implied_command_delay_s"] == pytest.approx(1.2, abs=0.1)
