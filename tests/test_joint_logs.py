"""Joint logs as recordings: CSV joint columns, ROS 2 bags and MCAP files, the joint term of the fitness."""

import json
import math
import subprocess
import sys
import warnings
from pathlib import Path

import numpy as np
import pytest

from simtune.data import Recording, load_recording, load_task_data, read_joint_bag, write_csv, write_joint_bag
from simtune.engines import Rollout
from simtune.errors import ConfigError, RecordingError
from simtune.fitness import JOINT_WEIGHT, FitnessWeights, Score, score_rollout
from simtune.robot.mico import ARM_JOINTS

pytest.importorskip("rosbags")

RATE = 100.0


def joint_recording(n: int = 301, joints=ARM_JOINTS, name: str = "r.csv", start: float = 0.0) -> Recording:
    """A joint log: each joint a slow sine of its own amplitude, well inside a turn."""
    t = start + np.arange(n) / RATE
    angles = {j: 0.3 * (k + 1) * np.sin(0.5 * t + k) for k, j in enumerate(joints)}
    return Recording(Path(name), t, joints=angles)


def assert_same_joints(a: Recording, b: Recording, tol: float = 1e-8) -> None:
    assert list(a.joints) == list(b.joints)
    np.testing.assert_allclose(a.time, b.time, atol=1e-9)
    for name in a.joints:
        np.testing.assert_allclose(a.joints[name], b.joints[name], atol=tol)


def cli(*args: str, capsys) -> tuple[int, str]:
    """Run the CLI in this process (the bad-input cases fail before any simulation): exit status and stderr."""
    from simtune.cli import main

    argv = sys.argv
    sys.argv = ["simtune", *args]
    try:
        with pytest.raises(SystemExit) as info:
            main()
    finally:
        sys.argv = argv
    return int(info.value.code or 0), capsys.readouterr().err


# --- CSV ------------------------------------------------------------------------------------------------------


@pytest.mark.parametrize("name", ["j.csv", "j.csv.gz"])
def test_csv_joint_log_round_trip(tmp_path: Path, name: str) -> None:
    rec = joint_recording(name=name)
    write_csv(tmp_path / name, rec)
    back = load_recording(tmp_path / name, joint_names=ARM_JOINTS)
    assert back.bodies == [] and back.lines is not None
    assert_same_joints(rec, back)


def test_csv_degrees_declared_in_the_header(tmp_path: Path) -> None:
    path = tmp_path / "deg.csv"
    path.write_text("time,joint_2 [deg],joint_1[rad]\n0.0,90,0.5\n0.01,-45.5,0.25\n")
    rec = load_recording(path)
    assert list(rec.joints) == ["joint_2", "joint_1"]
    np.testing.assert_allclose(rec.joints["joint_2"], [math.pi / 2, math.radians(-45.5)], rtol=1e-15)
    np.testing.assert_allclose(rec.joints["joint_1"], [0.5, 0.25])


def test_csv_markers_and_joints_in_one_file(tmp_path: Path) -> None:
    rec = joint_recording(n=50)
    n = len(rec)
    rec.positions["wrist"] = np.column_stack([np.linspace(0.1, 0.2, n), np.zeros(n), np.full(n, 0.5)])
    rec.rotations["wrist"] = np.tile(np.eye(3), (n, 1, 1))
    write_csv(tmp_path / "both.csv", rec)
    back = load_recording(tmp_path / "both.csv")
    assert back.bodies == ["wrist"]
    np.testing.assert_allclose(back.positions["wrist"], rec.positions["wrist"], atol=1e-6)
    assert_same_joints(rec, back)


# --- ROS 2 bags and MCAP ---------------------------------------------------------------------------------------


