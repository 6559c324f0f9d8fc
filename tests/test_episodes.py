"""Episodes as the unit of data: a LeRobot dataset of different motions (``simtune synth --episodes``) read by one
task file (``schedule_episode = "each"``) as one task per episode, tuned together with one command delay."""

import json
import math
from pathlib import Path

import numpy as np
import pytest
from conftest import cli_in_process

import simtune.api as st
from simtune.data import LeRobotReading, read_lerobot_dataset
from simtune.data.lerobot import episode_indices, read_lerobot_actions
from simtune.errors import ConfigError, ProjectError
from simtune.project import load_project
from simtune.robot.mico import ARM_JOINTS
from simtune.run_config import RunConfig
from simtune.run_plan import plan_run
from simtune.tasks.episodes import check_stream

pytest.importorskip("pyarrow")

TRUE_DELAY = 0.3
EPISODES = 3

WAVE = """\
name = "wave"
duration = 4.0
start_pose_deg = [0, 0, 0, 0, 0, 0]

[[phases]]
start = 0.5
targets_deg = [10, -20, 10, 0, 0, 0]

[recordings]
units = "deg"

[controller]
gain = 10.0
max_velocity_deg = 40.0

[mocap]
body = "hand"
"""

TRAIN = """\
name = "train"
description = "teleoperated moves"
duration = 4.0
schedule_lerobot = "../recordings/wave"
schedule_episode = "each"

[recordings]
folder = "recordings/wave"  # relative to the project
units = "deg"
{extra}
[controller]
gain = 10.0
max_velocity_deg = 40.0

[mocap]
body = "hand"
"""


def write_project(root: Path, extra: str = "", groups: str = "") -> Path:
    """A MICO project: ``wave`` (a stand-in whose robot, start and controller the episodes keep) and ``train``,
    every episode of ``recordings/wave``."""
    (root / "tasks").mkdir(parents=True, exist_ok=True)
    (root / "tasks" / "wave.toml").write_text(WAVE)
    (root / "tasks" / "train.toml").write_text(TRAIN.format(extra=extra))
    (root / "simtune.toml").write_text(
        f'robot = "mico"\ntasks = ["tasks/wave.toml", "tasks/train.toml"]\ndata = "recordings"\n{groups}'
    )
    return root


@pytest.fixture(scope="module")
def dataset(tmp_path_factory) -> Path:
    """A MICO project whose ``recordings/wave`` holds EPISODES different episodes, synthesised by MuJoCo with a
    command delay of TRUE_DELAY (``simtune synth --format lerobot --episodes``)."""
    root = tmp_path_factory.mktemp("episodes") / "arm"
    (root / "tasks").mkdir(parents=True)
    (root / "tasks" / "wave.toml").write_text(WAVE)
    (root / "simtune.toml").write_text('robot = "mico"\ntasks = ["tasks/wave.toml"]\ndata = "recordings"\n')
    st.synth(
        "mujoco", "wave", out=root / "recordings", project=root, delay_s=TRUE_DELAY, fmt="lerobot", episodes=EPISODES
    )
    return root


def test_synth_writes_different_episodes_within_the_robots_limits(dataset):
    folder = dataset / "recordings" / "wave"
    assert episode_indices(folder) == list(range(EPISODES))
    reading = LeRobotReading(units="deg")
    actions = [read_lerobot_actions(folder, k, ARM_JOINTS, reading) for k in range(EPISODES)]
    streams = [np.column_stack([a.targets[j] for j in ARM_JOINTS]) for a in actions]
    assert all(not np.allclose(streams[0], s) for s in streams[1:])  # each its own motion
    wave = load_project(dataset).task("wave")
    for a in actions:  # what synth checked on writing, checked again as read back
        check_stream(wave, _phases(a))
    # read as one task's repeats they are refused: they were commanded different motions
    with pytest.raises(Exception, match="commanded another motion"):
        read_lerobot_dataset(folder, ARM_JOINTS, reading)
    truth = json.loads((dataset / "recordings" / "truth.json").read_text())
    assert truth["params"]["command_delay"] == TRUE_DELAY and truth["episodes"] == EPISODES


