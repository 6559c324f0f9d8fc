"""Targets as the robot ran them: a task file corrects a published target with ``published_targets_deg`` beside
``targets_deg``; a run carries which it ran (``targets``: task or published; ``--paper-exact`` the published), and
a run stored before the correction keeps the published ones.  The bundled `cube` is such a task (issue 45)."""

from pathlib import Path

import pytest
from test_task_files import CUBE, project

from simtune import api
from simtune.errors import ConfigError, ProjectError
from simtune.project import load_project
from simtune.run_plan import RunConfig, plan_run
from simtune.runs import task_fingerprint
from simtune.tasks import get_task, parse_tasks

CORRECTED = CUBE.replace(
    "targets_deg = [0, -60, 65, 90, 0, 0]",
    "targets_deg = [0, -60, 74, 90, 0, 0]\npublished_targets_deg = [0, -60, 65, 90, 0, 0]",
)


def test_a_corrected_phase_keeps_its_published_targets(tmp_path):
    task = load_project(project(tmp_path, CORRECTED)).task("push")
    assert task.phases[1].targets_deg[2] == 74.0
    published = task.as_published()
    assert published.phases[1].targets_deg[2] == 65.0 and published.published_phases is None
    assert [p.start for p in published.phases] == [p.start for p in task.phases]
    # the published task is the file as it was before the correction, fingerprint and all
    before = load_project(project(tmp_path / "before")).task("push")
    assert task_fingerprint(published) == task_fingerprint(before) != task_fingerprint(task)


def test_published_targets_equal_to_the_targets_correct_nothing(tmp_path):
    same = CUBE.replace(
        "targets_deg = [0, -60, 65, 90, 0, 0]",
        "targets_deg = [0, -60, 65, 90, 0, 0]\npublished_targets_deg = [0, -60, 65, 90, 0, 0]",
    )
    task = load_project(project(tmp_path, same)).task("push")
    assert task.published_phases is None and task.as_published() is task


@pytest.mark.parametrize("bad", ["[0, -60, 65, 90]", '"65"'])
def test_bad_published_targets_name_the_key(tmp_path, bad):
    text = CORRECTED.replace("published_targets_deg = [0, -60, 65, 90, 0, 0]", f"published_targets_deg = {bad}")
    with pytest.raises(ProjectError, match=r"phases\[1\]\.published_targets_deg"):
        load_project(project(tmp_path, text)).task("push")


def test_the_bundled_cube_runs_joint_3_at_74_deg_in_phase_2():
    cube = get_task("cube")
    assert cube.phases[1].targets_deg == (0.0, -60.0, 74.0, 90.0, 0.0, 0.0)
    assert get_task("cube", targets="published").phases[1].targets_deg == (0.0, -60.0, 65.0, 90.0, 0.0, 0.0)
    assert [t.phases for t in parse_tasks("single", targets="published")] == [get_task("single").phases]
    with pytest.raises(ConfigError, match="targets must be one of task, published"):
        get_task("cube", targets="paper")


def test_a_run_config_carries_its_targets():
    new = RunConfig("mujoco", "cube", "calibrated", None, optimizer="de")
    assert new.targets == "task" and new.record()["targets"] == "task"
    exact = RunConfig("mujoco", "cube", "shared", None, optimizer="de", paper_exact=True)
    assert exact.targets == "published" and "targets" not in exact.record()  # as paper-exact runs stored it
    assert plan_run(exact).tasks[0].phases[1].targets_deg[2] == 65.0
    assert plan_run(new).tasks[0].phases[1].targets_deg[2] == 74.0
    # a store from before the correction names none: it ran the published targets
    stored = {k: v for k, v in new.record().items() if k != "targets"}
    assert RunConfig.from_stored(stored, "old").targets == "published"
    with pytest.raises(ConfigError, match="--paper-exact runs the published targets"):
        RunConfig("mujoco", "cube", "shared", None, optimizer="de", paper_exact=True, targets="task").check()
    with pytest.raises(ConfigError, match="targets must be one of"):
        RunConfig("mujoco", "cube", "calibrated", None, optimizer="de", targets="measured").check()
    assert api.run_config("mujoco", "cube", targets="published").targets == "published"
    assert api.run_config("mujoco", "cube", paper_exact=True, space="shared").targets == "published"


def test_the_reference_recording_runs_the_bundled_cube_as_it_is():
    """The shipped reference is a simulation of the bundled task: its hidden parameters score near its noise with
    the task's targets, and not with the published ones (the arm rests elsewhere in phase 2)."""
    import json

    from simtune.reference import REFERENCE_DIR

    truth = json.loads((Path(REFERENCE_DIR) / "truth.json").read_text())["params"]
    task = api.evaluate("mujoco", "cube", params=truth).fitness
    published = api.evaluate("mujoco", "cube", params=truth, targets="published").fitness
    assert task < 0.01 < published
