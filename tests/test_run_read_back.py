"""Every run `tune` makes can be read back from its own best_params.json: evaluated on the task it was tuned on and on
another one of its project (a transfer), exported and reported - for an own robot (a URDF project) in every space,
and for the bundled MICO (probe 5, issue 71: an own robot's `calibrated` file was refused by `evaluate` because it
was checked against the MICO's `calibrated`)."""

import json
import subprocess
import sys
from pathlib import Path

import pytest
from conftest import CPU_ENGINES, engine_or_skip

import simtune.api as st
from simtune.params.space import SPACES
from simtune.reference import REFERENCE_DIR
from simtune.tasks.init_project import init_project

#: two driven joints, a box on each link: quick to roll out in every engine
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
    <collision><origin xyz="0 0 0.05"/><geometry><box size="0.04 0.04 0.1"/></geometry></collision>
  </link>
  <joint name="shoulder" type="revolute">
    <parent link="base"/><child link="upper"/><origin xyz="0 0 0.5"/><axis xyz="0 1 0"/>
    <limit lower="-1.5" upper="1.5" effort="20" velocity="1"/>
  </joint>
  <joint name="elbow" type="revolute">
    <parent link="upper"/><child link="hand"/><origin xyz="0 0 0.3"/><axis xyz="0 1 0"/>
    <limit lower="-1.5" upper="1.5" effort="20" velocity="1"/>
  </joint>
