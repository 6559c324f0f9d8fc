"""Task files and projects: the schema's one-line errors, TOML = YAML, and the bundled MICO project as files."""

import json
import subprocess
import sys
from pathlib import Path

import pytest
import yaml

from simtune.errors import ProjectError
from simtune.project import bundled_project, load_project
from simtune.tasks.files import load_task_file

CUBE = """\
name = "push"
description = "push a box"
duration = 10.0
joints = ["joint_1", "joint_2", "joint_3", "joint_4", "joint_5", "joint_6"]
start_pose_deg = [0, 0, 0, 0, 0, 0]

[controller]
law = "clamped-p-velocity"
gain = 10.0
max_velocity_deg = 30.0

[mocap]
link = "link_6"
body = "wrist"

[object]
shape = "cube"
material = "plastic"
mass = 0.1
size = [0.075, 0.075, 0.075]
xy = [0.5, 0.0]
mocap_body = "box"

[[phases]]
start = 0.0
targets_deg = [0, 30, 120, 90, 0, 0]

[[phases]]
start = 5.0
targets_deg = [0, -60, 65, 90, 0, 0]
"""


def project(tmp_path: Path, task_text: str = CUBE, name: str = "push.toml", extra: str = "", robot="mico") -> Path:
    (tmp_path / "tasks").mkdir(parents=True, exist_ok=True)
    (tmp_path / "tasks" / name).write_text(task_text)
    robot_line = f'robot = "{robot}"\n' if robot else ""
    (tmp_path / "simtune.toml").write_text(f'{robot_line}tasks = ["tasks/{name}"]\n{extra}')
    return tmp_path


def test_a_task_file_reads_into_a_task(tmp_path):
    task = load_project(project(tmp_path)).task("push")
    assert task.duration == 10.0 and task.kp == 10.0 and task.wrist_body == "wrist"
    assert [p.start for p in task.phases] == [0.0, 5.0]
    assert task.phases[1].targets_deg == (0.0, -60.0, 65.0, 90.0, 0.0, 0.0)
    assert task.object is not None and task.object.mocap_body == "box" and task.object.mass == 0.1
    assert task.base_body is None and task.recordings is None


def test_yaml_and_toml_give_the_same_task(tmp_path):
    import tomllib

    doc = tomllib.loads(CUBE)
    (tmp_path / "push.yaml").write_text(yaml.safe_dump(doc))
    (tmp_path / "push.toml").write_text(CUBE)
    robot = bundled_project().robot
    assert load_task_file(tmp_path / "push.yaml", robot) == load_task_file(tmp_path / "push.toml", robot)


def test_a_csv_schedule_is_the_same_as_its_phases(tmp_path):
    rows = "time,joint_1,joint_2,joint_3,joint_4,joint_5,joint_6\n0,0,30,120,90,0,0\n5,0,-60,65,90,0,0\n"
    (tmp_path / "targets.csv").write_text(rows)
    head, _, _ = CUBE.partition("[[phases]]")
    (tmp_path / "csv.toml").write_text(
        head.replace("duration = 10.0\n", 'duration = 10.0\nschedule_csv = "targets.csv"\n')
    )
    (tmp_path / "phases.toml").write_text(CUBE)
    robot = bundled_project().robot
    assert load_task_file(tmp_path / "csv.toml", robot).phases == load_task_file(tmp_path / "phases.toml", robot).phases