@pytest.mark.parametrize(("name", "storage"), [("j.mcap", "mcap"), ("bag_mcap", "mcap"), ("bag_db3", "sqlite3")])
def test_bag_round_trip(tmp_path: Path, name: str, storage: str) -> None:
    rec = joint_recording(start=12.5)
    written = write_joint_bag(tmp_path / name, rec, storage=storage)
    assert written == tmp_path / name and (written.is_file() == name.endswith(".mcap"))
    back = load_recording(written, joint_names=ARM_JOINTS)
    assert back.bodies == []
    assert_same_joints(rec, back, tol=0.0)  # float64 angles, nanosecond stamps


def write_messages(path: Path, messages, topic: str = "/joint_states", extra_topic: str | None = None) -> Path:
    """A rosbag2 folder (MCAP storage) of JointState messages (time [s], names, positions), as the test lays them."""
    from rosbags.rosbag2 import StoragePlugin, Writer
    from rosbags.typesys import Stores, get_typestore

    store = get_typestore(Stores.ROS2_HUMBLE)
    types = store.types
    state = "sensor_msgs/msg/JointState"
    with Writer(path, version=8, storage_plugin=StoragePlugin.MCAP) as writer:
        conns = [writer.add_connection(topic, state, typestore=store)]
        if extra_topic is not None:
            conns.append(writer.add_connection(extra_topic, state, typestore=store))
        for k, (t, names, positions) in enumerate(messages):
            ns = round(t * 1e9)
            msg = types[state](
                header=types["std_msgs/msg/Header"](
                    stamp=types["builtin_interfaces/msg/Time"](sec=ns // 10**9, nanosec=ns % 10**9), frame_id=""
                ),
                name=list(names),
                position=np.asarray(positions, dtype=float),
                velocity=np.zeros(0),
                effort=np.zeros(0),
            )
            for conn in conns:
                writer.write(conn, 10**9 + k, store.serialize_cdr(msg, state))
    return path


def test_bag_joints_matched_by_name_across_publishers(tmp_path: Path) -> None:
    # the message's name field decides: the order changes, and a second publisher logs joint_3 at other times
    messages = [
        (0.00, ["joint_1", "joint_2"], [0.1, 0.2]),
        (0.005, ["joint_3"], [1.0]),
        (0.01, ["joint_2", "joint_1"], [0.4, 0.3]),
        (0.015, ["joint_3"], [2.0]),
        (0.02, ["joint_1", "joint_2"], [0.5, 0.6]),
    ]
    rec = read_joint_bag(write_messages(tmp_path / "bag", messages))
    np.testing.assert_allclose(rec.time, [0.0, 0.005, 0.01, 0.015, 0.02])
    np.testing.assert_allclose(rec.joints["joint_1"], [0.1, 0.2, 0.3, 0.4, 0.5])
    np.testing.assert_allclose(rec.joints["joint_2"], [0.2, 0.3, 0.4, 0.5, 0.6])
    np.testing.assert_allclose(rec.joints["joint_3"], [1.0, 1.0, 1.5, 2.0, 2.0])  # ends held


def test_bag_topic_is_chosen_when_there_are_two(tmp_path: Path) -> None:
    messages = [(0.0, ["joint_1"], [0.1]), (0.01, ["joint_1"], [0.2])]
    bag = write_messages(tmp_path / "two", messages, topic="/arm/joint_states", extra_topic="/gripper/joint_states")
    with pytest.raises(RecordingError, match="several"):
        read_joint_bag(bag)
    rec = load_recording(bag, joint_topic="/arm/joint_states")
    np.testing.assert_allclose(rec.joints["joint_1"], [0.1, 0.2])
    with pytest.raises(RecordingError, match="no topic '/nope'"):
        read_joint_bag(bag, topic="/nope")


# --- task data and the fitness ------------------------------------------------------------------------------


def test_task_data_holds_the_mean_joint_trajectory_on_the_20_hz_grid(tmp_path: Path) -> None:
    folder = tmp_path / "single"
    folder.mkdir()
    t = np.arange(401) / RATE
    for k, offset in enumerate([0.0, 0.2]):
        # linear angles: resampling is exact, so the mean is the mean of the lines
        joints = {"joint_2": 0.1 * t + offset, "joint_5": -0.2 * t}
        write_csv(folder / f"r{k}.csv", Recording(Path("x"), t, joints=joints))
    td = load_task_data(folder, "single", wrist_body="RB1(Orange)", object_body="PCube", joint_names=ARM_JOINTS)
    assert td.wrist_mean is None and td.object_final is None and td.repeat_spread is None
    assert td.joint_names == ["joint_2", "joint_5"] and len(td.times) == 81
    assert td.joint_repeats is not None and td.joint_repeats.shape == (2, 81, 2)
    np.testing.assert_allclose(td.joint_mean, np.column_stack([0.1 * td.times + 0.1, -0.2 * td.times]), atol=1e-7)


def test_every_repeat_must_log_the_same_joints(tmp_path: Path) -> None:
    folder = tmp_path / "single"
    folder.mkdir()
    write_csv(folder / "a.csv", joint_recording(joints=("joint_1", "joint_2")))
    write_csv(folder / "b.csv", joint_recording(joints=("joint_1",)))
    with pytest.raises(RecordingError, match="b.csv: its joints differ from the first repeat's \\(lacks joint_2\\)"):
        load_task_data(folder, "single", wrist_body="w")


def joint_reference(joint_names, joint_mean, wrist=None):
    from simtune.data import TaskData

    n = len(joint_mean)
    return TaskData(
        task="t",
        rate=20.0,
        times=np.arange(n) / 20.0,
        wrist_mean=wrist,
        wrist_repeats=None if wrist is None else wrist[None],
        object_final=None,
        object_start=None,
        sources=[],
        joint_names=list(joint_names),
        joint_mean=np.asarray(joint_mean, dtype=float),
        joint_repeats=np.asarray(joint_mean, dtype=float)[None],
    )


def rollout_with(angles: np.ndarray, wrist: np.ndarray | None = None) -> Rollout:
    n = len(angles)
    wrist = np.zeros((n, 3)) if wrist is None else wrist
    return Rollout(np.arange(n) / 20.0, wrist, np.tile(np.eye(3), (n, 1, 1)), angles, None, True)


def test_joint_error_equals_the_hand_computation() -> None:
    # the log names joint_5 and joint_2 (in that order); the rollout has the arm's six columns
    q = np.zeros((3, 6))
    q[:, 1] = [0.1, 0.2, 0.3]  # joint_2
    q[:, 4] = [1.0, 1.0, 1.0]  # joint_5
    recorded = [[0.9, 0.15], [1.3, 0.2], [1.0, 0.0]]  # (joint_5, joint_2) per sample
    # |1.0-0.9| + |0.1-0.15| + |1.0-1.3| + |0.2-0.2| + |1.0-1.0| + |0.3-0.0| = 0.75 over 6 values
    score = score_rollout(
        rollout_with(q), joint_reference(["joint_5", "joint_2"], recorded), {}, joint_names=ARM_JOINTS
    )
    assert score.joint_error == pytest.approx(0.125, abs=1e-15)
    assert score.wrist_error is None and score.object_error is None
    assert score.fitness == pytest.approx(JOINT_WEIGHT * 0.125, abs=1e-15)


def test_weights_combine_the_parts_that_are_there() -> None:
    q = np.zeros((4, 6))
    recorded = np.full((4, 1), 0.2)
    wrist_rec = np.zeros((4, 3))
    wrist_sim = np.tile([0.03, 0.04, 0.0], (4, 1))  # 5 cm off at every sample
    ref = joint_reference(["joint_3"], recorded, wrist=wrist_rec)
    weights = FitnessWeights.parse("joint=0.1,wrist=2")
    s = score_rollout(rollout_with(q, wrist_sim), ref, {}, weights=weights, joint_names=ARM_JOINTS)
    assert s.wrist_error == pytest.approx(0.05) and s.joint_error == pytest.approx(0.2)
    assert s.fitness == pytest.approx(2 * 0.05 + 0.1 * 0.2)
    total = Score.combine([s, s])
    assert total.joint_error == pytest.approx(0.4) and total.wrist_error == pytest.approx(0.1)
    assert Score.from_dict(total.to_dict()) == total


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("jiont=0.1", "unknown weight 'jiont' (known: joint, wrist, object)"),
        ("joint=-1", "weight 'joint' must be a finite number of at least 0"),
        ("joint=abc", "weight 'joint' must be a finite number"),
        ("joint=nan", "weight 'joint' must be a finite number"),
        ("joint", "expected KEY=NUMBER items"),
        ("wrist=1,wrist=2", "weight 'wrist' given twice"),
        ("joint=0,wrist=0,object=0", "every weight is 0"),
    ],
)
def test_bad_weights_are_one_line_errors(text: str, message: str) -> None:
    with pytest.raises(ConfigError, match="^--weights: ") as info:
        FitnessWeights.parse(text)
    assert message in str(info.value)


