"""Issue 71 (probe 5): a tuned result a user can always use, and nothing silent.  Each test is one numbered case of
the probe that gave a wrong or misleading answer with exit status 0; the cases with a home of their own are tested
there (tests/test_run_read_back.py, test_export.py, test_grid.py, test_run_safety.py, test_check_targets.py,
test_mjcf_projects.py, test_tune.py)."""

import json
from pathlib import Path

import pytest
from conftest import cli_in_process

from simtune.reference import REFERENCE_DIR


def main(*args: str, capsys) -> tuple[int, str, str]:
    """The CLI in this process, as a user runs it (warnings as `warning:` lines): exit status, stdout, stderr."""
    return cli_in_process(*args, capsys=capsys)


# --- 4, 9: evaluate says which delay each task ran with, and never prints a number it lacks -------------------
def test_evaluate_says_which_command_delay_each_task_ran_with(tmp_path, capsys):
    plain = tmp_path / "plain.json"
    plain.write_text(json.dumps({"timestep": 0.002}))  # a plain parameter file: no delay in it
    code, out, _ = main(
        "evaluate", "--task", "cube", "--data", str(REFERENCE_DIR), "--params-file", str(plain), capsys=capsys
    )
    assert code == 0
    text = " ".join(out.split())
    assert "command delay: cube ran at 0 s, the parameters give it none" in text and "--align-clock" in text
    timed = tmp_path / "timed.json"
    timed.write_text(json.dumps({"command_delay": 1.5}))
    code, out, _ = main(
        "evaluate", "--task", "cube", "--data", str(REFERENCE_DIR), "--params-file", str(timed), "--json", capsys=capsys
    )
    assert code == 0 and json.loads(out)["command_delay_s"] == {"cube": 1.5}


def test_an_alignment_without_a_motion_onset_prints_no_placeholder():
    """Probe 5 #9: "(motion onset - s)", the number missing."""
    from simtune.alignment import DelayEstimate
    from simtune.api import Result
    from simtune.cli import output

    estimate = DelayEstimate("cube", None, None, 1.2, 1.2, 0.1, 0.05, 10)
    result = Result(
        "mujoco", ("cube",), {}, 0.05, None, None, {}, 0.2, True, 1, alignments=(estimate,), fitness_unaligned=0.1
    )
    with output.out.capture() as seen:
        output.print_evaluation(result, "t")
    text = " ".join(seen.get().split())
    assert "clock aligned: cube's command delay 1.20 s, estimated from its recordings with the physics" in text
    assert "onset" not in text


# --- 39: help text whose markup ate `<inertial>` and `<task>` -----------------------------------------------------
def test_help_keeps_every_angle_bracketed_name(capsys):
    """Typer's markdown help reads a bare ``<task>`` as an HTML tag and drops it ("OUT/truth-.json")."""
    import re

    code, out, _ = main("synth", "--help", capsys=capsys)
    assert code == 0 and "OUT/truth-<task>.json" in out and "truth-.json" not in out
    code, out, _ = main("init", "--help", capsys=capsys)
    assert code == 0 and "<inertial>" in out and "without an  get" not in " ".join(out.split())
    # and none is left bare in any command's help: each inside a `code span`, which markdown keeps as written
    for source in (Path(__file__).resolve().parents[1] / "src" / "simtune" / "cli").glob("*.py"):
        for number, line in enumerate(source.read_text().splitlines(), 1):
            bare = re.sub(r"`[^`]*`", "", line)
            assert not re.search(r"<[a-z_]+>", bare), f"{source.name}:{number}: {line.strip()}"


# --- 5: one repeat has no floor, not "floor 0.0000" --------------------------------------------------------------
def test_a_task_of_one_repeat_has_no_floor(tmp_path):
    """Probe 5 #5: `check` gave a one-episode task "floor 0.0000", presented as what a tuned simulation compares
    with; one repeat scores 0 against itself."""
    import shutil

    from simtune.check.project import floor_words
    from simtune.fitness import reference_floor
    from simtune.objective import load_references
    from simtune.tasks import get_task

    (tmp_path / "cube").mkdir()
    first = sorted((REFERENCE_DIR / "cube").iterdir())[0]
    shutil.copy(first, tmp_path / "cube" / first.name)
    task = get_task("cube")
    (one,) = load_references(tmp_path, [task], reference="aligned").values()
    assert reference_floor(one).floor is None
    assert floor_words(None).startswith("no floor: one repeat") and "0.0000" not in floor_words(None)
    (many,) = load_references(REFERENCE_DIR, [task], reference="aligned").values()
    assert reference_floor(many).floor > 0


