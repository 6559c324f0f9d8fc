"""Active parameters: the measured probe, its cache, the search space without inactive ones, and where they show."""

import json
import os
import subprocess
import sys

import pytest

from simtune import activity
from simtune.activity import Activity, active_space, inactive_parameters, measure_activity, task_activity
from simtune.common.cache import CACHE_ENV
from simtune.engines import engine_class
from simtune.params import get_space
from simtune.reference import REFERENCE_DIR
from simtune.report.collect import Group, ReportedRun
from simtune.report.dr import dr_ranges
from simtune.report.tables import importance_table
from simtune.run_plan import plan_run
from simtune.runs import RunConfig
from simtune.store import RunRecord
from simtune.tasks import get_task

PROBED = [
    "mass_cube_plastic",  # the cube's own mass: acts
    "mass_cube_wood",  # no wood cube in `cube`
    "max_torque_joint_2",  # MuJoCo's servo never reaches 100 N m
    "max_velocity_joint_1",  # `cube` never moves joint 1
    "max_velocity_joint_2",
    "lateral_friction_plastic",
    "marker_offset_x",  # moves the marker, not the physics: still what the fitness sees
]


@pytest.fixture(scope="module")
def cube_probe():
    space = get_space("extended", engine_class("mujoco").supported(), PROBED)
    return space, measure_activity("mujoco", get_task("cube"), space)


def test_probe_finds_what_cannot_act_and_says_why(cube_probe):
    space, found = cube_probe
    assert list(found) == space.names
    active = {name for name, a in found.items() if a.active}
    assert active == {"mass_cube_plastic", "max_velocity_joint_2", "lateral_friction_plastic", "marker_offset_x"}
    assert found["mass_cube_wood"].reason == "task 'cube' has no wood cube"
    assert "servo" in found["max_torque_joint_2"].reason
    assert found["max_velocity_joint_1"].reason == "task 'cube' never commands joint 1 away from its start angle"
    for a in found.values():
        assert a.active == (a.change > activity.TOLERANCE) and bool(a.reason) != a.active


@pytest.mark.slow  # 6 s; the probe in one process stays in the default tier
def test_probe_on_worker_processes_finds_what_one_process_finds(cube_probe):
    """One process runs each round as one batch of the engine (MuJoCo's lockstep path), the workers one rollout at
    a time: the same changes, to the last digit."""
    space, found = cube_probe
    assert measure_activity("mujoco", get_task("cube"), space, workers=2) == found


def test_probe_is_cached_per_engine_task_and_space(tmp_path, monkeypatch):
    monkeypatch.setenv(CACHE_ENV, str(tmp_path))
    monkeypatch.setattr(activity, "_MEMORY", {})
    space = get_space("extended", engine_class("mujoco").supported(), ["mass_cube_wood", "command_delay"])
    first = task_activity("mujoco", get_task("cube"), space)
    files = list((tmp_path / "activity").glob("mujoco-cube-extended-*.json"))
    assert len(files) == 1
    stored = json.loads(files[0].read_text())
    assert stored["mass_cube_wood"]["active"] is False and stored["command_delay"]["active"] is True
    # a second process reads the file: tamper with it to see that it is read, not measured again
    stored["command_delay"]["reason"] = "read from the cache"
    files[0].write_text(json.dumps(stored))
    monkeypatch.setattr(activity, "_MEMORY", {})
    again = task_activity("mujoco", get_task("cube"), space)
    assert again["command_delay"].reason == "read from the cache" and again["mass_cube_wood"] == first["mass_cube_wood"]
    # another task is another entry
    task_activity("mujoco", get_task("single"), space)
    assert len(list((tmp_path / "activity").glob("mujoco-*.json"))) == 2


def test_several_tasks_leave_out_only_what_acts_in_none():
    space = get_space("extended", engine_class("mujoco").supported(), ["mass_cube_plastic", "mass_cube_wood"])
    both = inactive_parameters("mujoco", [get_task("single"), get_task("cube")], space)
    assert set(both) == {"mass_cube_wood"}
    assert set(inactive_parameters("mujoco", [get_task("single")], space)) == {"mass_cube_plastic", "mass_cube_wood"}


def _config(**kw):
    base = dict(engine="mujoco", tasks="cube", space="extended", data=str(REFERENCE_DIR), optimizer="de")
    return RunConfig(**{**base, **kw})


@pytest.mark.slow  # about 16 s: two activity probes of the whole space
def test_search_leaves_out_inactive_parameters_unless_kept():
    config = _config()
    plan = plan_run(config)
    full, inactive = plan.full_space, plan.inactive
    searched = plan.objective().vector_space().names
    assert searched == [n for n in full.names if n not in inactive]
    assert {"mass_cube_wood", "max_torque_joint_1", "lateral_friction_wood"} <= set(inactive)
    assert "mass_cube_plastic" in searched and "command_delay" in searched
    assert plan_run(_config(keep_inactive=True)).objective().vector_space().names == full.names
    # --only names stay even where inactive: the user asked for them
    only = plan_run(_config(only=["mass_cube_wood", "command_delay"])).objective().vector_space().names
    assert only == ["mass_cube_wood", "command_delay"]


