"""LeRobot datasets (v2.1 and v3.0 layouts) as recordings, and as the source of a task's schedule."""

import builtins
import json
import math
import subprocess
import sys
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

import simtune.api as st
from simtune.data import LeRobotReading, load_task_data, read_lerobot_dataset, task_files, write_lerobot_dataset
from simtune.data.fingerprint import file_fingerprint
from simtune.errors import ConfigError, ProjectError, RecordingError
from simtune.project import load_project
from simtune.reference.make import synthesize
from simtune.robot.mico import ARM_JOINTS
from simtune.tasks.spec import Phase, TaskSpec

pa = pytest.importorskip("pyarrow")
pq = pytest.importorskip("pyarrow.parquet")

FPS = 30
LAYOUTS = ("v2.1", "v3.0")
#: LeRobot's names for the MICO's joints, and a gripper opening (0-100, not an angle) on a joint it does not drive
NAMES = [f"{j}.pos" for j in ARM_JOINTS] + ["finger_joint_1.pos"]
#: the commanded schedule [deg]: steps at frame times a float32 timestamp holds exactly
STEPS = [
    (0.0, [0, 0, 0, 0, 0, 0]),
    (0.5, [0, -50, 0, 0, 0, 0]),
    (1.5, [0, -50, 40, 0, 0, 0]),
    (2.0, [30, -50, 40, 0, 0, 0]),
]
DURATION = 4.0
TRUE_DELAY = 0.6
#: the MICO's fingers are not driven: the gripper column is left out
READING = LeRobotReading(units="deg", undriven=("finger_joint_1",))


# --- a dataset written as LeRobot lays it out, with pyarrow alone (not through simtune's writer) ----------------


def write_raw(root: Path, version: str, episodes, names=NAMES, motors: bool = False, lengths=None) -> Path:
    """``episodes``: (time, state, action) per episode, in the dataset's unit; ``lengths`` overrides the
    episodes' stated lengths (metadata that disagrees with the data)."""
    spec = {"dtype": "float32", "shape": [len(names)], "names": {"motors": list(names)} if motors else list(names)}
    scalar = {"dtype": "float32", "shape": [1], "names": None}
    info = {
        "codebase_version": version,
        "robot_type": "so101_follower",
        "fps": FPS,
        "total_episodes": len(episodes),
        "features": {"observation.state": spec, "action": spec, "timestamp": scalar},
    }
    (root / "meta").mkdir(parents=True)
    (root / "meta" / "info.json").write_text(json.dumps(info))
    (root / "data" / "chunk-000").mkdir(parents=True)
    tables = []
    for k, (time, state, action) in enumerate(episodes):
        n = len(time)
        vector = pa.list_(pa.float32())
        tables.append(
            pa.table(
                {
                    "observation.state": pa.array(np.asarray(state, dtype=np.float32).tolist(), type=vector),
                    "action": pa.array(np.asarray(action, dtype=np.float32).tolist(), type=vector),
                    "timestamp": pa.array(np.asarray(time, dtype=np.float32)),
                    "frame_index": pa.array(np.arange(n)),
                    "episode_index": pa.array(np.full(n, k)),
                    "task_index": pa.array(np.zeros(n, dtype=np.int64)),
                }
            )
        )
    stated = lengths or [len(e[0]) for e in episodes]
    if version == "v3.0":
        pq.write_table(pa.concat_tables(tables), root / "data" / "chunk-000" / "file-000.parquet")
        (root / "meta" / "episodes" / "chunk-000").mkdir(parents=True)
        meta = pa.table({"episode_index": np.arange(len(stated)), "length": np.asarray(stated)})
        pq.write_table(meta, root / "meta" / "episodes" / "chunk-000" / "file-000.parquet")
    else:
        for k, table in enumerate(tables):
            pq.write_table(table, root / "data" / "chunk-000" / f"episode_{k:06d}.parquet")
        lines = [json.dumps({"episode_index": k, "tasks": ["wave"], "length": n}) for k, n in enumerate(stated)]
        (root / "meta" / "episodes.jsonl").write_text("\n".join(lines) + "\n")
    return root


