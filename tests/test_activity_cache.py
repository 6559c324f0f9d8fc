"""The inactive-parameter probe's cache: keyed by content, never by a folder, so a second checkout reads it; a probe
that is not cached says so in one line, a cached one says nothing."""

import shutil
from dataclasses import asdict, replace
from pathlib import Path

import pytest

from simtune import activity
from simtune.activity import Activity, announcing, cache_key, robot_content, task_activity
from simtune.common.cache import CACHE_ENV
from simtune.engines import engine_class
from simtune.params import get_space
from simtune.project import BUNDLED_DIR, load_project

#: a two-joint arm whose hand collides through an OBJ mesh beside it (used in place: its path is the folder's)
ARM_URDF = """\
<robot name="arm">
  <link name="base">
    <inertial><mass value="2"/><inertia ixx="0.01" iyy="0.01" izz="0.01" ixy="0" ixz="0" iyz="0"/></inertial>
  </link>
  <link name="upper">
    <inertial><mass value="1"/><inertia ixx="0.01" iyy="0.01" izz="0.01" ixy="0" ixz="0" iyz="0"/></inertial>
    <collision><geometry><box size="0.05 0.05 0.3"/></geometry></collision>
  </link>
  <link name="hand">
    <inertial><mass value="0.5"/><inertia ixx="0.001" iyy="0.001" izz="0.001" ixy="0" ixz="0" iyz="0"/></inertial>
    <collision><geometry><mesh filename="meshes/hand.obj"/></geometry></collision>
  </link>
  <joint name="shoulder" type="revolute">
    <parent link="base"/><child link="upper"/><origin xyz="0 0 0.1"/><axis xyz="0 1 0"/>
    <limit lower="-1.5" upper="1.5" effort="20" velocity="1"/>
  </joint>
  <joint name="elbow" type="revolute">
    <parent link="upper"/><child link="hand"/><origin xyz="0 0 0.3"/><axis xyz="0 1 0"/>
    <limit lower="-1.5" upper="1.5" effort="20" velocity="1"/>
  </joint>
</robot>
"""

PROJECT = """\
name = "arm"
description = "a two-joint arm"
tasks = ["tasks/reach.toml"]
data = "recordings"

[robot]
urdf = "arm.urdf"
joints = ["shoulder", "elbow"]
tracked_link = "hand"
gripper_links = ["hand"]
"""

REACH = """\
name = "reach"
description = "both joints turn and back"
duration = 8.0
joints = ["shoulder", "elbow"]
start_pose_deg = [0, 0]

[controller]
law = "clamped-p-velocity"
gain = 10.0
max_velocity_deg = 30.0

[mocap]
link = "hand"
body = "hand"

[[phases]]
start = 0.0
targets_deg = [20, 20]

[[phases]]
start = 4.0
targets_deg = [0, 0]
"""


def cube_obj(half: float) -> str:
    """An OBJ cube of half edge ``half`` [m]."""
    corners = [(x, y, z) for x in (-half, half) for y in (-half, half) for z in (-half, half)]
    faces = [(1, 2, 4), (1, 4, 3), (5, 7, 8), (5, 8, 6), (1, 5, 6), (1, 6, 2)]
    faces += [(3, 4, 8), (3, 8, 7), (1, 3, 7), (1, 7, 5), (2, 6, 8), (2, 8, 4)]
    return "".join(f"v {x} {y} {z}\n" for x, y, z in corners) + "".join(f"f {a} {b} {c}\n" for a, b, c in faces)


def write_project(folder: Path) -> Path:
    (folder / "meshes").mkdir(parents=True)
    (folder / "tasks").mkdir()
    (folder / "arm.urdf").write_text(ARM_URDF)
    (folder / "meshes" / "hand.obj").write_text(cube_obj(0.03))
    (folder / "simtune.toml").write_text(PROJECT)
    (folder / "tasks" / "reach.toml").write_text(REACH)
    return folder


def edit(path: Path, old: str, new: str) -> None:
    text = path.read_text()
    assert old in text, f"{old!r} not in {path}"
    path.write_text(text.replace(old, new, 1))