def _phases(actions):
    from simtune.tasks.spec import Phase

    rows = np.degrees(np.column_stack([actions.targets[j] for j in ARM_JOINTS]))
    return [Phase(float(t), tuple(map(float, r))) for t, r in zip(actions.time - actions.time[0], rows)]


def test_each_reads_one_task_per_episode_grouped_under_the_files_name(dataset, tmp_path):
    root = write_project(tmp_path / "arm")
    (root / "recordings").symlink_to(dataset / "recordings")
    project = load_project(root)
    names = [f"train.ep{k}" for k in range(EPISODES)]
    assert [n for n in project.tasks if n.startswith("train")] == names
    assert project.groups["train"] == tuple(names)
    assert [t.name for t in project.parse_tasks("train")] == names
    folder = str((root / "recordings" / "wave").resolve())
    for k, name in enumerate(names):
        task = project.task(name)
        assert task.lerobot is not None and task.lerobot.episodes == (k,)
        assert task.recordings == folder and task.shared_clock and task.episode_of == "train"
        assert task.description == f"episode {k} of train: teleoperated moves"
        commanded = read_lerobot_actions(folder, k, ARM_JOINTS, LeRobotReading(units="deg"))
        first = [commanded.targets[j][0] for j in ARM_JOINTS]
        assert task.phases[0].targets_deg == pytest.approx(np.degrees(first))
    # each task its own schedule, and the recordings of its own episode only
    assert project.task(names[0]).phases != project.task(names[1]).phases
    # the set-points at their frames' times, not at LeRobot's float32 timestamps (0.1 s stored as 0.10000000149 s):
    # a target switching a hair after the controller's tick on a frame time would lag it by a frame there
    starts = [p.start for p in project.task(names[0]).phases]
    assert starts == [k / 30 for k in range(len(starts))]


def test_a_list_of_episodes_and_a_project_group_of_an_episode_file(dataset, tmp_path):
    root = write_project(tmp_path / "arm", extra="episodes = [2, 0]\n", groups='[groups]\nall = ["wave", "train"]\n')
    (root / "recordings").symlink_to(dataset / "recordings")
    project = load_project(root)
    assert project.groups["train"] == ("train.ep2", "train.ep0")
    assert project.groups["all"] == ("wave", "train.ep2", "train.ep0")


def test_episodes_tuned_together_share_one_delay_that_tuning_recovers(dataset, tmp_path):
    root = write_project(tmp_path / "arm")
    (root / "recordings").symlink_to(dataset / "recordings")
    plan = plan_run(RunConfig(tasks="train", project=str(root / "simtune.toml"), only=["command_delay"]))
    assert plan.full_space.names == ["command_delay"]  # one, the robot's: commands and states on one clock
    # a task whose capture started on its own keeps its own delay beside the shared one
    mixed = plan_run(RunConfig(tasks="wave,train", project=str(root / "simtune.toml"), only=["command_delay"]))
    assert mixed.full_space.names == ["command_delay_wave", "command_delay"]
    tuned = st.tune("mujoco", "train", project=root, out=tmp_path / "run", only=["command_delay"], seed=0)
    assert tuned.x["command_delay"] == pytest.approx(TRUE_DELAY, abs=0.01), tuned.x
    assert set(tuned.parts) == {f"train.ep{k}" for k in range(EPISODES)}


BAD = {  # case: (text of the good file, its replacement, the message)
    "not a number": (
        'schedule_episode = "each"',
        'schedule_episode = "every"',
        r'schedule_episode: expected an episode number \(0 or more\) or "each"',
    ),
    "no dataset": (
        'schedule_lerobot = "../recordings/wave"\n',
        "",
        r"schedule_episode: names an episode of schedule_lerobot",
    ),
    "missing episode": (
        'units = "deg"',
        'units = "deg"\nepisodes = [0, 9]',
        r"recordings.episodes: no episode 9 in ../recordings/wave \(the dataset's episodes: 0-2\)",
    ),
    "unknown clock": (
        'units = "deg"',
        'units = "deg"\nclock = "gps"',
        r"recordings.clock: expected one of 'shared', 'own', got 'gps'",
    ),
}