</robot>
"""


@pytest.fixture(scope="module")
def own_project(tmp_path_factory) -> Path:
    """An own robot's project of two tasks (init's example `reach` and a second reach the other way), with
    synthetic recordings of both in its recordings folder."""
    root = tmp_path_factory.mktemp("own")
    (root / "arm.urdf").write_text(ARM_URDF)
    project = root / "arm"
    init_project(root / "arm.urdf", project)
    reach = (project / "tasks" / "reach.toml").read_text()
    for name, targets in (("back", "[-15, 25]"), ("side", "[10, -20]")):
        (project / "tasks" / f"{name}.toml").write_text(
            reach.replace('name = "reach"', f'name = "{name}"').replace(
                "targets_deg = [20, 20]", f"targets_deg = {targets}"
            )
        )
    toml = project / "simtune.toml"
    files = '"tasks/reach.toml", "tasks/back.toml", "tasks/side.toml"'
    toml.write_text(toml.read_text().replace('tasks = ["tasks/reach.toml"]', f"tasks = [{files}]"))
    st.synth("mujoco", "reach,back,side", out=project / "recordings", project=project, repeats=2)
    return project


def read_back(run: Path, tasks: list[str], tmp_path: Path, project: Path | None, data: Path | None) -> list[str]:
    """The run's best_params.json scored on each of ``tasks`` (those tuned on, through the API, to its stored
    fitness; then others, held out, through `simtune evaluate --params-file` as a user runs it), exported, reported.

    Returns:
        What `simtune evaluate` printed for each held-out task.
    """
    from typer.testing import CliRunner

    from simtune.cli import app

    best = run / "best_params.json"
    stored = json.loads(best.read_text())
    score = st.evaluate("mujoco", tasks[0], params=best, project=project, data=data)
    assert score.fitness == pytest.approx(stored["fitness"], rel=1e-9, abs=1e-12)
    where = ["--project", str(project)] if project else ["--data", str(data)]
    printed = []
    for task in tasks[1:]:
        done = CliRunner().invoke(app, ["evaluate", "--task", task, "--params-file", str(best), *where])
        assert done.exit_code == 0 and f"{task} " in done.output, done.output
        printed.append(" ".join(done.output.split()))
    exports, _ = st.export(run, tmp_path / "export")
    assert exports and (tmp_path / "export" / "provenance.json").is_file()
    first = tasks[0].split(",")[0]  # a run of several tasks exports a scene of each
    loaded = subprocess.run(
        [sys.executable, "load_mujoco.py", first], cwd=tmp_path / "export", capture_output=True, text=True
    )
    assert loaded.returncode == 0 and loaded.stdout.startswith(f"{first} wrist at"), loaded.stderr
    unknown = subprocess.run(
        [sys.executable, "load_mujoco.py", tasks[0] + "x"], cwd=tmp_path / "export", capture_output=True, text=True
    )
    assert unknown.returncode == 1 and "(this export has: " in unknown.stderr and "Traceback" not in unknown.stderr
    assert st.report(run, tmp_path / "report").is_file()
    return printed


#: the default tier reads back the default space; the slow tier every other (the default tier's 4 minutes)
QUICK = ("calibrated",)
#: every kind of run tune makes of an own robot: each space, a selection (--only), and several tasks tuned together,
#: each with its own command delay (issue 70: `evaluate --params-file` refused such a run's best_params.json)
RUNS = {
    **{space: {"space": space} for space in SPACES},
    "only": {"space": "extended", "only": "armature_joint_1,joint_damping_2,command_delay"},
    "two-tasks": {"space": "calibrated", "tasks": "reach,back"},
}


@pytest.mark.parametrize("kind", [k if k in QUICK else pytest.param(k, marks=pytest.mark.slow) for k in RUNS])
def test_an_own_robots_run_reads_back_in_every_space(kind, own_project, tmp_path):
    """Read back on the tasks tuned on and on `side`, held out: its shared parameters apply, the tuned tasks' own
    delays do not (said in a line), and its clock is aligned from its recordings."""
    settings = dict(RUNS[kind])
    tuned = settings.pop("tasks", "reach")
    run = tmp_path / "run"
    st.tune("mujoco", tuned, project=own_project, out=run, optimizer="random", max_evaluations=2, workers=1, **settings)
    (held,) = read_back(run, [tuned, "side"], tmp_path, own_project, None)
    assert "clock aligned: side's command delay" in held
    assert ("not applied: command_delay_reach, command_delay_back (each the clock" in held) == (kind == "two-tasks")


@pytest.mark.slow
@pytest.mark.parametrize("space", list(SPACES))
def test_a_mico_run_reads_back_in_every_space(space, tmp_path):
    run = tmp_path / "run"
    st.tune("mujoco", "cube", data=REFERENCE_DIR, space=space, out=run, optimizer="random", max_evaluations=2)
    read_back(run, ["cube"], tmp_path, None, REFERENCE_DIR)


@pytest.mark.slow  # 5 s: an own robot's evaluate on another task is in the default tier's read-back
def test_transfer_carries_an_own_robots_tasks(own_project, tmp_path):
    """`simtune transfer --project`: an own robot tuned on one of its tasks and tested on another (probe 5's third
    journey: transfer took no --project)."""
    from typer.testing import CliRunner

    from simtune.cli import app

    out = tmp_path / "transfer"
    args = ["transfer", "--project", str(own_project), "--train", "reach", "--test", "back", "--out", str(out)]
    done = CliRunner().invoke(app, [*args, "--optimizer", "random", "--max-evaluations", "2", "--workers", "1", "-q"])
    assert done.exit_code == 0, done.output
    result = json.loads((out / "transfer.json").read_text())
    assert [(r["task"], r["role"]) for r in result["tasks"]] == [("reach", "train"), ("back", "test")]
    assert all(r["stable"] and r["tuned"] > 0 for r in result["tasks"])


@pytest.mark.slow  # a short run in each engine, its export loaded by the export's own script
@pytest.mark.parametrize("engine", CPU_ENGINES)
def test_an_own_robots_run_reads_back_in_every_engine(engine, own_project, tmp_path):
    """The same read-back in each CPU engine, the default space: evaluated in that engine on the task tuned on
    (its stored fitness) and on another task, exported (loaded by the export's own script where it has one) and
    reported."""
    engine_or_skip(engine)
    run = tmp_path / "run"
    st.tune(engine, "reach", project=own_project, out=run, optimizer="random", max_evaluations=2, workers=1)
    best = run / "best_params.json"
    stored = json.loads(best.read_text())
    assert st.evaluate(engine, "reach", params=best, project=own_project).fitness == pytest.approx(
        stored["fitness"], rel=1e-9, abs=1e-12
    )
    assert st.evaluate(engine, "back", params=best, project=own_project).stable
    exports, _ = st.export(run, tmp_path / "export")
    assert exports and (tmp_path / "export" / "provenance.json").is_file()
    script = tmp_path / "export" / f"load_{engine}.py"
    if engine != "ode":  # ODE's export is its sidecar alone (docs/export.md)
        loaded = subprocess.run(
            [sys.executable, script.name, "reach"], cwd=script.parent, capture_output=True, text=True, timeout=300
        )
        assert loaded.returncode == 0 and loaded.stdout.startswith("reach wrist at"), loaded.stderr
    assert st.report(run, tmp_path / "report").is_file()