def key_of(folder: Path, task: str = "reach", engine: str = "mujoco") -> str:
    """The probe's cache key of ``task`` of the project in ``folder``, over the engine's whole extended space."""
    spec = load_project(folder).task(task)
    space = get_space("extended", engine_class(engine).supported(spec.robot), robot=spec.robot)
    return cache_key(engine, spec, space, activity.PROBE_POINTS)


@pytest.fixture
def two_checkouts(tmp_path) -> tuple[Path, Path]:
    """One project written in one folder and copied to another, as two clones of its repository are."""
    first = write_project(tmp_path / "one" / "arm")
    second = tmp_path / "elsewhere" / "clone" / "arm"
    shutil.copytree(first, second)
    return first, second


def test_two_checkouts_of_a_project_share_the_key(two_checkouts):
    first, second = two_checkouts
    task = load_project(second).task("reach")
    assert str(second) in task.robot.links[-1].shapes[0].path  # the mesh is named by its folder's path
    assert key_of(first) == key_of(second)


@pytest.mark.parametrize(
    ("file", "old", "new"),
    [
        ("arm.urdf", '<mass value="0.5"/>', '<mass value="0.6"/>'),  # the hand's mass
        ("arm.urdf", 'effort="20"', 'effort="25"'),  # a joint's force limit
        ("tasks/reach.toml", "targets_deg = [20, 20]", "targets_deg = [20, 25]"),  # a target
        ("tasks/reach.toml", "duration = 8.0", "duration = 9.0"),
        ("meshes/hand.obj", "v -0.03 -0.03 -0.03", "v -0.04 -0.03 -0.03"),  # the mesh's shape, same file name
        # a field added after the probes were shipped: left out of the key at its default, in it when set
        ("tasks/reach.toml", "max_velocity_deg = 30.0", 'max_velocity_deg = 30.0\ninterpolation = "linear"'),
    ],
    ids=["mass", "effort", "target", "duration", "mesh", "interpolation"],
)
def test_what_changes_a_rollout_changes_the_key(two_checkouts, file, old, new):
    first, second = two_checkouts
    edit(second / file, old, new)
    assert key_of(first) != key_of(second)


def test_what_changes_no_rollout_keeps_the_key(two_checkouts):
    first, second = two_checkouts
    edit(second / "tasks" / "reach.toml", 'description = "both joints', 'description = "each joint')
    edit(second / "simtune.toml", 'data = "recordings"', 'data = "/somewhere/else/recordings"')
    assert key_of(first) == key_of(second)


def test_the_bundled_project_copied_twice_shares_the_key(tmp_path):
    """The MICO project as a fresh clone has it: its recordings folder (relative to the project) lies elsewhere."""
    first, second = tmp_path / "a" / "mico", tmp_path / "b" / "deeper" / "mico"
    shutil.copytree(BUNDLED_DIR, first)
    shutil.copytree(BUNDLED_DIR, second)
    assert load_project(first).task("cube").recordings != load_project(second).task("cube").recordings
    assert key_of(first, "cube") == key_of(second, "cube")
    edit(second / "tasks" / "cube.toml", "mass = 0.0884", "mass = 0.09")  # the cube's mass
    assert key_of(first, "cube") != key_of(second, "cube")


def test_the_key_names_the_engine_and_the_space(two_checkouts):
    first, _ = two_checkouts
    task = load_project(first).task("reach")
    supported = engine_class("mujoco").supported(task.robot)
    space = get_space("extended", supported, robot=task.robot)
    fewer = get_space("extended", supported, ["command_delay", "timestep"], robot=task.robot)
    key = cache_key("mujoco", task, space, 3)
    assert cache_key("mujoco", task, fewer, 3) != key
    assert cache_key("mujoco", task, space, 2) != key
    assert cache_key("pybullet", task, space, 3) != key


MJCF = """\
<mujoco model="arm">
  <compiler meshdir="meshes"/>
  <asset><mesh name="hand" file="hand.obj"/></asset>
  <worldbody>
    <body name="base">
      <geom type="box" size="0.05 0.05 0.05"/>
      <body name="upper" pos="0 0 0.1">
        <joint name="shoulder" axis="0 1 0"/>
        <geom type="box" size="0.025 0.025 0.15" pos="0 0 0.15" mass="1"/>
        <include file="parts/hand.xml"/>
      </body>
    </body>
  </worldbody>
</mujoco>
"""
HAND = """\
<mujoco>
  <body name="hand" pos="0 0 0.3">
    <joint name="elbow" axis="0 1 0"/>
    <geom type="mesh" mesh="hand" mass="0.5"/>
  </body>
</mujoco>
"""