@pytest.mark.parametrize("case", sorted(BAD))
def test_bad_episode_files_are_one_line_naming_file_and_key(dataset, tmp_path, case):
    old, new, message = BAD[case]
    root = write_project(tmp_path / "arm")
    (root / "recordings").symlink_to(dataset / "recordings")
    path = root / "tasks" / "train.toml"
    text = path.read_text()
    assert old in text
    path.write_text(text.replace(old, new, 1))
    with pytest.raises(ProjectError, match=message) as info:
        load_project(root)
    assert str(path) in str(info.value) and "\n" not in str(info.value)


def test_a_stated_own_clock_keeps_each_episodes_delay(dataset, tmp_path):
    root = write_project(tmp_path / "arm", extra='clock = "own"\n')
    (root / "recordings").symlink_to(dataset / "recordings")
    plan = plan_run(RunConfig(tasks="train", project=str(root / "simtune.toml"), only=["command_delay"]))
    assert plan.full_space.names == [f"command_delay_train.ep{k}" for k in range(EPISODES)]


def test_synth_episodes_out_of_range_or_in_a_format_of_repeats(dataset, tmp_path):
    with pytest.raises(
        ConfigError, match=r"^episodes: format 'tsv' holds repeats, not different episodes: choose one of lerobot"
    ):
        st.synth("mujoco", "wave", out=tmp_path / "a", project=dataset, episodes=3)
    with pytest.raises(ConfigError, match=r"^episodes must be an integer from 1 to 1000, got 0"):
        st.synth("mujoco", "wave", out=tmp_path / "b", project=dataset, fmt="lerobot", episodes=0)


# --- simtune init --dataset --------------------------------------------------------------------------------------

ARM_URDF = """\
<robot name="arm">
  <link name="base">
    <inertial><mass value="2"/><inertia ixx="0.01" iyy="0.01" izz="0.01" ixy="0" ixz="0" iyz="0"/></inertial>
  </link>
  <link name="upper">
    <inertial><mass value="1"/><inertia ixx="0.01" iyy="0.01" izz="0.01" ixy="0" ixz="0" iyz="0"/></inertial>
    <collision><origin xyz="0 0 0.15"/><geometry><box size="0.05 0.05 0.3"/></geometry></collision>
  </link>
  <link name="hand">
    <inertial><mass value="0.5"/><inertia ixx="0.001" iyy="0.001" izz="0.001" ixy="0" ixz="0" iyz="0"/></inertial>
    <collision><geometry><box size="0.05 0.05 0.05"/></geometry></collision>
  </link>
  <joint name="shoulder" type="revolute">
    <parent link="base"/><child link="upper"/><origin xyz="0 0 0.5"/><axis xyz="0 1 0"/>
    <limit lower="-1.5" upper="1.5" effort="20" velocity="2"/>
  </joint>
  <joint name="elbow" type="revolute">
    <parent link="upper"/><child link="hand"/><origin xyz="0 0 0.3"/><axis xyz="0 1 0"/>
    <limit lower="-1.5" upper="1.5" effort="20" velocity="2"/>
  </joint>
</robot>
"""


def teleop_dataset(root: Path, unit: str = "deg", names=("shoulder.pos", "elbow.pos"), lengths=(4.0, 3.7, 5.0)):
    """A LeRobot dataset of different episodes of the two-joint arm (30 fps), its angles in ``unit``."""
    from simtune.data import write_lerobot_dataset

    episodes = []
    for k, length in enumerate(lengths):
        time = np.arange(int(length * 30)) / 30
        action = np.column_stack([0.4 * np.sin(time * (1 + k)), -0.3 * np.sin(time * (2 + k))])  # [rad]
        action = np.degrees(action) if unit == "deg" else action
        episodes.append((time, action, action))
    return write_lerobot_dataset(root, episodes, list(names), 30)