# --- 8: at 80 columns no cell a user acts on is cut short ---------------------------------------------------------
def test_a_table_wider_than_the_terminal_becomes_one_line_per_row_never_cut_short(monkeypatch):
    """Probe 5 #8: in a pipe (80 columns) `check`'s table cut every file name to `CubeE…` and the floor to `0.00…`."""
    from simtune.cli import output

    headers = ("file", "lost frames", "longest gap [s]", "to mean [mm]", "as recorded [mm]", "onset [s]", "floor")
    rows = [(f"CubeExp00{k:02d}_6D.tsv", "0", "0.00", "1.9", "12.1", "1.215", "0.0043") for k in range(1, 4)]
    monkeypatch.setattr(output.out, "width", 80)
    with output.out.capture() as seen:
        output.print_whole_table("cube: 3 repeats", headers, rows)
    text = seen.get()
    assert "…" not in text and all(f"CubeExp00{k:02d}_6D.tsv" in text for k in range(1, 4))
    assert "floor 0.0043" in text and max(len(line) for line in text.splitlines()) <= 80
    monkeypatch.setattr(output.out, "width", 200)  # wide enough: the table itself
    with output.out.capture() as seen:
        output.print_whole_table("cube: 3 repeats", headers, rows)
    assert "┃ file" in seen.get() or "│ CubeExp0001_6D.tsv" in seen.get()


# --- third journey: the velocity clamp's range comes from the robot, and a project can state its own -----------
def test_an_own_robots_velocity_clamp_ranges_to_its_joints_limits_or_the_projects(tmp_path):
    """Probe 5: the clamp's range was [10, 40] deg/s for every robot; a task commanded at 60 deg/s was forced to 40 on
    every joint and the fit pushed the true damping to 0. The MICO keeps the seed paper's range."""
    import math

    from test_run_read_back import ARM_URDF

    from simtune.errors import ProjectError
    from simtune.params.space import SPACES, get_space
    from simtune.project import load_project
    from simtune.tasks.init_project import init_project

    urdf = tmp_path / "arm.urdf"
    urdf.write_text(ARM_URDF.replace('velocity="1"/>', 'velocity="2"/>', 1))  # the shoulder 2 rad/s, the elbow 1
    init_project(urdf, tmp_path / "p")
    robot = load_project(tmp_path / "p").robot.description
    space = {p.name: (p.low, p.high) for p in get_space("shared", robot=robot).parameters}
    assert space["max_velocity_joint_1"] == (10.0, pytest.approx(math.degrees(2.0)))
    assert space["max_velocity_joint_2"] == (10.0, pytest.approx(math.degrees(1.0)))
    assert {p.name: (p.low, p.high) for p in SPACES["shared"]}["max_velocity_joint_2"] == (10.0, 40.0)
    toml = tmp_path / "p" / "simtune.toml"
    toml.write_text(toml.read_text().replace("[robot]\n", "[robot]\nmax_velocity_deg = [20, 90]\n", 1))
    robot = load_project(tmp_path / "p").robot.description
    assert all(
        (p.low, p.high) == (20.0, 90.0) for p in get_space("shared", robot=robot).parameters if "velocity" in p.name
    )
    toml.write_text(toml.read_text().replace("max_velocity_deg = [20, 90]", "max_velocity_deg = [90, 20]"))
    with pytest.raises(ProjectError, match=r"max_velocity_deg: expected 0 < low < high"):
        load_project(tmp_path / "p")


# --- 18: init into a folder it cannot write: one line, never a traceback (nor one from its own clean-up) ---------
def test_init_into_a_folder_it_cannot_write_is_one_line(tmp_path, monkeypatch):
    from test_run_read_back import ARM_URDF

    from simtune.errors import ProjectError
    from simtune.tasks import init_project as init_module

    urdf = tmp_path / "arm.urdf"
    urdf.write_text(ARM_URDF)
    # as a folder without write permission reads (the tests run as root, who may write anywhere)
    monkeypatch.setattr(init_module.os, "access", lambda path, mode: False)
    with pytest.raises(ProjectError, match=r"cannot write the project there \(.* is not writable\)"):
        init_module.init_project(urdf, tmp_path / "new")
    monkeypatch.undo()
    (tmp_path / "empty").mkdir()

    def refused(self, *args, **kwargs):
        raise PermissionError(13, "Permission denied")

    monkeypatch.setattr(Path, "write_text", refused)  # an existing empty folder whose files cannot be written
    with pytest.raises(ProjectError, match=r"cannot write the project there \(Permission denied\)"):
        init_module.init_project(urdf, tmp_path / "empty")


# --- 13: an arm driven into the floor is never told it "never reaches the floor" ----------------------------------
def test_the_floor_surfaces_of_a_task_without_an_object_are_said_to_be_held_not_unreached():
    from simtune.engines import engine_class
    from simtune.tasks import get_task

    reasons = engine_class("mujoco").inactive_parameters(get_task("single"))
    floor = [why for name, why in reasons.items() if name.endswith("_floor")]
    assert floor and all("never reaches" not in why and "surfaces are held" in why for why in floor)


# --- 24: the API refuses a setting when it is given, not later ---------------------------------------------------
@pytest.mark.parametrize(
    ("setting", "message"),
    [
        ({"space": "nope"}, r"unknown parameter space 'nope' \(known: shared, individual, extended"),
        ({"max_evaluations": 10**30}, "max_evaluations must be at most 1000000000"),
    ],
)
def test_run_config_refuses_an_unknown_space_and_an_endless_budget_at_once(setting, message):
    import simtune.api as st
    from simtune.errors import ConfigError

    with pytest.raises(ConfigError, match=message):
        st.run_config("mujoco", "cube", **setting)