def test_a_linear_schedule_ramps_between_its_set_points_and_hold_keeps_the_fingerprint(tmp_path):
    """[controller] interpolation = "linear": the target moves from each set-point to the next over the time
    between them (a logged stream a trajectory controller ramped through); the default, hold, is the task as
    before, fingerprint and all."""
    import numpy as np

    from simtune.engines.controller import JointController
    from simtune.runs import task_fingerprint

    (tmp_path / "hold.toml").write_text(CUBE)
    (tmp_path / "stated.toml").write_text(CUBE.replace("gain = 10.0", 'gain = 10.0\ninterpolation = "hold"'))
    (tmp_path / "linear.toml").write_text(CUBE.replace("gain = 10.0", 'gain = 10.0\ninterpolation = "linear"'))
    robot = bundled_project().robot
    hold, stated, linear = (load_task_file(tmp_path / f"{n}.toml", robot) for n in ("hold", "stated", "linear"))
    assert hold == stated and task_fingerprint(hold) == task_fingerprint(stated) != task_fingerprint(linear)
    times = [0.2, 2.7, 5.2, 9.0]  # with a 0.2 s delay: the first set-point, halfway, the last, after it
    ramped = np.degrees(JointController(linear, {"command_delay": 0.2}).targets(times))
    np.testing.assert_allclose(ramped[:, 1:3], [[30, 120], [-15, 92.5], [-60, 65], [-60, 65]], atol=1e-9)
    held = np.degrees(JointController(hold, {"command_delay": 0.2}).targets(times))
    np.testing.assert_allclose(held[:, 1:3], [[30, 120], [30, 120], [-60, 65], [-60, 65]], atol=1e-9)


@pytest.mark.parametrize(
    ("edit", "message"),
    [
        (("gain = 10.0", "gain = 10.0\nkd = 1.0"), "push.toml: controller.kd: unknown key"),
        (("duration = 10.0", 'duration = "ten"'), "push.toml: duration: expected a number, got a string"),
        (("duration = 10.0", "duration = -1.0"), "push.toml: duration: must be above 0 seconds, got -1"),
        (
            ("targets_deg = [0, 30, 120, 90, 0, 0]", "targets_deg = [0, 30, 120]"),
            "push.toml: phases[0].targets_deg: expected 6 numbers (one per driven joint: joint_1",
        ),
        (("start = 5.0", "start = 0.0"), "push.toml: phases[1].start: 0 s is not after the previous phase's start"),
        (('shape = "cube"', 'shape = "sphere"'), "push.toml: object.shape: unknown shape 'sphere'"),
        (('material = "plastic"', 'material = "rubber"'), "push.toml: object.material: unknown material group"),
        (('link = "link_6"', 'link = "link_9"'), "push.toml: mocap.link: robot mico has no link 'link_9'"),
        (('"joint_6"]\nstart', '"joint_7"]\nstart'), "push.toml: joints[5]: robot mico has no movable joint 'joint_7'"),
        (
            ("size = [0.075, 0.075, 0.075]", "size = [0.075, 0.075]"),
            "push.toml: object.size: expected 3 numbers for a cube",
        ),
        (('law = "clamped-p-velocity"', 'law = "torque"'), "push.toml: controller.law: unknown control law 'torque'"),
        (("mass = 0.1", "mass = 0.0"), "push.toml: object.mass: must be above 0, got 0"),
        (('body = "wrist"', ""), "push.toml: mocap.body: missing (required)"),
        (("duration = 10.0", "duration = 4.0"), "push.toml: phases[1].start: starts at 5 s, not before the task's end"),
        (("[[phases]]\nstart = 0.0", "[[phase]]\nstart = 0.0"), "push.toml: phase: unknown key"),
        (
            ("gain = 10.0", 'gain = 10.0\ninterpolation = "spline"'),
            "push.toml: controller.interpolation: unknown interpolation 'spline' (known: hold, linear)",
        ),
    ],
)
def test_bad_task_files_are_one_line_naming_file_and_key(tmp_path, edit, message):
    old, new = edit
    assert old in CUBE
    root = project(tmp_path, CUBE.replace(old, new, 1))
    with pytest.raises(ProjectError) as info:
        load_project(root)
    text = str(info.value)
    assert message in text and "\n" not in text
    assert str(root / "tasks" / "push.toml") in text


def test_bad_yaml_is_one_line(tmp_path):
    root = project(tmp_path, "name: push\nduration: [1,\n", name="push.yaml")
    with pytest.raises(ProjectError, match=r"push.yaml: not valid YAML: .*line \d+") as info:
        load_project(root)
    assert "\n" not in str(info.value)