def test_init_from_a_dataset_writes_one_task_file_for_every_episode(tmp_path):
    (tmp_path / "arm.urdf").write_text(ARM_URDF)
    data = teleop_dataset(tmp_path / "teleop")
    made: list = []
    file = st.init_project(tmp_path / "arm.urdf", tmp_path / "proj", dataset=data, made=made)
    (task,) = made
    assert (task.name, task.episodes, task.units, task.joints) == ("teleop", 3, "deg", ("shoulder", "elbow"))
    assert task.duration_s == 3.5  # the shortest episode, 3.7 s, rounded down to half a second
    project = load_project(file.parent)
    assert list(project.tasks) == ["teleop.ep0", "teleop.ep1", "teleop.ep2"]
    text = (file.parent / "tasks" / "teleop.toml").read_text()
    assert 'schedule_lerobot = "../../teleop"' in text and 'folder = "../teleop"' in text
    for k in range(3):
        assert project.task(f"teleop.ep{k}").shared_clock
    # the clamp is above what the episodes command (0.4 rad/s x 3 at most)
    assert project.task("teleop.ep0").max_velocity_deg > math.degrees(0.4 * 3)


def test_init_from_a_dataset_in_radians_states_radians(tmp_path):
    (tmp_path / "arm.urdf").write_text(ARM_URDF)
    made: list = []
    st.init_project(tmp_path / "arm.urdf", tmp_path / "proj", dataset=teleop_dataset(tmp_path / "d", "rad"), made=made)
    assert made[0].units == "rad"


def test_init_from_a_dataset_with_names_of_no_joint_is_one_line_and_writes_nothing(tmp_path):
    (tmp_path / "arm.urdf").write_text(ARM_URDF)
    data = teleop_dataset(tmp_path / "d", names=("shoulder.pos", "Rotation"))
    with pytest.raises(ProjectError, match=r"features.action.names: 'Rotation' names no joint of arm") as info:
        st.init_project(tmp_path / "arm.urdf", tmp_path / "proj", dataset=data)
    assert "\n" not in str(info.value) and not (tmp_path / "proj").exists()
    with pytest.raises(ProjectError, match=r"--dataset: .*nowhere.*meta/info.json: missing"):
        st.init_project(tmp_path / "arm.urdf", tmp_path / "proj", dataset=tmp_path / "nowhere")


# --- tune --validate -----------------------------------------------------------------------------------------------


def test_validate_holds_the_last_episodes_out_and_scores_them_with_the_best(dataset, tmp_path, capsys):
    root = write_project(tmp_path / "arm")
    (root / "recordings").symlink_to(dataset / "recordings")
    run = tmp_path / "run"
    args = ["tune", "--project", str(root), "--task", "train", "--only", "command_delay", "--validate", "1"]
    code, text, err = cli_in_process(*args, "--seed", "0", "--out", str(run), "--json", "--quiet", capsys=capsys)
    assert code == 0, err
    payload = json.loads(text)
    validation = payload["validation"]
    assert validation["tasks"] == ["train.ep2"] and set(validation["parts"]) == {"train.ep2"}
    assert payload["validation_fitness"] == validation["fitness"] == validation["parts"]["train.ep2"]
    assert validation["fitted"] == pytest.approx(payload["fitness"] / 2)  # two tuned episodes, per task
    assert validation["clock_aligned"] == {}  # the shared delay applied: commands and states on one clock
    # the tuned delay is the robot's: the held-out episode scores as the tuned ones do
    assert validation["ratio"] < 1.5, validation
    result = st.read_run(run)
    assert set(result.parts) == {"train.ep0", "train.ep1"}  # tuned on those alone
    code, text, _ = cli_in_process("resume", str(run), capsys=capsys)
    text = " ".join(text.split())  # wrapped at the terminal's width
    assert code == 0 and "held out 1 task(s) (train.ep2): fitness" in text and "per tuned task (" in text
    assert result.validation == validation  # the API reads it back too
    page = st.report(run, tmp_path / "report").read_text()
    assert "train.ep2 (held out)" in page  # the report's headline shows it beside the tuned tasks