# --- bad input: one line, exit status 2 -------------------------------------------------------------------------

GOOD_HEADER = "time,joint_1,joint_2"


def csv_case(text: str):
    return lambda path: (path / "single0001.csv").write_text(text)


def bag_case(messages, **kwargs):
    return lambda path: write_messages(path / "single0001", messages, **kwargs)


BAD_INPUTS = {
    "time backwards": (
        csv_case(f"{GOOD_HEADER}\n0.00,0.1,0.2\n0.02,0.1,0.2\n0.01,0.1,0.2\n"),
        "single/single0001.csv line 4: time check: the time goes backwards",
    ),
    "empty angle": (
        csv_case(f"{GOOD_HEADER}\n0.00,0.1,0.2\n0.01,,0.2\n"),
        "single/single0001.csv line 3, column 2: joint 'joint_1' has no angle",
    ),
    "nan angle": (
        csv_case(f"{GOOD_HEADER}\n0.00,0.1,0.2\n0.01,0.1,nan\n"),
        "single/single0001.csv line 3, column 3: joint 'joint_2' has no angle",
    ),
    "unknown joint": (
        csv_case("time,joint_1,elbow\n0.00,0.1,0.2\n0.01,0.1,0.2\n"),
        "single/single0001.csv line 1, column 3: unknown joint 'elbow' (the arm's joints: joint_1, joint_2",
    ),
    "degrees in a radian file": (
        csv_case(f"{GOOD_HEADER}\n0.00,0.1,45.0\n0.01,0.1,90.0\n"),
        "single/single0001.csv line 2, column 3: units check: joint 'joint_2' is 45 rad: looks like degrees: declare "
        "the unit in the header as 'joint_2 [deg]'",
    ),
    "unknown unit": (
        csv_case("time,joint_1 [grad]\n0.00,0.1\n0.01,0.1\n"),
        "single/single0001.csv line 1, column 2: unknown angle unit 'grad' for joint 'joint_1'",
    ),
    "text in a cell": (
        csv_case(f"{GOOD_HEADER}\n0.00,0.1,0.2\n0.01,0.1,x\n"),
        "single/single0001.csv line 3, column 3: 'x' is not a number",
    ),
    "bag nan": (
        bag_case([(0.0, ["joint_1"], [0.1]), (0.01, ["joint_1"], [float("nan")])]),
        "single/single0001 topic /joint_states message 2: joint 'joint_1' has no finite angle",
    ),
    "bag unknown joint": (
        bag_case([(0.0, ["joint_1", "gripper"], [0.1, 0.0])]),
        "single/single0001 topic /joint_states message 1: unknown joint 'gripper'",
    ),
    "bag degrees": (
        bag_case([(0.0, ["joint_1"], [0.1]), (0.01, ["joint_1"], [90.0])]),
        "message 2: units check: joint 'joint_1' is 90, beyond two turns: looks like degrees",
    ),
    "bag time backwards": (
        bag_case([(0.0, ["joint_1"], [0.1]), (0.02, ["joint_1"], [0.1]), (0.01, ["joint_1"], [0.1])]),
        "message 3: time check: the time goes backwards for joint 'joint_1'",
    ),
    "bag names and positions disagree": (
        bag_case([(0.0, ["joint_1", "joint_2"], [0.1])]),
        "message 1: 2 joint names but 1 positions",
    ),
    "bag without the chosen topic": (
        bag_case([(0.0, ["joint_1"], [0.1])], topic="/other"),
        "no topic '/joint_states' (its sensor_msgs/msg/JointState topics: /other)",
    ),
    "damaged mcap": (
        lambda path: (path / "single0001.mcap").write_bytes(b"\x89MCAP0\r\n" + b"\x00" * 40),
        "single/single0001.mcap: cannot read as a ROS 2 bag or MCAP file",
    ),
}


