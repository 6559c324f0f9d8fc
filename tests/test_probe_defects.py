"""Issue 31: no silent wrong answers on the newer surfaces: joint logs, weights, task files, synth, export, the API.

Every case is one that gave a wrong answer with exit status 0, lost data or ended in a traceback; each now
gives the right answer or one line naming what is wrong (``error: ...``, exit status 2).
"""

import contextlib
import json
import math
import os
import shutil
import subprocess
import tempfile
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, assume, given, settings
from hypothesis import strategies as hs
from test_joint_logs import cli  # the CLI in this process: exit status and stderr
from test_run_safety import held_elsewhere  # another process holds a run's lock meanwhile

import simtune.api as st
from simtune.data import LeRobotReading, Recording, write_csv, write_joint_bag
from simtune.engines import Rollout
from simtune.errors import ConfigError, ProjectError, RecordingError, RecordingWarning, SimtuneError
from simtune.fitness import score_rollout
from simtune.objective import load_task_recordings
from simtune.project import load_project
from simtune.robot.mico import ARM_JOINTS
from simtune.store import STORE_FILE, RunStore
from simtune.studies.synth import make_synthetic

pytest.importorskip("rosbags")


def one_line(code: int, err: str, *fragments: str) -> None:
    assert code == 2, err
    assert err.startswith("error: ") and err.count("\n") == 1 and "Traceback" not in err, err
    for fragment in fragments:
        assert fragment in err, err


@contextlib.contextmanager
def read_only(*paths: Path):
    """``paths`` cannot be written meanwhile: their write permission taken away, or for root (whom permissions do
    not stop) the file system's immutable attribute."""
    if os.geteuid() != 0:
        modes = [p.stat().st_mode for p in paths]
        for p in paths:
            p.chmod(p.stat().st_mode & 0o555)
        try:
            yield
        finally:
            for p, mode in zip(paths, modes):
                p.chmod(mode)
        return
    if shutil.which("chattr") is None:
        pytest.skip("root without chattr: cannot make a folder read-only")
    done = []
    try:
        for p in paths:
            if subprocess.run(["chattr", "+i", str(p)], capture_output=True).returncode != 0:
                pytest.skip("root on a file system without the immutable attribute: cannot make a folder read-only")
            done.append(p)
        yield
    finally:
        for p in done:
            subprocess.run(["chattr", "-i", str(p)], check=True)


# --- a small MICO project whose task moves little (a degrees log of it stays within two turns) -----------------

NUDGE = """\
name = "nudge"
duration = 4.0
start_pose_deg = [0, 0, 5, 0, 0, 0]
{extra}
[controller]
gain = 10.0

[mocap]
body = "wrist"

[[phases]]
start = 0.5
targets_deg = [0, -10, 5, 0, 0, 0]
"""


def nudge_project(root: Path, extra: str = "", data: str | None = "recordings") -> Path:
    (root / "tasks").mkdir(parents=True, exist_ok=True)
    (root / "tasks" / "nudge.toml").write_text(NUDGE.format(extra=extra))
    data_line = f'data = "{data}"\n' if data else ""
    (root / "simtune.toml").write_text(f'robot = "mico"\ntasks = ["tasks/nudge.toml"]\n{data_line}')
    return root


def followed(task, rate: float = 100.0) -> tuple[np.ndarray, np.ndarray]:
    """Times and joint angles [rad] (n, joints) of an arm that follows ``task``'s schedule with its clamped P law."""
    starts, table = task.schedule
    q = np.radians(table[0]).copy()
    n = int(round(task.duration * rate)) + 1
    out = np.empty((n, len(q)))
    v = np.zeros_like(q)
    vmax = np.radians(task.max_velocity_deg)
    per_update = int(round(rate / 20.0))
    for k in range(n):
        if k % per_update == 0:  # the controller's 20 Hz update
            target = np.radians(table[np.searchsorted(starts, k / rate, side="right")])
            v = np.clip(task.kp * (target - q), -vmax, vmax)
        out[k] = q
        q = q + v / rate
    return np.arange(n) / rate, out