def targets_at(time: np.ndarray) -> np.ndarray:
    """The schedule's targets [deg] in force at each time, (n, 6)."""
    starts = np.array([s for s, _ in STEPS])
    return np.array([row for _, row in STEPS], dtype=float)[np.searchsorted(starts, time, side="right") - 1]


def wave_task() -> TaskSpec:
    """The schedule as a task of its own (three phases), for the simulation that makes the truth."""
    return TaskSpec(
        name="wave",
        description="",
        duration=DURATION,
        phases=tuple(Phase(s, tuple(float(v) for v in row)) for s, row in STEPS[1:]),
        kp=10.0,
        max_velocity_deg=40.0,
        wrist_body="hand",
    )


@pytest.fixture(scope="module")
def simulated():
    """Three repeats of the schedule simulated by MuJoCo with a command delay of TRUE_DELAY and 0.05 deg encoder
    noise, at 30 frames per second: per repeat (time, state [deg] with a gripper column, action [deg])."""
    recordings = synthesize(
        "mujoco",
        wave_task(),
        {"command_delay": TRUE_DELAY},
        repeats=3,
        noise_m=0.0,
        jitter_s=0.0,
        seed=7,
        rate=FPS,
        joint_names=ARM_JOINTS,
        joint_noise_rad=math.radians(0.05),
    )
    episodes = []
    for rec in recordings:
        gripper = np.full((len(rec), 1), 35.0)  # percent open
        state = np.column_stack([np.degrees(np.column_stack([rec.joints[j] for j in ARM_JOINTS])), gripper])
        action = np.column_stack([targets_at(rec.time), gripper])
        episodes.append((rec.time, state, action))
    return episodes


TASK = """\
name = "wave"
duration = 4.0
{schedule}

[recordings]
units = "deg"
{extra}
[controller]
gain = 10.0
max_velocity_deg = 40.0

[mocap]
body = "hand"
"""
PHASES = "\n".join(
    f"[[phases]]\nstart = {s}\ntargets_deg = {row}" for s, row in STEPS[1:]
)  # the same schedule, written out


def make_project(root: Path, schedule: str = 'schedule_lerobot = "../recordings/wave"', extra: str = "") -> Path:
    """A MICO project whose task `wave` reads its recordings from ``recordings/wave`` (a LeRobot dataset)."""
    (root / "tasks").mkdir(parents=True, exist_ok=True)
    (root / "simtune.toml").write_text('robot = "mico"\ntasks = ["tasks/wave.toml"]\ndata = "recordings"\n')
    text = TASK.format(schedule=schedule if schedule != "phases" else "", extra=extra)
    if schedule == "phases":
        text += "\n" + PHASES + "\n"
    (root / "tasks" / "wave.toml").write_text(text)
    return root


# --- reading ----------------------------------------------------------------------------------------------------


@pytest.mark.parametrize("version", LAYOUTS)
@pytest.mark.parametrize("motors", [False, True])
def test_both_layouts_read_as_one_repeat_per_episode(tmp_path, simulated, version, motors):
    root = write_raw(tmp_path / "wave", version, simulated, motors=motors)
    recs = read_lerobot_dataset(root, ARM_JOINTS, READING)
    assert [r.source.name for r in recs] == ["episode_000000", "episode_000001", "episode_000002"]
    for rec, (time, state, _) in zip(recs, simulated):
        assert list(rec.joints) == list(ARM_JOINTS)  # the gripper's opening is left out
        np.testing.assert_allclose(rec.time, time, atol=1e-6)  # float32 timestamps
        np.testing.assert_allclose(rec.joints["joint_2"], np.radians(state[:, 1]), atol=1e-6)
        assert rec.where(2) == "frame 3"
    assert task_files(root) == [root]  # the task folder is the dataset: one source of three repeats
    assert read_lerobot_dataset(root, ARM_JOINTS, replace(READING, episodes=(2, 0)))[0].source.name == (
        "episode_000002"
    )


def test_radians_and_a_joints_table(tmp_path, simulated):
    """Other names (a Koch-like arm's), mapped by [recordings.joints]; "" leaves a name out."""
    names = ["Rotation", "Pitch", "Elbow", "Wrist_Pitch", "Wrist_Roll", "Wrist_Yaw", "Gripper"]
    time, state, action = simulated[0]
    root = write_raw(tmp_path / "koch", "v3.0", [(time, np.radians(state), action)], names=names)
    table = (*zip(names[:6], ARM_JOINTS), ("Gripper", ""))
    (rec,) = read_lerobot_dataset(root, ARM_JOINTS, LeRobotReading(units="rad", joints=table))
    np.testing.assert_allclose(rec.joints["joint_3"], np.radians(state[:, 2]), atol=1e-6)