@pytest.mark.parametrize(
    ("extra", "message"),
    [
        ('urdf = "arm.urdf"\n', r"simtune.toml: urdf: name the URDF in the robot table: \[robot\]"),
        ("colour = 1\n", "simtune.toml: colour: unknown key"),
        ('[groups]\nboth = ["push", "pull"]\n', "simtune.toml: groups.both: unknown task 'pull'"),
        ('[groups]\npush = ["push"]\n', "simtune.toml: groups.push: 'push' already names a task"),
    ],
)
def test_bad_project_files(tmp_path, extra, message):
    with pytest.raises(ProjectError, match=message):
        load_project(project(tmp_path, extra=extra, robot=None if extra.startswith("urdf") else "mico"))


def test_a_project_folder_without_a_project_file(tmp_path):
    with pytest.raises(ProjectError, match=r"no project file \(simtune.toml or simtune.yaml"):
        load_project(tmp_path)


def test_recordings_are_relative_to_the_project(tmp_path):
    text = CUBE.replace("duration = 10.0\n", 'duration = 10.0\nrecordings = "data/push"\n')
    proj = load_project(project(tmp_path, text, extra='data = "elsewhere"\n'))
    assert proj.task("push").recordings == str((tmp_path / "data" / "push").resolve())
    assert proj.data_root() is None  # the task's own folder, not elsewhere/push
    assert any("recordings folder" in p and "does not exist" in p for p in proj.validate())


def test_the_cli_reports_a_bad_project_in_one_line(tmp_path):
    root = project(tmp_path, CUBE.replace("duration = 10.0", "duration = -1.0"))
    run = subprocess.run(
        [sys.executable, "-m", "simtune.cli", "tasks", "--project", str(root)], capture_output=True, text=True
    )
    assert run.returncode == 2, run.stderr
    assert run.stderr.startswith("error: ") and run.stderr.count("\n") == 1 and "duration" in run.stderr


#: task_fingerprint of every task as Python defined it before tasks were files (the fingerprints that run
#: stores hold): the files must define the very same tasks, field for field (a test comparing the two
#: passed before the Python definitions were deleted)
PYTHON_FINGERPRINTS = {
    "single": "c1f7ab884c68a1bdbe2ed2db3d95f37e374293cfdb90ce869c160519038c0482",
    "double": "5d5bf0964f0279e146e088df7e3b4d9241d8cc4959c4cf438d69ac230925d047",
    "cube": "3692f3b6c26dd9ee6186571b8617bc8980d98f05918f2fac987ba7abedb1094d",
    "seed-1": "045dccf5799f153c1466b9eccb2e1d3d771c2bcd5d78f59bc4200b8b05f21640",
    "seed-2": "6d932e3ffab8bf7b5b14cc428b144bf5dbfa67e341d12bb93b5459dbae2e3f93",
    "seed-3": "55d2e137a126f1747b718cbe0c3e9b5d56e18e0726bcbb7a0bba13a99e32e394",
    "seed-4": "5605e256c2a8c366c5bc759d50d40c1efa69df92fea89306f54b2e3716f5c133",
    "seed-5": "fccf971829ba49005c7c1bdcf5e3a031363e7d57e240f692c38968648584d1d8",
    "seed-6": "9ae7835e5f8a17b8294949e71d6bb08a69117ffdc21fb593f48ea4057d96bc40",
    "seed-7": "d4bbb6b32010a260425420e49f3a57f66b745e53831ca5ad7e6a09607a25c615",
    "seed-8": "61cecfd423959aa8ae2f6ee8af87d63324e722fa6a407b46dd27d29a4af981b9",
    "seed-9": "fdfdd46354a45ac56a8703af70cc0b1f6be45e383a9ad7145dde8654663048ed",
    "seed-10": "63246ee990f9e889553c83f73f66a2140a8048d943793725416cb48d9d490b85",
}


def test_bundled_tasks_are_the_former_python_tasks():
    """With their published targets (the cube's phase 2 is corrected since): the runs of the former tasks resume."""
    from simtune.runs import FORMER_TASK_FINGERPRINTS, task_fingerprint

    project = bundled_project()
    assert list(project.tasks) == list(PYTHON_FINGERPRINTS)
    assert [n for n, t in project.tasks.items() if t.published_phases is not None] == ["cube"]
    for name, task in project.tasks.items():
        now = task_fingerprint(task.as_published())
        assert PYTHON_FINGERPRINTS[name] in (now, FORMER_TASK_FINGERPRINTS.get(now)), name
    assert [n for n, t in project.tasks.items() if t.has_public_recordings] == ["single", "cube"]
    assert project.task("seed-3").description.endswith("(schedule re-aimed: docs/seed-tasks.md)")
    assert project.groups == {"seed-11": tuple(f"seed-{n}" for n in range(1, 11))}