def write_log(path: Path, times, angles, *, unit: str, column_unit: bool = False, fmt: str = "csv") -> Path:
    """Angles [rad] written in ``unit`` as a CSV (its columns declaring the unit with ``column_unit``) or MCAP."""
    values = np.degrees(angles) if unit == "deg" else np.asarray(angles)
    joints = {name: values[:, j] for j, name in enumerate(ARM_JOINTS)}
    if fmt == "mcap":
        return write_joint_bag(path.with_suffix(".mcap"), Recording(path, times, joints=joints))
    if not column_unit:
        write_csv(path.with_suffix(".csv"), Recording(path, times, joints=joints))
        return path.with_suffix(".csv")
    header = "time," + ",".join(f"{name} [{unit}]" for name in ARM_JOINTS)
    rows = [",".join([f"{t:.6f}", *(f"{v:.8f}" for v in row)]) for t, row in zip(times, values)]
    path.with_suffix(".csv").write_text("\n".join([header, *rows]) + "\n")
    return path.with_suffix(".csv")


def joint_error(task, data, angles20) -> float:
    """The joint error of a simulation that moved exactly as ``angles20`` (20 Hz) against the loaded recordings."""
    n = len(data.times)
    rollout = Rollout(data.times, np.zeros((n, 3)), np.tile(np.eye(3), (n, 1, 1)), angles20[:n], None, True)
    score = score_rollout(rollout, data, {}, joint_names=ARM_JOINTS)
    return float(score.joint_error)


# --- 1. a joint log in degrees read as radians ----------------------------------------------------------------


def test_a_degrees_log_within_two_turns_stops_naming_file_joint_and_units_key(tmp_path, capsys):
    root = nudge_project(tmp_path / "p")
    task = load_project(root).task("nudge")
    times, angles = followed(task)
    (root / "recordings" / "nudge").mkdir(parents=True)
    write_log(root / "recordings" / "nudge" / "nudge0001", times, angles, unit="deg")  # joint_2 reaches -10 "rad"
    assert np.abs(np.degrees(angles)).max() < 4 * np.pi  # within two turns: the old check let it through
    code, err = cli("evaluate", "--project", str(root), "--task", "nudge", capsys=capsys)
    one_line(code, err, "nudge/nudge0001.csv", "joint 'joint_2'", "limits", 'units = "deg"', "[recordings]")
    # simtune check calls it a problem, not a warning about the start pose
    from simtune.check.project import check_project

    problems = [f.message for f in check_project(root, engines=()) if f.level == "problem"]
    assert len(problems) == 1 and "units check" in problems[0] and "joint_2" in problems[0], problems


def test_declared_degrees_read_right(tmp_path):
    root = nudge_project(tmp_path / "p", extra='[recordings]\nunits = "deg"   # the logs are in degrees\n')
    task = load_project(root).task("nudge")
    times, angles = followed(task)
    folder = root / "recordings" / "nudge"
    folder.mkdir(parents=True)
    write_log(folder / "nudge0001", times, angles, unit="deg")
    write_log(folder / "nudge0002", times, angles, unit="deg", fmt="mcap")
    data = load_task_recordings(folder, task)
    assert len(data.sources) == 2 and joint_error(task, data, angles[::5]) < 1e-7


#: start poses and targets [deg] within the MICO's limits, some of them near zero (where the units are hardest
#: to tell apart)
ANGLE = hs.one_of(hs.floats(-130, 130), hs.floats(-2, 2), hs.just(0.0))
POSE = hs.lists(ANGLE, min_size=6, max_size=6)


@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(
    start=POSE,
    targets=hs.lists(POSE, min_size=1, max_size=2),
    gain=hs.floats(2.0, 20.0),
    unit=hs.sampled_from(["rad", "deg"]),
    declared=hs.sampled_from(["no", "task", "column"]),
    fmt=hs.sampled_from(["csv", "mcap"]),
)
def test_joint_log_units_are_right_or_refused_never_wrong(start, targets, gain, unit, declared, fmt):
    """A joint log in radians or degrees, its unit declared (the task's ``units`` key, a CSV column's ``[deg]``)
    or not: the joint error of the arm that made it is 0 (read right) or the log is refused, never wrong."""
    from simtune.tasks import get_task
    from simtune.tasks.spec import Phase

    # a log is told apart only where some joint starts or is driven at least this far from 0 (docs/recordings.md)
    assume(max(abs(a) for a in [*start, *(a for row in targets for a in row)]) >= 0.5)
    assume(not (declared == "column" and fmt == "mcap"))  # a bag has no columns to declare
    phases = tuple(Phase(0.5 + 1.5 * k, tuple(row)) for k, row in enumerate(targets))
    stated = LeRobotReading(units=unit) if declared == "task" else None  # the task file's [recordings] units
    task = replace(get_task("single"), start_pose_deg=tuple(start), phases=phases, kp=gain, lerobot=stated)
    times, angles = followed(task)
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp) / task.name
        folder.mkdir()
        write_log(folder / "single0001", times, angles, unit=unit, column_unit=declared == "column", fmt=fmt)
        try:
            data = load_task_recordings(folder, task)
        except RecordingError as exc:
            assert unit == "deg" and declared == "no", f"a right log was refused: {exc}"
            assert "units check" in str(exc)
            return
    assert joint_error(task, data, angles[::5]) < 1e-6, f"{unit} log, declared {declared}: read wrong, not refused"