def test_an_mjcf_robot_is_read_by_content_with_its_includes_and_meshes(tmp_path):
    from simtune.robot.mjcf import load_mjcf

    first = tmp_path / "one"
    (first / "meshes").mkdir(parents=True)
    (first / "parts").mkdir()
    (first / "arm.xml").write_text(MJCF)
    (first / "parts" / "hand.xml").write_text(HAND)
    (first / "meshes" / "hand.obj").write_text(cube_obj(0.03))
    second = tmp_path / "two" / "copy"
    shutil.copytree(first, second)

    def content(folder: Path) -> dict:
        return robot_content(load_mjcf(folder / "arm.xml", tracked_link="hand"))

    assert content(first) == content(second)
    edit(second / "meshes" / "hand.obj", "v -0.03 -0.03 -0.03", "v -0.04 -0.03 -0.03")
    assert content(first) != content(second)
    shutil.copy(first / "meshes" / "hand.obj", second / "meshes" / "hand.obj")
    edit(second / "parts" / "hand.xml", 'mass="0.5"', 'mass="0.6"')  # in the included file only
    assert content(first) != content(second)


# --- a probe that runs says so; a cached one does not ----------------------------------------------------------
def fake_probe(calls: list):
    """A stand-in for the rollouts: every parameter active, each call counted."""

    def measure(engine, task, space, points=activity.PROBE_POINTS, samples=None, workers=1, on_rollouts=None):
        calls.append(task.name)
        return {name: Activity(name, True, 1.0) for name in space.names}

    return measure


@pytest.fixture
def fresh_cache(tmp_path, monkeypatch) -> list:
    """An empty cache, the probe's rollouts counted (:func:`fake_probe`); the shipped probes as simtune ships them."""
    monkeypatch.setenv(CACHE_ENV, str(tmp_path / "cache"))
    monkeypatch.setattr(activity, "_MEMORY", {})
    calls: list = []
    monkeypatch.setattr(activity, "measure_activity", fake_probe(calls))
    return calls


@pytest.fixture
def empty_cache(fresh_cache, monkeypatch) -> list:
    monkeypatch.setattr(activity, "shipped_probes", dict)  # nothing shipped either: a probe runs
    return fresh_cache


def test_a_second_checkout_reads_the_first_ones_probe(two_checkouts, empty_cache, monkeypatch):
    first, second = two_checkouts
    for folder in (first, second):
        task = load_project(folder).task("reach")
        space = get_space("extended", engine_class("mujoco").supported(task.robot), robot=task.robot)
        monkeypatch.setattr(activity, "_MEMORY", {})  # another process
        task_activity("mujoco", task, space)
    assert empty_cache == ["reach"]  # measured once, for the first checkout


def test_a_probe_that_is_not_cached_says_so_in_one_line(empty_cache, capsys):
    from simtune.tasks import get_task

    task = get_task("cube")
    space = get_space("shared", engine_class("mujoco").supported())
    with announcing(True):
        task_activity("mujoco", task, space, workers=2)
        first = capsys.readouterr()
        task_activity("mujoco", task, space)  # cached in this process
        again = capsys.readouterr()
    assert first.out == "" and len(first.err.splitlines()) == 1, first.err
    line = first.err
    assert line.startswith("measuring which of ") and "'cube'" in line and "mujoco" in line
    assert "on 2 workers" in line and "cached afterwards" in line and line.rstrip().endswith("...")
    assert again.err == "" and empty_cache == ["cube"]
    # read from the file by a fresh process: nothing said either
    activity._MEMORY.clear()
    with announcing(True):
        task_activity("mujoco", task, space)
    assert capsys.readouterr().err == "" and empty_cache == ["cube"]


def test_a_probe_says_nothing_when_told_not_to_or_when_nobody_watches(empty_cache, capsys):
    from simtune.tasks import get_task

    space = get_space("shared", engine_class("mujoco").supported())
    with announcing(False):
        task_activity("mujoco", get_task("cube"), space)
    task_activity("mujoco", get_task("single"), space)  # stderr is captured here, no terminal
    assert capsys.readouterr().err == "" and empty_cache == ["cube", "single"]