@pytest.mark.parametrize("version", LAYOUTS)
def test_simtunes_writer_reads_back(tmp_path, simulated, version):
    episodes = [(t, s[:, :6], a[:, :6]) for t, s, a in simulated]
    root = write_lerobot_dataset(tmp_path / "w", episodes, NAMES[:6], FPS, version=version, task="wave")
    info = json.loads((root / "meta" / "info.json").read_text())
    assert info["codebase_version"] == version and info["fps"] == 30 and info["total_frames"] == 3 * len(episodes[0][0])
    files = sorted(p.relative_to(root).as_posix() for p in (root / "data").rglob("*.parquet"))
    expected = (
        ["data/chunk-000/file-000.parquet"]
        if version == "v3.0"
        else [f"data/chunk-000/episode_00000{k}.parquet" for k in range(3)]
    )
    assert files == expected
    recs = read_lerobot_dataset(root, ARM_JOINTS, LeRobotReading(units="deg"))
    np.testing.assert_allclose(recs[1].joints["joint_1"], np.radians(simulated[1][1][:, 0]), atol=1e-6)
    with pytest.raises(RecordingError, match="already holds a LeRobot dataset"):
        write_lerobot_dataset(root, episodes, NAMES[:6], FPS)


def test_the_fingerprint_reads_no_videos(tmp_path, simulated):
    root = write_raw(tmp_path / "wave", "v3.0", simulated[:1])
    before = file_fingerprint(root)
    (root / "videos" / "observation.images.front" / "chunk-000").mkdir(parents=True)
    (root / "videos" / "observation.images.front" / "chunk-000" / "file-000.mp4").write_bytes(b"\0" * 1000)
    assert file_fingerprint(root) == before
    (root / "meta" / "info.json").write_text(
        (root / "meta" / "info.json").read_text().replace('"fps": 30', '"fps": 15')
    )
    assert file_fingerprint(root)["sha256"] != before["sha256"]


# --- a task driven by the dataset's actions, tuned on its observations ----------------------------------------


@pytest.mark.parametrize("version", LAYOUTS)
def test_actions_drive_the_task_and_tuning_recovers_the_delay(tmp_path, simulated, version):
    """The known truth (MuJoCo, command delay 0.6 s) comes back from a dataset in each layout."""
    root = make_project(tmp_path / "proj")
    write_raw(root / "recordings" / "wave", version, simulated)
    task = load_project(root).task("wave")
    assert len(task.phases) == len(simulated[0][0]) - 1  # one phase per frame before the task's end: the actions
    assert task.phases[15].start == 0.5 and task.phases[15].targets_deg[1] == pytest.approx(-50.0)
    assert max(abs(a) for a in task.start_pose_deg) < 0.3  # the first observation (0 and its noise)
    data = load_task_data(root / "recordings" / "wave", "wave", "hand", lerobot=READING)
    assert data.joint_repeats is not None and data.joint_repeats.shape == (3, 81, 6)
    generic = st.evaluate("mujoco", "wave", project=root)
    at_truth = st.evaluate("mujoco", "wave", project=root, params={"command_delay": TRUE_DELAY})
    assert at_truth.fitness < 0.1 * generic.fitness
    tuned = st.tune(
        "mujoco", "wave", project=root, out=tmp_path / "run", only=["command_delay"], max_evaluations=30, seed=1
    )
    assert tuned.x["command_delay"] == pytest.approx(TRUE_DELAY, abs=0.05)
    assert tuned.fitness <= at_truth.fitness * 1.01