# --- 2. a rosbag2 folder without metadata.yaml ----------------------------------------------------------------


@pytest.mark.parametrize("storage", ["sqlite3", "mcap"])
def test_a_rosbag2_folder_without_metadata_is_read(tmp_path, storage):
    from simtune.tasks import get_task

    task = get_task("single")
    times, angles = followed(task)
    for name in ("single0001", "single0002"):
        joints = {j: angles[:, k] for k, j in enumerate(ARM_JOINTS)}
        write_joint_bag(tmp_path / "single" / name, Recording(Path(name), times, joints=joints), storage=storage)
    (tmp_path / "single" / "single0002" / "metadata.yaml").unlink()  # what a killed `ros2 bag record` leaves
    data = load_task_recordings(tmp_path / "single", task)
    assert [p.name for p in data.sources] == ["single0001", "single0002"]
    assert joint_error(task, data, angles[::5]) < 1e-9


def test_an_unreadable_rosbag2_folder_without_metadata_is_warned_about_by_name(tmp_path):
    from simtune.tasks import get_task

    task = get_task("single")
    times, angles = followed(task)
    joints = {j: angles[:, k] for k, j in enumerate(ARM_JOINTS)}
    for name in ("single0001", "single0002"):
        write_joint_bag(tmp_path / "single" / name, Recording(Path(name), times, joints=joints), storage="mcap")
    killed = tmp_path / "single" / "single0002"
    (killed / "metadata.yaml").unlink()
    (inner,) = killed.glob("*.mcap")
    inner.write_bytes(inner.read_bytes()[:-300])  # the writer never wrote its summary and footer
    with pytest.warns(RecordingWarning, match="single/single0002: .*no metadata.yaml.*left out"):
        data = load_task_recordings(tmp_path / "single", task)
    assert [p.name for p in data.sources] == ["single0001"]


# --- 3. weights that weigh nothing the recordings hold --------------------------------------------------------


def test_weights_zeroing_every_recorded_part_are_refused(tmp_path, capsys):
    with pytest.raises(ConfigError, match="weights: .*nothing the recordings hold"):
        st.evaluate("mujoco", "cube", weights={"wrist": 0, "object": 0})
    code, err = cli("evaluate", "--task", "cube", "--weights", "wrist=0,object=0", capsys=capsys)
    one_line(code, err, "--weights", "wrist", "object")
    code, err = cli("tune", "--task", "cube", "--weights", "wrist=0,object=0", "--out", str(tmp_path), capsys=capsys)
    one_line(code, err, "--weights")
    assert list(tmp_path.iterdir()) == []


def test_weights_are_refused_before_the_inactive_parameters_are_probed(tmp_path, capsys, monkeypatch):
    """The probe costs a fresh machine tens of seconds of rollouts (its cache is empty): a refusal that needs only
    the recordings comes first."""
    import simtune.run_plan

    def probe(*args, **kwargs):
        raise AssertionError("the inactive parameters were probed before the weights were checked")

    monkeypatch.setattr(simtune.run_plan, "inactive_parameters", probe)
    code, err = cli("tune", "--task", "cube", "--weights", "wrist=0,object=0", "--out", str(tmp_path), capsys=capsys)
    one_line(code, err, "--weights")


# --- 4. YAML task files: duplicate keys, YAML 1.2 numbers -------------------------------------------------------

YAML_TASK = """\
name: nudge
duration: {duration}
controller: {{gain: 10.0}}
mocap: {{body: wrist}}
phases:
  - {{start: 0.0, targets_deg: [0, -10, 5, 0, 0, 0]}}
{more}"""