@pytest.mark.parametrize("case", sorted(BAD_INPUTS))
def test_bad_joint_logs_fail_with_one_line_and_exit_2(tmp_path: Path, case: str, capsys) -> None:
    write, message = BAD_INPUTS[case]
    (tmp_path / "single").mkdir()
    write(tmp_path / "single")
    args = ["evaluate", "--engine", "mujoco", "--task", "single", "--data", str(tmp_path)]
    if case == "bag without the chosen topic":
        args += ["--joint-topic", "/joint_states"]
    code, err = cli(*args, capsys=capsys)
    assert code == 2
    assert err.startswith("error: ") and err.count("\n") == 1, err
    assert message in err, err


def test_bad_weights_on_the_command_line(tmp_path: Path, capsys) -> None:
    code, err = cli("evaluate", "--task", "cube", "--weights", "joint=0.1,wirst=1", capsys=capsys)
    assert code == 2 and err == "error: --weights: unknown weight 'wirst' (known: joint, wrist, object)\n"


def test_a_real_process_exits_2_with_one_line(tmp_path: Path) -> None:
    (tmp_path / "single").mkdir()
    (tmp_path / "single" / "r.csv").write_text(f"{GOOD_HEADER}\n0.00,0.1,0.2\n0.01,0.1,\n")
    proc = subprocess.run(
        [sys.executable, "-m", "simtune.cli", "evaluate", "--task", "single", "--data", str(tmp_path)],
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert proc.returncode == 2 and proc.stdout == ""
    message = "single/r.csv line 3, column 3: joint 'joint_2' has no angle (a joint log needs a value in every line)"
    assert proc.stderr == f"error: {message}\n"


# --- end to end ---------------------------------------------------------------------------------------------


@pytest.mark.slow
@pytest.mark.parametrize("fmt", ["joints-csv", "mcap"])
def test_tuning_on_a_synthetic_joint_log_beats_generic(tmp_path: Path, fmt: str) -> None:
    truth = tmp_path / "truth_in.json"
    truth.write_text(json.dumps({"command_delay": 1.2, "max_velocity_joint_2": 30.0, "max_velocity_joint_3": 15.0}))
    data = tmp_path / "data"

    def simtune(*args: str) -> str:
        proc = subprocess.run([sys.executable, "-m", "simtune.cli", *args], capture_output=True, text=True, timeout=600)
        assert proc.returncode == 0, proc.stderr
        return proc.stdout

    synth = ["synth", "--engine", "mujoco", "--task", "single", "--repeats", "4", "--format"]
    simtune(*synth, fmt, "--truth", str(truth), "--out", str(data))
    evaluate = ["evaluate", "--task", "single", "--json", "--params-file"]
    at_truth = json.loads(simtune(*evaluate, str(data / "truth.json"), "--data", str(data)))
    assert at_truth["wrist_error"] is None and at_truth["joint_error"] < 0.005
    tune = ["tune", "--engine", "mujoco", "--task", "single", "--max-evaluations", "60", "--quiet", "--json"]
    only = ["--only", "command_delay,max_velocity_joint_2,max_velocity_joint_3", "--weights", "joint=1"]
    result = json.loads(simtune(*tune, *only, "--data", str(data), "--out", str(tmp_path / "run")))
    assert result["joint_error"] is not None and result["wrist_error"] is None
    assert result["fitness"] == pytest.approx(result["joint_error"])  # --weights joint=1
    assert result["fitness"] < 0.25 * result["generic_fitness"]
    best = json.loads((tmp_path / "run" / "best_params.json").read_text())["params"]
    assert best["command_delay"] == pytest.approx(1.2, abs=0.15)


# --- C3D marker files ---------------------------------------------------------------------------------------


def write_c3d(path: Path, rec: Recording, units: str = "mm", seen=None) -> Path:
    """The recording's body positions as C3D points (float32, in ``units``); ``seen`` False marks lost frames."""
    c3d = pytest.importorskip("c3d")
    scale = {"mm": 1000.0, "m": 1.0}[units]
    writer = c3d.Writer(point_rate=float(round(1 / (rec.time[1] - rec.time[0]))), point_units=units)
    writer.set_point_labels(rec.bodies)
    frames = []
    for i in range(len(rec)):
        points = np.zeros((len(rec.bodies), 5), dtype=np.float32)
        for k, body in enumerate(rec.bodies):
            points[k, :3] = rec.positions[body][i] * scale
            if seen is not None and not seen[i]:
                points[k, 3] = -1.0
        frames.append((points, np.zeros((0, 1), dtype=np.float32)))
    writer.add_frames(frames)
    with open(path, "wb") as handle, warnings.catch_warnings():
        warnings.simplefilter("ignore")  # the library warns that the file has no analog channels
        writer.write(handle)
    return path


def test_c3d_points_read_as_bodies_in_metres(tmp_path: Path) -> None:
    from simtune.data import load_recording as load
    from simtune.reference import REFERENCE_DIR

    rec = load(sorted((REFERENCE_DIR / "cube").glob("*.tsv.gz"))[0])
    seen = np.ones(len(rec), dtype=bool)
    seen[5:8] = False
    back = load(write_c3d(tmp_path / "cube.c3d", rec, seen=seen))
    assert back.bodies == rec.bodies and back.joints == {}
    np.testing.assert_allclose(back.time, rec.time - rec.time[0], atol=1e-9)
    for body in rec.bodies:
        assert np.isnan(back.positions[body][5:8]).all() and np.isnan(back.rotations[body]).all()
        np.testing.assert_allclose(back.positions[body][seen], rec.positions[body][seen], atol=1e-6)


def test_c3d_task_data_matches_the_tsv_one(tmp_path: Path) -> None:
    from simtune.data import load_recording as load
    from simtune.reference import REFERENCE_DIR

    folder = tmp_path / "cube"
    folder.mkdir()
    for path in sorted((REFERENCE_DIR / "cube").glob("*.tsv.gz")):
        write_c3d(folder / path.name.replace(".tsv.gz", ".c3d"), load(path), units="m")
    kwargs = {"wrist_body": "RB1(Orange)", "object_body": "PCube", "duration_s": 20.0}
    ours = load_task_data(folder, "cube", **kwargs)
    tsv = load_task_data(REFERENCE_DIR / "cube", "cube", **kwargs)
    assert ours.wrist_mean is not None and tsv.wrist_mean is not None and ours.joint_mean is None
    np.testing.assert_allclose(ours.wrist_mean, tsv.wrist_mean, atol=1e-6)
    np.testing.assert_allclose(ours.object_final, tsv.object_final, atol=1e-6)


def test_bad_c3d_files_are_one_line_errors(tmp_path: Path) -> None:
    path = tmp_path / "bad.c3d"
    path.write_bytes(b"\x02P" + b"\x00" * 300)
    with pytest.raises(RecordingError, match="/bad.c3d: cannot read as a C3D file \\(") as info:
        load_recording(path)
    assert "\n" not in str(info.value)
    t = np.arange(20) / RATE
    far = Recording(Path("x"), t, {"wrist": np.tile([0.1, 20.0, 0.5], (20, 1))}, {"wrist": np.zeros((20, 3, 3))})
    with pytest.raises(RecordingError, match="far.c3d frame 1: units check: body 'wrist' is 20 m away"):
        load_recording(write_c3d(tmp_path / "far.c3d", far, units="m"))


# --- the objective on markers and joints together --------------------------------------------------------------


def test_motion_capture_fitness_is_the_plain_sum_to_the_last_digit() -> None:
    rng = np.random.default_rng(3)
    wrist, obj = rng.normal(size=(40, 3)), rng.normal(size=(40, 3))
    from simtune.data import TaskData

    ref = TaskData("t", 20.0, np.arange(40) / 20.0, wrist, wrist[None], obj[-1:] + 0.1, obj[:1], [])
    rollout = Rollout(np.arange(40) / 20.0, wrist + 0.01, np.tile(np.eye(3), (40, 1, 1)), np.zeros((40, 6)), obj)
    s = score_rollout(rollout, ref, {}, joint_names=ARM_JOINTS)
    assert s.joint_error is None
    assert s.fitness == s.wrist_error + s.object_error  # exactly: weights of 1 leave the sum alone


def test_residuals_weigh_markers_and_joints_like_the_fitness(tmp_path: Path) -> None:
    pytest.importorskip("mujoco")
    from simtune.fitness import marker_positions
    from simtune.objective import Objective, load_references
    from simtune.studies.synth import make_synthetic
    from simtune.tasks import parse_tasks

    make_synthetic("mujoco", "single", tmp_path, truth={"command_delay": 1.3}, repeats=2, fmt="csv")
    tasks = parse_tasks("single")
    refs = load_references(tmp_path, tasks)
    ref = refs["single"]
    assert ref.wrist_mean is not None and ref.joint_mean is not None and ref.joint_names == list(ARM_JOINTS)
    weights = FitnessWeights(joint=0.3, wrist=2.0)
    objective = Objective("mujoco", tasks, refs, weights=weights)
    residuals, score = objective.residuals_and_score({})
    n = len(ref.times)
    assert residuals.shape == (objective.residual_size,) == (3 * n + 6 * n,)
    rollout = objective.rollouts({})["single"]
    wrist_sq = np.mean(np.sum((marker_positions(rollout, {}) - ref.wrist_mean) ** 2, axis=1))
    joint_sq = np.mean((rollout.joint_angles - ref.joint_mean) ** 2)
    assert np.sum(residuals**2) == pytest.approx(2.0 * wrist_sq + 0.3 * joint_sq, rel=1e-12)
    assert score.fitness == pytest.approx(2.0 * score.wrist_error + 0.3 * score.joint_error, rel=1e-12)
    assert objective.score({}).fitness == score.fitness
    objective.close()


def test_the_python_api_takes_weights(tmp_path: Path) -> None:
    pytest.importorskip("mujoco")
    from simtune import api
    from simtune.studies.synth import make_synthetic

    make_synthetic("mujoco", "single", tmp_path, truth={"command_delay": 1.3}, repeats=2, fmt="joints-csv")
    one = api.evaluate("mujoco", "single", data=tmp_path, weights={"joint": 1.0})
    assert one.wrist_error is None and one.joint_error is not None and one.fitness == one.joint_error
    two = api.evaluate("mujoco", "single", data=tmp_path, weights="joint=2")
    assert two.fitness == pytest.approx(2 * one.joint_error, rel=1e-12)
    assert two.parts["single"].joint_error == one.joint_error