def test_a_run_stored_before_task_files_resumes_without_changes():
    """A fingerprint as runs stored it: no task definition changed."""
    from simtune.runs import fingerprint_differences, task_fingerprint

    tasks = {n: PYTHON_FINGERPRINTS[n] for n in ("single", "cube", "seed-3")}
    # such a run stores no targets: it ran the published ones (RunConfig.from_stored)
    now = {n: task_fingerprint(bundled_project().task(n).as_published()) for n in tasks}
    assert fingerprint_differences({"data": {}, "tasks": tasks}, {"data": {}, "tasks": now, "engine": "x"}) == []
    changed = dict(now, cube=PYTHON_FINGERPRINTS["double"])
    assert fingerprint_differences({"data": {}, "tasks": tasks}, {"data": {}, "tasks": changed, "engine": "x"}) == [
        "the definition of task 'cube' changed"
    ]


def test_published_seed_tasks_drop_the_offset():
    from simtune.tasks.seed import published_task

    fixed, published = bundled_project().task("seed-5"), published_task(5)
    assert published.phases[0].targets_deg == (0.0, -11.0, 105.0, 87.0, -4.0, 1.0)
    assert fixed.phases[0].targets_deg == (0.0, -29.0, 85.0, 87.0, -4.0, 1.0)
    assert published.description == "seed paper task 5: push the plastic cylinder"


REACH = """\
name = "reach"
description = "bend joints 2 and 3"
duration = 3.0
recordings = "recordings/reach"

[controller]
gain = 10.0

[mocap]
body = "RB1(Orange)"

[[phases]]
start = 0.0
targets_deg = [0, -30, 30, 0, 0, 0]
"""


def cli(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "simtune.cli", *args], capture_output=True, text=True, timeout=600)


@pytest.mark.slow  # about 20-25 s: synth, evaluate, tune, resume and report in subprocesses
def test_a_project_from_synth_to_tune_and_report(tmp_path):
    """A project of its own: listed, recorded by synth (generic truth), evaluated, tuned and reported."""
    root = project(tmp_path / "arm", REACH, name="reach.toml")
    listed = cli("tasks", "--project", str(root))
    assert listed.returncode == 0 and "reach" in listed.stdout and "seed-3" not in listed.stdout
    made = cli("synth", "--project", str(root), "--engine", "mujoco", "--task", "reach", "--repeats", "2",
               "--out", str(root / "recordings"))  # fmt: skip
    assert made.returncode == 0, made.stderr
    truth = json.loads((root / "recordings" / "truth.json").read_text())
    assert truth["params"] == {"command_delay": 1.5}  # the engine's generic values (and the default delay)
    # no --data: the task file's recordings folder
    scored = cli("evaluate", "--project", str(root), "--engine", "mujoco", "--task", "reach", "--json",
                 "--params-file", str(root / "recordings" / "truth.json"))  # fmt: skip
    assert scored.returncode == 0, scored.stderr
    result = json.loads(scored.stdout)
    assert result["fitness"] < 0.005 < result["generic_fitness"]  # the truth fits within the noise; no delay does not
    run = tmp_path / "run"
    tuned = cli("tune", "--project", str(root), "--engine", "mujoco", "--task", "reach", "--space", "extended",
                "--only", "command_delay", "--max-evaluations", "8", "--out", str(run), "--json", "-q")  # fmt: skip
    assert tuned.returncode == 0, tuned.stderr
    assert json.loads(tuned.stdout)["fitness"] < result["generic_fitness"]
    resumed = cli("resume", str(run), "--json", "-q")  # the run names its project: found from anywhere
    assert resumed.returncode == 0, resumed.stderr
    # the bundled project has no task "reach": the run's own project is read
    assert cli("tasks").stdout.count("reach") == 0
    report = cli("report", str(run), "--out", str(tmp_path / "report"), "-q")
    assert report.returncode == 0, report.stderr
    assert (tmp_path / "report" / "index.html").is_file()


