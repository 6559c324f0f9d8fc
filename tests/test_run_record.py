"""One record of a finished run (issue 49 item 2): the API's Result, the report's ReportedRun and export's TunedRun
are views of one :class:`~simtune.store.RunRecord` with a checked configuration; nothing outside store/ reads the
stored configuration by key; a user's project is read once per process, again once a file of it changes."""

import ast
import os
import shutil
from dataclasses import replace
from pathlib import Path

import pytest

import simtune.api as st
from simtune.errors import ConfigError, SimtuneError
from simtune.project import BUNDLED_DIR
from simtune.report.collect import ReportedRun, load_run
from simtune.run_plan import RunConfig, new_run_config, plan_run
from simtune.runs import read_run_record
from simtune.store import RunStore
from simtune.tasks import project as project_module
from simtune.tasks.project import get_project

ROOT = Path(__file__).resolve().parent.parent
PACKAGE = ROOT / "src" / "simtune"
FIXTURE = Path(__file__).parent / "fixtures" / "stores" / "v3"


def test_the_readers_are_views_of_one_checked_record():
    record = read_run_record(FIXTURE)
    assert isinstance(record.config, RunConfig) and record.settings.seed == 5
    # a store from before these settings: what RunConfig.from_stored fills in for it
    assert (record.settings.reference, record.settings.targets, record.settings.repeats) == ("mean", "published", "all")
    assert [t.name for t in record.task_specs] == ["cube"] and record.task_specs[0].phases[1].targets_deg[2] == 65.0
    result = st.read_run(FIXTURE)
    reported = load_run(FIXTURE)
    assert isinstance(reported, ReportedRun)
    assert result.x == record.best_params == reported.best_params
    assert result.fitness == reported.best_fitness and result.generic_fitness == reported.generic_fitness
    assert (result.reference, result.repeats) == (reported.config.reference, reported.config.repeats) == ("mean", "all")
    assert reported.config == record.settings and reported.task("cube") == record.task_specs[0]


def _copy_with_config(tmp_path: Path, **changes) -> Path:
    run_dir = tmp_path / "run"
    shutil.copytree(FIXTURE, run_dir)
    store = RunStore(run_dir)
    config = dict(store.get("config"))
    config.update(changes)
    store.set(config=config)
    store.close()
    return run_dir


def test_one_check_of_the_stored_configuration_for_every_reader(tmp_path):
    run_dir = _copy_with_config(tmp_path, colour="red")
    message = "unknown key 'colour' in the stored configuration"
    with pytest.raises(ConfigError, match=message):
        st.read_run(run_dir)
    with pytest.raises(SimtuneError, match=message):
        st.export(run_dir, tmp_path / "export")
    skipped = load_run(run_dir)
    assert not isinstance(skipped, ReportedRun) and message in skipped.reason


def _keyed_reads(tree: ast.AST) -> list[int]:
    """Lines reading a configuration by key: ``<...>config["key"]`` or ``<...>config.get("key" ...)``."""

    def is_config(node: ast.AST) -> bool:
        name = node.attr if isinstance(node, ast.Attribute) else node.id if isinstance(node, ast.Name) else ""
        return name.endswith("config")

    lines = []
    for node in ast.walk(tree):
        keyed = isinstance(node, ast.Subscript) and is_config(node.value) and isinstance(node.slice, ast.Constant)
        got = isinstance(node, ast.Call) and isinstance(node.func, ast.Attribute) and node.func.attr == "get"
        if keyed or (got and is_config(node.func.value)):
            lines.append(node.lineno)
    return lines


def test_no_keyed_read_of_a_stored_configuration_outside_the_store():
    found = []
    for file in sorted(PACKAGE.rglob("*.py")):
        if file.relative_to(PACKAGE).parts[0] == "store":
            continue
        found += [f"{file.relative_to(PACKAGE)}:{line}" for line in _keyed_reads(ast.parse(file.read_text()))]
    assert found == []


def test_a_run_plan_resolves_its_project_once_and_holds_it(tmp_path, monkeypatch):
    """plan_run reads the run's project once (its file found once) and keeps it beside the tasks it gave."""
    folder = tmp_path / "mico"
    shutil.copytree(BUNDLED_DIR, folder)
    reads, finds = [], []
    read, find = project_module._read_project, project_module.find_project_file
    monkeypatch.setattr(project_module, "_read_project", lambda file: reads.append(file) or read(file))
    monkeypatch.setattr(project_module, "find_project_file", lambda path: finds.append(path) or find(path))
    config = replace(new_run_config("mujoco", "single,cube", "calibrated", data=None), project=str(folder))
    plan = plan_run(config)
    assert reads == [folder / "simtune.toml"] and len(finds) == 1
    assert plan.project is get_project(folder / "simtune.toml") and plan.project.file == folder / "simtune.toml"
    assert [t.name for t in plan.tasks] == ["single", "cube"]
    assert all(t.robot is plan.robot for t in plan.tasks)  # the one robot, from the tasks as before


def test_a_users_project_is_read_once_and_again_once_edited(tmp_path, monkeypatch):
    folder = tmp_path / "mico"
    shutil.copytree(BUNDLED_DIR, folder)
    toml = folder / "simtune.toml"
    toml.write_text(
        toml.read_text().replace('data = "../../reference"', f'data = "{BUNDLED_DIR.parent.parent / "reference"}"')
    )
    reads = []
    read = project_module._read_project  # what reads a project file once get_project has found it
    monkeypatch.setattr(project_module, "_read_project", lambda file: reads.append(file) or read(file))
    first = get_project(folder)
    assert get_project(folder) is first and get_project(str(folder)) is first and reads == [first.file]
    task_file = first.task_files["cube"]
    task_file.write_text(task_file.read_text() + "\n# edited\n")
    stat = task_file.stat()
    os.utime(task_file, ns=(stat.st_atime_ns, stat.st_mtime_ns + 1_000_000))  # a coarse clock: still a new time
    again = get_project(folder)
    assert again is not first and len(reads) == 2 and get_project(folder) is again