@pytest.mark.parametrize(
    ("validate", "message"),
    [
        ("3", r"--validate 3: holds out the last N of the 3 tasks named, N from 1 to 2"),
        ("0,1,2", r"--validate: holds out every task named"),
        ("7", r"--validate 7: holds out the last N"),
        ("train.ep9", r"--validate: 'train.ep9' is not one of the tasks named \(train.ep0, train.ep1, train.ep2\)"),
    ],
)
def test_validate_that_leaves_nothing_to_tune_or_names_no_task_is_one_line(
    dataset, tmp_path, capsys, validate, message
):
    import re

    root = write_project(tmp_path / "arm")
    (root / "recordings").symlink_to(dataset / "recordings")
    args = ["tune", "--project", str(root), "--task", "train", "--validate", validate, "--out", str(tmp_path / "r")]
    code, _, err = cli_in_process(*args, capsys=capsys)
    assert code == 2 and re.search(message, err), err
    assert len(err.strip().splitlines()) == 1 and not (tmp_path / "r").exists()


def test_validate_by_episode_number():
    from simtune.tasks import held_out
    from simtune.tasks.spec import Phase, TaskSpec

    tasks = [TaskSpec(f"t.ep{k}", "", 1.0, (Phase(0.0, (0.0,) * 6),), 10.0) for k in range(4)]
    train, held = held_out(tasks, "3, 1")
    assert [t.name for t in held] == ["t.ep1", "t.ep3"] and [t.name for t in train] == ["t.ep0", "t.ep2"]
    assert [t.name for t in held_out(tasks, "2")[1]] == ["t.ep2", "t.ep3"]
    assert held_out(tasks, "") == (tasks, [])


@pytest.mark.slow  # about a minute: 8 SO-101 episodes synthesised, a project from the dataset, tuned
def test_so101_from_a_dataset_of_different_episodes_to_one_delay_and_held_out_episodes(tmp_path):
    """Issue 70's journey: a dataset of different teleoperation-like episodes (synth --episodes, a known truth),
    a project started from it in one init, tuned by one command with episodes held out."""
    from test_lerobot import so101_urdf

    from simtune.tasks.init_project import init_project

    urdf = so101_urdf()
    stand_in = tmp_path / "so101"
    init_project(urdf, stand_in)  # its `reach`: the start pose and controller the drawn episodes keep
    reach = stand_in / "tasks" / "reach.toml"
    reach.write_text(reach.read_text().replace("[mocap]", '[recordings]\nunits = "deg"\n\n[mocap]'))
    truth = {"command_delay": 0.2, "kp_joint_2": 15.0}
    st.synth("mujoco", "reach", out=tmp_path / "data", project=stand_in, fmt="lerobot", episodes=8,
             truth=_truth_file(tmp_path, truth))  # fmt: skip
    made: list = []
    project = st.init_project(urdf, tmp_path / "proj", dataset=tmp_path / "data" / "reach", made=made)
    assert made[0].episodes == 8 and made[0].units == "deg"
    run = tmp_path / "run"
    st.tune("mujoco", "reach", project=project.parent, out=run, only=["command_delay", "kp_joint_2"], validate=2,
            workers=2, seed=0)  # fmt: skip
    tuned = st.read_run(run)
    assert tuned.x["command_delay"] == pytest.approx(0.2, abs=0.005), tuned.x
    assert tuned.x["kp_joint_2"] == pytest.approx(15.0, abs=0.05 * 39), tuned.x  # 5 % of its range, 1-40
    validation = tuned.validation
    assert validation is not None and validation["tasks"] == ["reach.ep6", "reach.ep7"]
    assert validation["ratio"] < 1.2, validation  # the held-out episodes within 20 % of the fitted score


def _truth_file(folder: Path, truth: dict) -> Path:
    path = folder / "truth.json"
    path.write_text(json.dumps(truth))
    return path