def yaml_project(root: Path, duration: str = "8.0", more: str = "") -> Path:
    (root / "tasks").mkdir(parents=True)
    (root / "tasks" / "nudge.yaml").write_text(YAML_TASK.format(duration=duration, more=more))
    (root / "simtune.toml").write_text('robot = "mico"\ntasks = ["tasks/nudge.yaml"]\n')
    return root


def test_duplicate_yaml_keys_are_refused_naming_file_key_and_line(tmp_path):
    root = yaml_project(tmp_path, more="duration: 2.0\n")
    with pytest.raises(ProjectError, match=r"nudge.yaml: not valid YAML: key 'duration' appears twice \(line 7"):
        load_project(root)


def test_yaml_12_numbers_are_numbers(tmp_path):
    for text, value in [("8e0", 8.0), ("1.5e1", 15.0), ("2E+0", 2.0), ("8", 8.0)]:
        root = yaml_project(tmp_path / text, duration=text)
        assert load_project(root).task("nudge").duration == value


# --- 5. options that were silently ignored ------------------------------------------------------------------------


@pytest.mark.parametrize("command", ["tune", "grid", "compare", "transfer", "sensitivity"])
def test_only_without_a_parameter_name_is_refused(command, tmp_path, capsys):
    code, err = cli(command, "--only", " , ", "--out", str(tmp_path / "out"), capsys=capsys)
    one_line(code, err, "--only", "no parameter")
    assert list(tmp_path.iterdir()) == []


def test_start_from_recordings_with_joint_logs_is_refused(tmp_path):
    obj = (
        'start_from_recordings = true\n\n[object]\nshape = "cube"\nmaterial = "plastic"\nmass = 0.1\n'
        'size = [0.05, 0.05, 0.05]\nxy = [0.5, 0.0]\nmocap_body = "box"\n'
    )
    root = nudge_project(tmp_path / "p", extra=obj)
    task = load_project(root).task("nudge")
    times, angles = followed(task)
    folder = root / "recordings" / "nudge"
    folder.mkdir(parents=True)
    write_log(folder / "nudge0001", times, angles, unit="rad")
    with pytest.raises(SimtuneError, match="start_from_recordings = true.*joint logs.*'box'"):
        st.evaluate("mujoco", "nudge", project=root)


def test_align_clock_of_an_unknown_task_is_refused():
    with pytest.raises(ConfigError, match="align_clock: unknown task 'nope'"):
        st.evaluate("mujoco", "cube", align_clock=["nope"])
    with pytest.raises(ConfigError, match="align_clock: expected True, False or task names"):
        st.evaluate("mujoco", "cube", align_clock=3)


def test_a_group_name_that_cannot_be_selected_is_refused(tmp_path):
    root = nudge_project(tmp_path)
    with open(root / "simtune.toml", "a") as fh:
        fh.write('[groups]\n"a,b" = ["nudge"]\n')
    with pytest.raises(ProjectError, match=r"simtune.toml: groups.a,b: 'a,b' cannot name a group"):
        load_project(root)


# --- 6. synth into a folder that holds another task's truth -------------------------------------------------------


def test_synth_keeps_one_truth_per_task_and_never_overwrites_one_without_force(tmp_path):
    make_synthetic("mujoco", "single", tmp_path, truth={"command_delay": 1.0}, repeats=1)
    make_synthetic("mujoco", "double", tmp_path, truth={"command_delay": 1.0}, repeats=1)  # the README's flow

    def read(name: str) -> dict:
        return json.loads((tmp_path / name).read_text())

    assert read("truth-single.json")["params"] == read("truth-double.json")["params"] == {"command_delay": 1.0}
    assert read("truth.json")["tasks"] == ["single", "double"]  # one truth for both: still a --params-file
    with pytest.raises(SimtuneError, match="truth.json holds another truth.*--force"):
        make_synthetic("mujoco", "seed-9", tmp_path, truth={"command_delay": 0.5}, repeats=1)
    assert not (tmp_path / "seed-9").exists() and read("truth.json")["tasks"] == ["single", "double"]
    make_synthetic("mujoco", "seed-9", tmp_path, truth={"command_delay": 0.5}, repeats=1, force=True)
    assert read("truth.json")["params"] == read("truth-seed-9.json")["params"] == {"command_delay": 0.5}
    assert read("truth-single.json")["params"] == {"command_delay": 1.0}  # the earlier tasks keep theirs