def test_the_note_counts_only_the_parameters_the_engine_has():
    from simtune.tasks import get_task

    task = get_task("cube")
    space = get_space("shared", engine_class("mujoco").supported())
    note = activity.probe_note("mujoco", task, space, 3, 1, cached=False)
    n = len(space.names)
    assert f"of {n} parameters" in note and f"up to {4 * (1 + 2 * n)} rollouts of 20 s" in note
    assert "workers" not in note and "cached" not in note
    assert "rollouts of 8 s" in activity.probe_note("mujoco", replace(task, duration=8.0), space, 3, 1, True)


# The probes shipped with simtune (scripts/seed_probes.py): a fresh machine's first run of a bundled task reads them.

#: the bundled tasks whose probes are shipped, for the default engine
SHIPPED_TASKS = ("single", "cube", "double")


def bundled_plan(task: str, space: str, targets: str = "task"):
    from simtune.run_config import RunConfig
    from simtune.run_plan import plan_run

    plan = plan_run(RunConfig(tasks=task, space=space, targets=targets))
    return plan.tasks[0], plan.full_space


def test_every_bundled_task_and_space_ships_its_probe_for_the_default_engine():
    """Keyed without the engine's version: on the version it was measured on it is read as it is, on another (a
    patch release) only where its witness replays - checked here for whichever MuJoCo is installed."""
    from simtune.params.space import SPACES
    from simtune.tasks import TARGETS

    missing, stale = [], []
    for task_name in SHIPPED_TASKS:
        for space_name in SPACES:
            for targets in TARGETS:
                task, space = bundled_plan(task_name, space_name, targets)
                if activity.shipped_name("mujoco", task, space) not in activity.shipped_probes():
                    missing.append(f"{task_name}/{space_name}/{targets}")
                    continue
                found, why = activity.shipped_activity("mujoco", task, space)
                if found is None:
                    stale.append(why)
    assert not missing, (
        f"no shipped probe for {', '.join(missing)}: a bundled task, the robot or a space changed; run "
        "`python scripts/seed_probes.py` and commit src/simtune/projects/probes.json.gz"
    )
    assert not stale, (
        f"{stale[0]} (and {len(stale) - 1} more): this MuJoCo rolls the bundled tasks out differently; run "
        "`python scripts/seed_probes.py` with it and commit src/simtune/projects/probes.json.gz with the lock"
    )


def test_a_fresh_cache_reads_the_shipped_probe_and_runs_none(tmp_path, monkeypatch):
    monkeypatch.setenv(CACHE_ENV, str(tmp_path / "cache"))
    monkeypatch.setattr(activity, "_MEMORY", {})

    def no_probe(*args, **kwargs):
        raise AssertionError("a shipped probe was measured again")

    monkeypatch.setattr(activity, "measure_activity", no_probe)
    task, space = bundled_plan("cube", "calibrated")
    found = task_activity("mujoco", task, space)
    shipped = activity.shipped_probes()[activity.shipped_name("mujoco", task, space)]["activity"]
    assert list(found) == space.names
    assert {name: found[name].active for name in found} == {name: shipped[name]["active"] for name in found}
    assert not found["mass_cube_wood"].active  # cube has no wood object: the engine's reason, as shipped
    assert "wood" in found["mass_cube_wood"].reason
    # and kept in the cache under today's key, engine version included: the next process reads it at once
    assert (tmp_path / "cache" / "activity" / activity.cache_name("mujoco", task, space)).is_file()


@pytest.mark.parametrize("task_name", ["single", pytest.param("cube", marks=pytest.mark.slow)])
def test_a_shipped_probe_is_what_the_probe_measures_today(task_name):
    """Its key holds simtune's version, not its code: an engine change that moves a rollout without moving the key
    shows here, as a shipped outcome that today's probe no longer gives (on any installed MuJoCo)."""
    # `single` in the shared space (2 s) in the default tier; `cube` in the calibrated one, a default run's
    task, space = bundled_plan(task_name, "shared" if task_name == "single" else "calibrated")
    measured = activity.measure_activity("mujoco", task, space)
    shipped = activity.shipped_probes()[activity.shipped_name("mujoco", task, space)]["activity"]
    assert {name: shipped[name] for name in space.names} == {name: asdict(a) for name, a in measured.items()}