def test_a_run_stored_before_the_setting_kept_every_parameter():
    stored = {"engine": "mujoco", "tasks": "cube", "space": "extended", "data": str(REFERENCE_DIR)}
    assert RunConfig.from_stored(stored, "old").keep_inactive is True
    assert RunConfig.from_stored({**stored, "keep_inactive": False}, "new").keep_inactive is False


def test_active_space_keeps_order():
    space = get_space("shared")
    kept = active_space(space, {"timestep": "why"}, keep=None)
    assert kept.names == space.names[1:]


def test_params_command_shows_an_active_column_with_reasons():
    proc = subprocess.run(
        [sys.executable, "-m", "simtune.cli", "params", "--engine", "mujoco", "--task", "cube", "--space", "shared"],
        capture_output=True,
        text=True,
        timeout=300,
        env={**os.environ, "COLUMNS": "300"},
    )
    assert proc.returncode == 0, proc.stderr
    text = " ".join(proc.stdout.split())
    assert "active" in text and "active on cube" in text
    assert "task 'cube' has no wood cube" in text


def _record(seed: int, values: dict[str, float], inactive: dict[str, str]) -> ReportedRun:
    names = list(values)
    record = RunRecord(
        path=REFERENCE_DIR,
        version=3,
        status="finished",
        message="",
        config=RunConfig("mujoco", "cube", "shared", "", seed=seed),
        command=[],
        versions={},
        fingerprint=None,
        parameters=names,
        bounds=[(0.0, 1.0)] * len(names),
        inactive=inactive,
        generic={"fitness": 1.0},
        best={"x": list(values.values()), "score": {"fitness": 0.5}},
        de_settings=None,
        converged=False,
        stop_reason=None,
        verdict=None,
        uncertainty=None,
        validation=None,
        evaluations=1,
        outcomes={},
        generations=[],
        initial_fitness=[],
        initial_population=[],
        rescored_from=None,
        elapsed_s=1.0,
        finished_at=None,
    )
    return ReportedRun(record, f"run{seed}", [get_task("cube")], random_start=[[0.1] * len(names), [0.9] * len(names)])


def test_report_and_ranges_never_pool_an_inactive_parameter():
    why = {"mass_cube_wood": "task 'cube' has no wood cube"}
    runs = [_record(s, {"mass_cube_plastic": 0.2 + s / 10, "mass_cube_wood": 0.1 + s / 3}, why) for s in range(3)]
    group = Group("mujoco", "cube", "shared", runs)
    assert group.searched == ["mass_cube_plastic", "mass_cube_wood"] and group.parameters == ["mass_cube_plastic"]
    ranges = dr_ranges([group], {})
    assert set(ranges["mujoco"]) == {"mass_cube_plastic"}
    table = importance_table([group])
    rows = {row[4]: dict(zip(table.headers, row)) for row in table.rows}
    assert rows["mass_cube_plastic"]["rank"] == 1 and rows["mass_cube_plastic"]["active"] == "yes"
    assert rows["mass_cube_wood"]["rank"] is None and rows["mass_cube_wood"]["active"] == f"no: {why['mass_cube_wood']}"


def test_activity_records_are_plain():
    a = Activity("x", False, 0.0, "why")
    assert Activity(**json.loads(json.dumps(a.__dict__))) == a


@pytest.mark.slow
def test_tune_searches_the_active_parameters_unless_told_to_keep_them(tmp_path):
    def tune(*extra):
        out = tmp_path / ("keep" if extra else "active")
        args = ["tune", "--task", "cube", "--space", "shared", "--optimizer", "random", "--max-evaluations", "2"]
        proc = subprocess.run(
            [sys.executable, "-m", "simtune.cli", *args, "--out", str(out), "--json", *extra],
            capture_output=True,
            text=True,
            timeout=600,
        )
        assert proc.returncode == 0, proc.stderr
        return json.loads(proc.stdout)

    active, kept = tune(), tune("--keep-inactive")
    assert kept["search_dimension"] == 31 and active["search_dimension"] == 31 - len(active["inactive_parameters"])
    # a run that keeps every parameter records the declared list (no probe): the measured one adds to it
    assert set(kept["inactive_parameters"]) <= set(active["inactive_parameters"])
    assert "mass_cube_wood" in active["inactive_parameters"]


def test_a_probe_at_a_terminal_says_so_and_shows_its_rollouts_on_a_bar(capsys, monkeypatch):
    """Issue 48: the probe has its own progress bar (on stderr at a terminal, where its note goes), counting the
    rollouts of each round; the results are those of a probe without one."""
    monkeypatch.setenv("FORCE_COLOR", "1")  # Rich draws its bar as at a terminal
    space = get_space("extended", engine_class("mujoco").supported(), ["command_delay", "mass_cube_wood"])
    counted: list[int] = []
    quiet = measure_activity("mujoco", get_task("cube"), space, on_rollouts=counted.append)
    assert counted[0] == 1 and sum(counted) >= 1 + len(space.names)  # the base point, then each parameter moved
    with activity.announcing(True):
        shown = task_activity("mujoco", get_task("cube"), space, use_cache=False)
    err = capsys.readouterr().err
    assert "measuring which of 2 parameters change the rollouts of task 'cube'" in err
    assert "probe" in err.split("...", 1)[1]  # the bar, after the note
    assert shown == quiet