# --- a finished run to export, resume and read ---------------------------------------------------------------------


@pytest.fixture(scope="module")
def finished_run(tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("run") / "run"
    tuned = st.tune("mujoco", "cube", out=out, only="command_delay", max_evaluations=1, optimizer="random")
    assert list(tuned.x) == ["command_delay"]  # 8. a string names one parameter, not its letters
    return out


def copy_run(run_dir: Path, to: Path) -> Path:
    shutil.copytree(run_dir, to)
    return to


# --- 7. export into a read-only folder ----------------------------------------------------------------------------


def test_export_into_a_read_only_folder_is_one_line(finished_run, tmp_path, capsys):
    out = tmp_path / "out"
    out.mkdir()
    with read_only(out):
        code, err = cli("export", str(finished_run), "--out", str(out), capsys=capsys)
    one_line(code, err, f"cannot write the export into {out}")
    assert cli("export", str(finished_run), "--out", str(out), capsys=capsys)[0] == 0
    written = sorted(p.name for p in out.iterdir())
    with read_only(out):  # --force removes the previous export first
        code, err = cli("export", str(finished_run), "--out", str(out), "--force", capsys=capsys)
    one_line(code, err, f"cannot write the export into {out}")
    assert sorted(p.name for p in out.iterdir()) == written


# --- 8. the Python API: SimtuneError for bad arguments, the natural types accepted ----------------------------------


def test_api_arguments_of_the_wrong_type_are_simtune_errors(finished_run, tmp_path):
    assert st.evaluate("mujoco", ["cube"]).fitness == st.evaluate("mujoco", "cube").fitness  # a list of task names
    cases = [
        (lambda: st.evaluate("mujoco", "cube", project=5), "project: expected"),
        (lambda: st.evaluate("mujoco", "cube", data=5), "data: expected"),
        (lambda: st.evaluate("mujoco", "cube", weights=[1, 2]), "weights: expected"),
        (lambda: st.evaluate("mujoco", "cube", params={1: 1.0}), "params: expected"),
        (lambda: st.evaluate("mujoco", 5), "tasks: expected"),
        (lambda: st.tune("mujoco", "cube", out=None), "out: expected"),
        (lambda: st.tune("mujoco", "cube", out=tmp_path / "x", only=5), "only: expected"),
    ]
    for call, message in cases:
        with pytest.raises(SimtuneError, match=message):
            call()
    damaged = copy_run(finished_run, tmp_path / "damaged")
    (damaged / STORE_FILE).write_bytes(b"SQLite format 3\x00" + b"\x13" * 4000)
    with pytest.raises(SimtuneError, match="run.sqlite"):
        st.read_run(damaged)


# --- 9. a relative --data --------------------------------------------------------------------------------------------


def test_a_relative_data_folder_is_stored_absolute(tmp_path, monkeypatch, capsys):
    (tmp_path / "data").mkdir()
    monkeypatch.chdir(tmp_path)
    configs = []

    def started(config, run_dir, show_progress=True):  # the run as it would be stored; nothing simulated
        configs.append(config)
        raise SimtuneError("stop")

    monkeypatch.setattr("simtune.runs.start_run", started)
    monkeypatch.setattr("simtune.api.start_run", started)
    assert cli("tune", "--task", "cube", "--data", "data", "--out", "run", capsys=capsys) == (2, "error: stop\n")
    with pytest.raises(SimtuneError, match="stop"):
        st.tune("mujoco", "cube", data="data", out="run")
    assert [c.data for c in configs] == [str(tmp_path / "data")] * 2  # resume, uncertainty, export: any folder


def test_a_data_folder_that_has_gone_is_named(finished_run, tmp_path, capsys):
    run = copy_run(finished_run, tmp_path / "run")
    store = RunStore(run)
    store.set(config={**store.get("config"), "data": str(tmp_path / "moved")})
    store.close()
    for command in ("resume", "uncertainty"):  # not "cube/cube0001.tsv removed and 2 more"
        code, err = cli(command, str(run), capsys=capsys)
        one_line(code, err, f"data folder {tmp_path / 'moved'} was not found")
    with pytest.warns(UserWarning, match="data folder .* not found: controller.yaml gives no sample counts"):
        from simtune.export import export_run

        export_run(run, tmp_path / "exported")


# --- 10. messages that said the wrong thing ---------------------------------------------------------------------------


def test_synth_refuses_noise_and_jitter_its_recordings_cannot_hold(tmp_path, capsys):
    with pytest.raises(ConfigError, match="--noise-mm: 1e\\+06 mm"):
        make_synthetic("mujoco", "single", tmp_path, truth={}, noise_m=1000.0)
    with pytest.raises(ConfigError, match="--jitter-s: .*single lasts 6 s"):
        make_synthetic("mujoco", "single", tmp_path, truth={"command_delay": 1.5}, jitter_s=100.0)
    code, err = cli("synth", "--task", "single", "--joint-noise-deg", "1000", "--out", str(tmp_path), capsys=capsys)
    one_line(code, err, "--joint-noise-deg")
    assert list(tmp_path.iterdir()) == []


def test_an_empty_store_beside_other_files_suggests_a_new_folder(tmp_path, capsys):
    run = tmp_path / "run"
    run.mkdir()
    (run / STORE_FILE).write_bytes(b"")
    (run / "best_params.json").write_text("{}")
    for command in ("uncertainty", "resume"):
        code, err = cli(command, str(run), capsys=capsys)
        one_line(code, err, "never set up", "new folder")
        assert f"--out {run}`" not in err  # not the folder tune refuses


def test_export_names_an_unknown_engine(finished_run, tmp_path, capsys):
    code, err = cli("export", str(finished_run), "--engine", "foo", "--out", str(tmp_path / "x"), capsys=capsys)
    one_line(code, err, "unknown engine 'foo'")
    assert "tune foo" not in err


def test_export_of_a_run_being_tuned_says_so(finished_run, tmp_path, capsys):
    run = copy_run(finished_run, tmp_path / "run")
    RunStore(run).set(status="running")
    with held_elsewhere(run) as pid:
        code, err = cli("export", str(run), "--out", str(tmp_path / "x"), capsys=capsys)
    one_line(code, err, f"process {pid}", "export it when it has finished")
    assert "simtune resume" not in err


def test_resume_of_a_read_only_run_says_so(finished_run, tmp_path, capsys):
    run = copy_run(finished_run, tmp_path / "run")
    with read_only(run, *run.iterdir()):
        for command in ("resume", "uncertainty"):
            code, err = cli(command, str(run), capsys=capsys)
            one_line(code, err, f"{run} is read-only", "copy")


def test_a_data_root_that_is_a_file_is_not_called_missing(tmp_path, capsys):
    root = nudge_project(tmp_path, data="simtune.toml")
    (problem,) = load_project(root).validate()[:1]
    assert "simtune.toml: data: " in problem and problem.endswith("simtune.toml is a file, not a folder of recordings")
    code, err = cli("evaluate", "--task", "cube", "--data", str(root / "simtune.toml"), capsys=capsys)
    one_line(code, err, "is a file, not a folder")
    assert "does not exist" not in err


def test_a_radians_log_whose_arm_overshoots_its_commands_is_not_called_degrees():
    """Read as degrees any log of small numbers fits the task's range; a log in radians whose arm overshoots what
    it was commanded (beyond the check's margin, as a synthetic arm with hidden servo gains did) is radians, since
    read as degrees it would barely move; a log in degrees that strays as far is still refused."""
    from simtune.data.sanity import JointRange, check_joint_units

    times = np.arange(200) / 20.0
    commanded = JointRange(0.0, math.radians(-30), math.radians(35), -2.9, 2.9)  # joint 5's in the drive problem
    angles = math.radians(35) * np.sin(times / 2.0)
    angles[100:140] = -math.radians(50.2)  # 20.2 deg past the -30 deg target
    log = Recording(Path("drive0001.csv"), times, joints={"joint_5": angles})
    check_joint_units(log, {"joint_5": commanded}, "drive/drive0001.csv")  # read right: no error
    in_degrees = Recording(Path("drive0001.csv"), times, joints={"joint_5": np.degrees(angles)})
    with pytest.raises(RecordingError, match="units check: joint 'joint_5'.*it is in degrees"):
        check_joint_units(in_degrees, {"joint_5": commanded}, "drive/drive0001.csv")