def test_the_same_schedule_from_phases_and_from_actions(tmp_path, simulated):
    by_actions = make_project(tmp_path / "a")
    write_raw(by_actions / "recordings" / "wave", "v3.0", simulated)
    by_phases = make_project(tmp_path / "p", schedule="phases")
    write_raw(by_phases / "recordings" / "wave", "v3.0", simulated)
    params = {"command_delay": 0.3}
    a = st.evaluate("mujoco", "wave", project=by_actions, params=params)
    p = st.evaluate("mujoco", "wave", project=by_phases, params=params)
    # the start pose differs by the first observation's noise (hundredths of a degree)
    assert a.fitness == pytest.approx(p.fitness, rel=0.02)


@pytest.mark.parametrize("fmt", ["lerobot", "lerobot-v2.1"])
def test_synth_writes_a_dataset_that_tunes(tmp_path, simulated, fmt):
    """The SO-101 owner's path in the small: a task driven by a dataset's actions, recordings synthesised as a
    LeRobot dataset, tuned."""
    from simtune.studies.synth import make_synthetic

    source = tmp_path / "proj" / "source"
    write_raw(source, "v3.0", simulated[:1])
    root = make_project(tmp_path / "proj", schedule='schedule_lerobot = "../source"')
    result = make_synthetic(
        "mujoco", "wave", root / "recordings", truth={"command_delay": 0.9}, repeats=2, fmt=fmt, project=root
    )
    dataset = root / "recordings" / "wave"
    assert result.files == {"wave": [dataset]}
    info = json.loads((dataset / "meta" / "info.json").read_text())
    assert info["codebase_version"] == {"lerobot": "v3.0", "lerobot-v2.1": "v2.1"}[fmt]
    assert info["features"]["action"]["names"] == NAMES[:6]
    table = pq.read_table(next((dataset / "data").rglob("*.parquet")))
    assert table.column("action").to_pylist()[30] == pytest.approx([0, -50, 0, 0, 0, 0])  # 1.0 s, in degrees
    tuned = st.tune(
        "mujoco", "wave", project=root, out=tmp_path / "run", only=["command_delay"], max_evaluations=30, seed=1
    )
    assert tuned.x["command_delay"] == pytest.approx(0.9, abs=0.1)  # each repeat's delay jittered by +-0.05 s
    with pytest.raises(Exception, match="already holds recordings"):
        make_synthetic("mujoco", "wave", root / "recordings", truth={"command_delay": 0.9}, fmt=fmt, project=root)


def test_synth_refuses_a_task_without_a_stated_unit(tmp_path):
    from simtune.studies.synth import make_synthetic

    root = make_project(tmp_path / "proj", schedule="phases")
    text = (root / "tasks" / "wave.toml").read_text().replace('[recordings]\nunits = "deg"\n', "")
    (root / "tasks" / "wave.toml").write_text(text)
    with pytest.raises(ConfigError, match=r"task 'wave': .*add units = \"deg\""):
        make_synthetic("mujoco", "wave", tmp_path / "out", truth={}, fmt="lerobot", project=root)
    assert not (tmp_path / "out" / "wave").exists()


# --- bad datasets: one line naming the file and the field, exit status 2 -------------------------------------


def _rewrite(root: Path, change) -> None:
    """Rewrite the v3.0 data file through ``change(table) -> table``."""
    path = root / "data" / "chunk-000" / "file-000.parquet"
    pq.write_table(change(pq.read_table(path)), path)


def _set_state(table, row: int, value):
    states = table.column("observation.state").to_pylist()
    states[row] = value
    column = pa.array(states, type=pa.list_(pa.float32()))
    return table.set_column(table.schema.get_field_index("observation.state"), "observation.state", column)


def _info(root: Path, change) -> None:
    info = json.loads((root / "meta" / "info.json").read_text())
    change(info)
    (root / "meta" / "info.json").write_text(json.dumps(info))