def test_the_documented_examples_load(tmp_path):
    """docs/task-files.md: its task file in TOML and in YAML define the same motion and object."""
    import re

    text = (Path(__file__).resolve().parents[1] / "docs" / "task-files.md").read_text()
    toml_blocks = re.findall(r"```toml\n(.*?)```", text, re.S)
    yaml_block = re.search(r"```yaml\n(.*?)```", text, re.S)
    assert yaml_block is not None
    task_toml = next(b for b in toml_blocks if b.startswith("# myproject/tasks/push.toml"))
    (tmp_path / "push.toml").write_text(task_toml)
    (tmp_path / "push.yaml").write_text(yaml_block.group(1))
    robot = bundled_project().robot
    a, b = load_task_file(tmp_path / "push.toml", robot), load_task_file(tmp_path / "push.yaml", robot)
    assert (a.phases, a.object, a.kp, a.duration, a.joints) == (b.phases, b.object, b.kp, b.duration, b.joints)
    assert a.base_body == "RB2(Black)" and b.base_body is None


@pytest.mark.parametrize(
    ("rows", "message"),
    [
        ("time,joint_1,joint_2\n0,1,2\n", "targets.csv: line 1: expected the header time,joint_1,"),
        ("time,joint_1,joint_2,joint_3,joint_4,joint_5,joint_6\n0,1,2,3,4,5\n", "line 2: expected 7 values, got 6"),
        ("time,joint_1,joint_2,joint_3,joint_4,joint_5,joint_6\n0,1,2,3,4,5,x\n", "line 2: a value is not a number"),
        (
            "time,joint_1,joint_2,joint_3,joint_4,joint_5,joint_6\n1,0,0,0,0,0,0\n1,0,0,0,0,0,0\n",
            "line 3: time 1 s is not after the previous row's",
        ),
    ],
)
def test_bad_schedule_csv_names_file_and_line(tmp_path, rows, message):
    (tmp_path / "tasks").mkdir()
    (tmp_path / "tasks" / "targets.csv").write_text(rows)
    head = CUBE.partition("[[phases]]")[0].replace(
        "duration = 10.0\n", 'duration = 10.0\nschedule_csv = "targets.csv"\n'
    )
    with pytest.raises(ProjectError, match="push.toml: schedule_csv: ") as info:
        load_project(project(tmp_path, head))
    assert message in str(info.value)


def test_a_yaml_project_file(tmp_path):
    project(tmp_path)
    (tmp_path / "simtune.toml").unlink()
    (tmp_path / "simtune.yaml").write_text("robot: mico\ntasks: [tasks/push.toml]\ngroups: {all: [push]}\n")
    proj = load_project(tmp_path)
    assert proj.name == tmp_path.name and proj.parse_tasks("all") == [proj.task("push")]
    (tmp_path / "simtune.toml").write_text('robot = "mico"\ntasks = ["tasks/push.toml"]\n')
    with pytest.raises(ProjectError, match=r"two project files \(simtune.toml, simtune.yaml\): keep one"):
        load_project(tmp_path)


def test_a_changed_robot_is_named_as_such_on_resume():
    """A URDF edited before `resume` used to read as "the definition of task ... changed"; runs stored before the
    robot's own fingerprint was kept still compare by their tasks."""
    from simtune.run_plan import plan_run
    from simtune.runs import RunConfig, fingerprint_differences, run_fingerprint

    now = run_fingerprint(plan_run(RunConfig("mujoco", "cube", "calibrated", None, optimizer="de")))
    assert len(now["robot"]) == 64
    stored = {**now, "robot": "0" * 64, "tasks": {"cube": "1" * 64}}
    assert fingerprint_differences(stored, now) == ["the robot changed (its description or a mesh file)"]
    before = {k: v for k, v in stored.items() if k != "robot"}
    assert fingerprint_differences(before, now) == ["the definition of task 'cube' changed"]