# --- a shipped probe of another engine version: read where its witness replays, measured again where not ----------
def shipped_as_if_measured_on(monkeypatch, version: str, nudge: float = 0.0):
    """The shipped probes as if measured on MuJoCo ``version``, each witness moved by ``nudge`` [m]."""
    import copy

    entries = copy.deepcopy(activity.shipped_probes())
    for entry in entries.values():
        entry["engine_version"] = version
        for track in entry["witness"]:
            if track is not None:
                track[len(track) // 2][0] += nudge
    monkeypatch.setattr(activity, "shipped_probes", lambda: entries)
    return entries


def test_a_shipped_probe_of_another_engine_version_answers_where_its_witness_replays(
    fresh_cache, monkeypatch, capsys, recwarn
):
    """Measured: MuJoCo 4.0.0 and 4.0.1 roll the bundled tasks out bit for bit alike (benchmarks/engine_versions.py),
    so a probe shipped from one answers on the other after two rollouts, not a few hundred."""
    entries = shipped_as_if_measured_on(monkeypatch, "0.0.1")
    task, space = bundled_plan("single", "shared")
    with announcing(True):
        found = task_activity("mujoco", task, space)
    shipped = entries[activity.shipped_name("mujoco", task, space)]["activity"]
    assert fresh_cache == [] and {n: asdict(a) for n, a in found.items()} == {n: shipped[n] for n in space.names}
    assert capsys.readouterr().err == "" and not recwarn.list  # nothing to say: the fast start holds


def test_a_shipped_probe_whose_witness_moves_is_measured_again_saying_why(fresh_cache, monkeypatch, capsys):
    shipped_as_if_measured_on(monkeypatch, "0.0.1", nudge=activity.WITNESS_TOLERANCE * 10)
    task, space = bundled_plan("single", "shared")
    installed = engine_class("mujoco").version()
    with announcing(True):  # someone watches: the probe's own line says why it runs
        task_activity("mujoco", task, space)
    (line,) = capsys.readouterr().err.splitlines()
    assert line.startswith("measuring which of ") and "'single'" in line and line.endswith("...")
    assert "measured on mujoco 0.0.1" in line and f"mujoco {installed}'s rollouts of it move by up to 1e-07 m" in line
    assert fresh_cache == ["single"]
    # in a log (nobody watches): a warning line instead, for the next space's probe
    task, space = bundled_plan("single", "calibrated")
    with announcing(False), pytest.warns(activity.EngineVersionWarning, match="measured on mujoco 0.0.1.*again"):
        task_activity("mujoco", task, space)
    assert fresh_cache == ["single", "single"]


def test_a_probe_of_an_own_task_says_it_was_never_measured_here(empty_cache, capsys):
    from simtune.tasks import get_task

    with announcing(True):
        task_activity("mujoco", get_task("cube"), get_space("shared", engine_class("mujoco").supported()))
    assert "not measured on this machine before" in capsys.readouterr().err


def test_a_probe_past_its_deadline_measures_no_further_task_and_keeps_their_parameters(empty_cache):
    """Under --max-seconds the probe stops measuring tasks it does not hold at its deadline: their parameters stay
    in the search but those ruled out without a rollout, said in one warning; what it measured is cached."""
    import time

    from simtune.activity import declared_inactive, inactive_parameters
    from simtune.errors import RecordingWarning
    from simtune.tasks import get_task

    single, cube = get_task("single"), get_task("cube")
    space = get_space("shared", engine_class("mujoco").supported())
    inactive_parameters("mujoco", [single], space)  # measured once (every parameter active: the fake probe's)
    assert empty_cache == ["single"]
    with pytest.warns(RecordingWarning, match=r"cut short by the time cap: 1 of 2 tasks not probed \(cube\)"):
        found = inactive_parameters("mujoco", [single, cube], space, deadline=time.monotonic() - 1)
    assert empty_cache == ["single"]  # cube was not measured, single read from the cache
    assert found == {}  # single's fake probe found every parameter active
    declared = declared_inactive("mujoco", [cube], space)
    with pytest.warns(RecordingWarning):
        alone = inactive_parameters("mujoco", [cube], space, deadline=time.monotonic() - 1)
    assert alone == declared and empty_cache == ["single"]