BAD = {
    "no info.json": (
        lambda root: (root / "meta" / "info.json").unlink(),
        "wave/meta/info.json: missing: a LeRobot dataset folder holds meta/info.json",
    ),
    "info.json not JSON": (
        lambda root: (root / "meta" / "info.json").write_text("{"),
        "wave/meta/info.json: not valid JSON",
    ),
    "a version simtune does not read": (
        lambda root: _info(root, lambda i: i.update(codebase_version="v1.6")),
        "wave/meta/info.json: codebase_version: 'v1.6' is not a layout simtune reads",
    ),
    "a name that is not a joint": (
        lambda root: _info(root, lambda i: i["features"]["observation.state"]["names"].__setitem__(2, "elbow.pos")),
        "wave/meta/info.json: features.observation.state.names[2]: 'elbow.pos' is not a joint of the robot",
    ),
    "shape and names disagree": (
        lambda root: _info(root, lambda i: i["features"]["observation.state"].update(shape=[8])),
        "wave/meta/info.json: features.observation.state.shape: [8] but names has 7 entries",
    ),
    "a row of another length": (
        lambda root: _rewrite(root, lambda t: _set_state(t, 4, [0.0] * 6)),
        "wave/data/chunk-000/file-000.parquet row 5: observation.state: 6 values, but meta/info.json's "
        "features.observation.state names 7",
    ),
    "a NaN row": (
        lambda root: _rewrite(root, lambda t: _set_state(t, 9, [float("nan")] * 7)),
        "wave/data/chunk-000/file-000.parquet row 10: observation.state[0] ('joint_1.pos'): nan is not an angle "
        "(episode 0",
    ),
    "a null row": (
        lambda root: _rewrite(root, lambda t: _set_state(t, 9, None)),
        "wave/data/chunk-000/file-000.parquet row 10: observation.state: missing (null)",
    ),
    "episode lengths disagree": (
        lambda root: pq.write_table(
            pa.table({"episode_index": [0, 1], "length": [121, 100]}),
            root / "meta" / "episodes" / "chunk-000" / "file-000.parquet",
        ),
        "wave/meta/episodes/chunk-000/file-000.parquet row 2: length: episode 1 has 100 frames, the data holds 121",
    ),
    "time going backwards": (
        lambda root: _rewrite(
            root,
            lambda t: t.set_column(
                t.schema.get_field_index("timestamp"),
                "timestamp",
                pa.array(np.r_[t.column("timestamp").to_numpy()[:3], [0.0], t.column("timestamp").to_numpy()[4:]]),
            ),
        ),
        "wave/data/chunk-000/file-000.parquet row 4: timestamp: the time goes backwards in episode 0",
    ),
    "no timestamp column": (
        lambda root: _rewrite(root, lambda t: t.drop_columns(["timestamp"])),
        "wave/data/chunk-000/file-000.parquet: no column 'timestamp'",
    ),
    "not Parquet": (
        lambda root: (root / "data" / "chunk-000" / "file-000.parquet").write_bytes(b"PAR1 not really"),
        "wave/data/chunk-000/file-000.parquet: cannot read as Parquet",
    ),
    "radians stated for degrees": (
        lambda root: None,
        "wave/data/chunk-000/file-000.parquet row 89: units check: observation.state[0] ('joint_1.pos') is 13.1083 "
        '(13.11 rad): looks like degrees: units = "deg" in the task file\'s [recordings] table',
    ),
    "no unit stated": (
        lambda root: None,
        "LeRobot datasets store no angle unit: state it in the task file's [recordings] table",
    ),
    "an episode it lacks": (
        lambda root: None,
        "wave: recordings.episodes: no episode 5 (the dataset's episodes: 0-1)",
    ),
}
EXTRA = {"radians stated for degrees": 'units = "rad"', "an episode it lacks": "episodes = [0, 5]"}


def bad_project(tmp_path: Path, simulated, case: str = "a NaN row") -> Path:
    """A project whose recordings are a v3.0 dataset spoiled as ``BAD[case]`` says (the schedule: phases)."""
    root = make_project(tmp_path / "proj", schedule="phases")
    task_file = root / "tasks" / "wave.toml"
    if case in EXTRA:
        key = EXTRA[case].split(" ")[0]
        old = 'units = "deg"' if key == "units" else 'units = "deg"\n'
        task_file.write_text(task_file.read_text().replace(old, EXTRA[case] if key == "units" else old + EXTRA[case]))
    if case == "no unit stated":
        task_file.write_text(task_file.read_text().replace('units = "deg"\n', ""))
    BAD[case][0](write_raw(root / "recordings" / "wave", "v3.0", simulated[:2]))
    return root


@pytest.mark.parametrize("case", sorted(BAD))
def test_bad_datasets_stop_with_one_line_naming_file_and_field(tmp_path, simulated, case):
    root = bad_project(tmp_path, simulated, case)
    with pytest.raises(RecordingError) as info:
        st.evaluate("mujoco", "wave", project=root)
    assert BAD[case][1] in str(info.value) and "\n" not in str(info.value)


def test_a_bad_dataset_on_the_command_line_is_one_line_and_exit_2(tmp_path, simulated):
    root = bad_project(tmp_path, simulated)
    proc = subprocess.run(
        [
            sys.executable,
            "-m",
            "simtune.cli",
            "evaluate",
            "--project",
            str(root),
            "--engine",
            "mujoco",
            "--task",
            "wave",
        ],
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert proc.returncode == 2 and proc.stdout == ""
    assert proc.stderr.startswith(f"error: {BAD['a NaN row'][1]}") and proc.stderr.count("\n") == 1, proc.stderr


def test_v2_episode_lengths_and_a_missing_episode_file(tmp_path, simulated):
    root = write_raw(tmp_path / "wave", "v2.1", simulated[:2], lengths=[121, 121, 50])
    with pytest.raises(RecordingError, match=r"wave/meta/episodes.jsonl line 3: length: episode 2 has 50 frames, "):
        read_lerobot_dataset(root, ARM_JOINTS, READING)


def test_a_dataset_without_pyarrow_names_the_install_command(tmp_path, simulated, monkeypatch):
    root = write_raw(tmp_path / "wave", "v3.0", simulated[:1])
    real_import = builtins.__import__

    def no_pyarrow(name, *args, **kwargs):
        if name.startswith("pyarrow"):
            raise ImportError(name)
        return real_import(name, *args, **kwargs)

    monkeypatch.setattr(builtins, "__import__", no_pyarrow)
    with pytest.raises(RecordingError, match=r"^wave: reading and writing LeRobot datasets needs pyarrow: "):
        read_lerobot_dataset(root, ARM_JOINTS, READING)
    with pytest.raises(RecordingError, match=r"pip install 'simtune\[lerobot\]'"):
        write_lerobot_dataset(tmp_path / "new", [], NAMES, FPS)


# --- task files -------------------------------------------------------------------------------------------------

TASK_ERRORS = {
    "both schedules": (
        'schedule_lerobot = "../recordings/wave"\n' + PHASES,
        "wave.toml: phases: give the schedule as phases, schedule_csv, schedule_lerobot: exactly one of them",
    ),
    "an episode without a dataset": (
        "schedule_episode = 1\n" + PHASES,
        "wave.toml: schedule_episode: names an episode of schedule_lerobot, which the file does not give",
    ),
    "an episode the dataset lacks": (
        'schedule_lerobot = "../recordings/wave"\nschedule_episode = 4',
        "wave.toml: schedule_lerobot: wave: schedule_episode: no episode 4 (the dataset's episodes: 0-1)",
    ),
    "a bad unit": (
        'schedule_lerobot = "../recordings/wave"\n[recordings]\nunits = "grad"\n[x]',
        "wave.toml: recordings.units: unknown angle unit 'grad' (known: deg, rad)",
    ),
    "a name mapped to no joint": (
        'schedule_lerobot = "../recordings/wave"\n[recordings.joints]\n"joint_3.pos" = "elbow"\n[x]',
        "wave.toml: schedule_lerobot: wave/meta/info.json: features.action.names[2]: 'joint_3.pos' is mapped to "
        "'elbow' by the task file's [recordings.joints], which is not a joint of the robot",
    ),
    "a dataset folder that is not one": (
        'schedule_lerobot = "../nowhere"',
        "wave.toml: schedule_lerobot: nowhere/meta/info.json: missing",
    ),
}


@pytest.mark.parametrize("case", sorted(TASK_ERRORS))
def test_task_file_errors_name_file_and_key(tmp_path, simulated, case):
    schedule, message = TASK_ERRORS[case]
    root = make_project(tmp_path / "proj", schedule=schedule)
    text = (root / "tasks" / "wave.toml").read_text()
    if "[x]" in schedule:  # the case's own [recordings] table replaces the template's
        text = text.replace('[recordings]\nunits = "deg"\n\n', "").replace("[x]\n", "")
    (root / "tasks" / "wave.toml").write_text(text)
    write_raw(root / "recordings" / "wave", "v3.0", simulated[:2])
    with pytest.raises(ProjectError) as info:
        load_project(root)
    assert message in str(info.value) and "\n" not in str(info.value)


def test_schedule_episode_and_a_start_pose_of_the_files_own(tmp_path, simulated):
    time, state, action = simulated[0]
    later = (time, state + 1.0, action + np.r_[[5.0] * 6, [0.0]])  # episode 1: every target 5 deg further
    root = make_project(
        tmp_path / "proj",
        schedule='schedule_lerobot = "../recordings/wave"\nschedule_episode = 1\nstart_pose_deg = [0, 0, 0, 0, 0, 2]',
    )
    write_raw(root / "recordings" / "wave", "v2.1", [simulated[0], later])
    task = load_project(root).task("wave")
    assert task.start_pose_deg == (0, 0, 0, 0, 0, 2)
    assert task.phases[0].targets_deg == pytest.approx((5, 5, 5, 5, 5, 5))
    assert task.phases[-1].start < DURATION
    assert task.lerobot == LeRobotReading(units="deg")


# --- the command line, end to end --------------------------------------------------------------------------------


@pytest.mark.slow  # about 15 s: synth, evaluate and tune in subprocesses
def test_cli_synth_lerobot_and_tune(tmp_path, simulated):
    root = make_project(tmp_path / "proj", schedule='schedule_lerobot = "../source"')
    write_raw(root / "source", "v2.1", simulated[:1])

    def simtune(*args) -> str:
        proc = subprocess.run(
            [sys.executable, "-m", "simtune.cli", *map(str, args)], capture_output=True, text=True, timeout=600
        )
        assert proc.returncode == 0, proc.stderr
        return proc.stdout

    out = simtune("synth", "--project", root, "--task", "wave", "--format", "lerobot", "--delay-s", "1.1",
                  "--repeats", "3", "--out", root / "recordings")  # fmt: skip
    assert "wave: 3 episodes of a LeRobot dataset in" in out
    check = subprocess.run([sys.executable, "-m", "simtune.cli", "check", root], capture_output=True, text=True)
    assert check.returncode == 0 and "3 recordings in" in check.stdout, check.stdout + check.stderr
    result = json.loads(simtune("tune", "--project", root, "--task", "wave", "--only", "command_delay",
                                "--max-evaluations", "40", "--quiet", "--json", "--out", tmp_path / "run"))  # fmt: skip
    best = json.loads((tmp_path / "run" / "best_params.json").read_text())["params"]
    assert best["command_delay"] == pytest.approx(1.1, abs=0.1)
    assert result["fitness"] < 0.2 * result["generic_fitness"]


def so101_urdf() -> Path:
    """The SO-101's URDF of the example-robot-data package (joints shoulder_pan ... wrist_roll, gripper)."""
    from importlib import metadata

    try:
        files = metadata.distribution("example-robot-data").files or []
    except metadata.PackageNotFoundError:
        pytest.skip("the SO-101 URDF comes with example-robot-data (pip install example-robot-data)")
    found = [f for f in files if f.name == "so101.urdf"]
    if not found:
        pytest.skip("example-robot-data holds no so101.urdf")
    return Path(str(found[0].locate()))


@pytest.mark.slow  # about 5 s (the URDF's meshes); test_synth_writes_a_dataset_that_tunes is its fast twin on the MICO
def test_so101_path_from_lerobot_actions_to_a_tuned_delay(tmp_path):
    """An SO-101 owner's path: LeRobot's names and degrees (gripper 0-100, a held joint here, left out), a task
    driven by a teleoperated episode's actions, recordings synthesised as a LeRobot dataset, tuned."""
    from simtune.studies.synth import make_synthetic
    from simtune.tasks.init_project import init_project

    root = tmp_path / "so101"
    init_project(so101_urdf(), root)
    time = np.arange(121) / FPS
    names = [f"{j}.pos" for j in ("shoulder_pan", "shoulder_lift", "elbow_flex", "wrist_flex", "wrist_roll")]
    action = np.zeros((len(time), 6))
    action[:, 0] = 30 * np.sin(2 * np.pi * time / 4)
    action[:, 1] = np.where(time >= 1.0, -25.0, 0.0)
    action[:, 3] = 20 * np.sin(2 * np.pi * time / 2)
    action[:, 5] = np.where(time >= 2.0, 80.0, 10.0)  # the gripper, percent open
    write_raw(root / "teleop", "v3.0", [(time, action, action)], names=[*names, "gripper.pos"])
    (root / "tasks" / "wave.toml").write_text(
        TASK.format(schedule='schedule_lerobot = "../teleop"', extra="").replace(
            "body = ", 'link = "gripper_link"\nbody = '
        )
    )
    (root / "simtune.toml").write_text(
        (root / "simtune.toml").read_text().replace('"tasks/reach.toml"', '"tasks/reach.toml", "tasks/wave.toml"')
    )
    make_synthetic("mujoco", "wave", root / "recordings", truth={"command_delay": 0.25}, repeats=2, fmt="lerobot",
                   project=root)  # fmt: skip
    info = json.loads((root / "recordings" / "wave" / "meta" / "info.json").read_text())
    assert info["features"]["observation.state"]["names"] == names
    tuned = st.tune(
        "mujoco", "wave", project=root, out=tmp_path / "run", only=["command_delay"], max_evaluations=30, seed=1
    )
    assert tuned.x["command_delay"] == pytest.approx(0.25, abs=0.06), tuned.x


def test_episodes_of_other_commanded_motions_are_never_averaged_into_one_reference(tmp_path, simulated):
    """Probe 5 #2: a dataset of different motions read as one task's repeats was averaged into one reference with
    only a clock warning. Repeats of one schedule, each started a frame or two apart, stay one task's."""
    episodes = [(t, s[:, :6], a[:, :6]) for t, s, a in simulated]
    late = episodes[1][2].copy()
    late[2:] = late[:-2]  # the same commands two frames later (a start jitter)
    same = write_lerobot_dataset(
        tmp_path / "same", [episodes[0], (episodes[1][0], episodes[1][1], late)], NAMES[:6], FPS
    )
    assert len(read_lerobot_dataset(same, ARM_JOINTS, LeRobotReading(units="deg"))) == 2
    other = episodes[2][2].copy()
    other[:, 0] += 15.0  # joint 1 commanded 15 deg elsewhere the whole episode: another motion
    mixed = write_lerobot_dataset(
        tmp_path / "mixed", [episodes[0], episodes[1], (episodes[2][0], episodes[2][1], other)], NAMES[:6], FPS
    )
    with pytest.raises(RecordingError, match=r"episodes 2 were commanded another motion than episode 0") as info:
        read_lerobot_dataset(mixed, ARM_JOINTS, LeRobotReading(units="deg"))
    assert "`[recordings] episodes = [0]`" in str(info.value) and "schedule_episode" in str(info.value)
    # the repeats named: read as the task's recordings
    assert len(read_lerobot_dataset(mixed, ARM_JOINTS, LeRobotReading(units="deg", episodes=(0, 1)))) == 2


@pytest.mark.parametrize(
    ("fps", "scale", "message"),
    [
        (30, 10.0, "steps 0.333333 s a frame (3 frames per second), but meta/info.json says fps 30"),
        (0, 1.0, "fps: 0 is not a frame rate"),
        (-30, 1.0, "fps: -30 is not a frame rate"),
        ("thirty", 1.0, 'fps: "thirty" is not a frame rate'),
        (300, 1.0, "(30 frames per second), but meta/info.json says fps 300"),
    ],
)
def test_timestamps_and_fps_that_disagree_are_one_line(tmp_path, simulated, fps, scale, message):
    """Probe 5 #15: timestamps 10 x too large (3 Hz where info.json says 30), and fps 0, -30, "thirty", 300, were
    read without a line: the schedule stretched 10 x."""
    t, s, a = simulated[0]
    root = write_raw(tmp_path / "d", "v3.0", [(t * scale, s, a)])
    info_path = root / "meta" / "info.json"
    info = json.loads(info_path.read_text())
    info["fps"] = fps
    info_path.write_text(json.dumps(info))
    with pytest.raises(RecordingError, match="^") as caught:
        read_lerobot_dataset(root, ARM_JOINTS, LeRobotReading(units="deg", undriven=("finger_joint_1",)))
    assert message in str(caught.value)
