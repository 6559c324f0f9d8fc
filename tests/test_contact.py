"""Arm-object contact from each engine's own contact list, and whether the seed tasks push their objects."""

import dataclasses
import itertools
import json
import subprocess
import sys

import numpy as np
import pytest
from conftest import COSTLY_ENGINES, SLOWEST_ENGINES, engine_or_skip, every_engine

from simtune.engines import make_engine
from simtune.engines.contact import floor_touches, probe_contact
from simtune.tasks import TASKS, get_task
from simtune.tasks.seed import published_task
from simtune.tasks.spec import Phase

PUSHING = [name for name, task in TASKS.items() if name.startswith("seed-") and task.object is not None]


@pytest.mark.parametrize("engine", every_engine(slow=SLOWEST_ENGINES))
def test_every_engine_sees_the_hand_reach_the_cube(engine):
    """The cube task (qrg2019): no contact at rest, first contact when the arm swings into its third
    phase (t = 14 s), at the same instant in every engine."""
    sim = engine_or_skip(engine)(get_task("cube"))
    sim.reset({})
    sim.step(1)
    assert not sim.arm_object_contact()
    probe = probe_contact(sim)
    assert probe.touched and probe.stable
    assert 14.0 < probe.first_contact_s < 14.3
    sim.close()


@pytest.mark.parametrize("engine", every_engine())
def test_watching_every_step_changes_no_trajectory(engine):
    """A rollout that calls back after every physics step is the same rollout."""
    sim = engine_or_skip(engine)(get_task("cube"))
    params = {"timestep": 0.004}
    plain = sim.rollout(params, 60)
    calls = []
    watched = sim.rollout(params, 60, after_step=lambda: calls.append(1))
    np.testing.assert_array_equal(plain.wrist_pos, watched.wrist_pos)
    np.testing.assert_array_equal(plain.object_pos, watched.object_pos)
    assert len(calls) == watched.steps == plain.steps
    sim.close()


@pytest.mark.parametrize("task", PUSHING)
def test_every_pushing_seed_task_moves_its_object_in_mujoco(task):
    """The generic MuJoCo simulation of each seed task with an object touches it and pushes it at least 1 cm."""
    probe = probe_contact(make_engine("mujoco", get_task(task)))
    assert probe.touched, f"{task}: the hand never touches the object"
    assert probe.object_displacement_m > 0.01, f"{task}: object moved {probe.object_displacement_m * 1000:.1f} mm"


@pytest.mark.parametrize("engine", every_engine(slow=COSTLY_ENGINES))
def test_every_pushing_seed_task_is_touched_in_every_engine(engine):
    """The contact table of docs/seed-tasks.md: every engine's hand reaches every seed task's object and
    pushes it at least 1 cm (in PyBullet and DART the cylinder of tasks 5 and 6 then rolls past the
    blow-up limit, as that page says: stability is not asserted here)."""
    cls = engine_or_skip(engine)
    for task in PUSHING:
        sim = cls(get_task(task))
        probe = probe_contact(sim)
        sim.close()
        assert probe.touched, f"{engine} on {task}: the hand never touches the object"
        assert probe.object_displacement_m > 0.01, f"{engine} on {task}: moved {probe.object_displacement_m:.4f} m"


def test_the_published_schedules_miss_their_objects():
    """Why the seed schedules carry a fix: as the authors' code gives them, the hand passes the object."""
    for number in (3, 5, 7, 9):
        probe = probe_contact(make_engine("mujoco", published_task(number)))
        assert not probe.touched, f"seed-{number}"


def test_a_task_without_an_object_has_no_contact_to_probe():
    sim = make_engine("mujoco", get_task("single"))
    sim.reset({})
    assert not sim.arm_object_contact()
    with pytest.raises(ValueError, match="no object"):
        probe_contact(sim)


def test_cli_contact_json_lines_and_figure(tmp_path):
    proc = subprocess.run(
        [
            sys.executable, "-m", "simtune.cli", "tasks", "--contact", "--engine", "mujoco", "--task",
            "seed-3,cube", "--json", "--figure", str(tmp_path),
        ],
        capture_output=True, text=True, check=True,
    )  # fmt: skip
    rows = [json.loads(line) for line in proc.stdout.splitlines()]
    assert [r["task"] for r in rows] == ["seed-3", "cube"]
    for row in rows:
        assert list(row) == ["task", "engine", "touched", "first_contact_s", "object_displacement_m"]
        assert row["engine"] == "mujoco" and row["touched"] is True
        assert isinstance(row["first_contact_s"], float) and row["object_displacement_m"] > 0
    assert (tmp_path / "contact-mujoco.png").stat().st_size > 10_000


def test_cli_contact_refuses_tasks_without_objects_and_stray_options():
    run = [sys.executable, "-m", "simtune.cli", "tasks"]
    proc = subprocess.run([*run, "--contact", "--task", "single"], capture_output=True, text=True)
    assert proc.returncode == 2 and "has no object" in proc.stderr
    proc = subprocess.run([*run, "--json"], capture_output=True, text=True)
    assert proc.returncode == 2 and "--contact" in proc.stderr
    proc = subprocess.run([*run, "--contact", "--engine", "bullet"], capture_output=True, text=True)
    assert proc.returncode == 2 and "unknown engine" in proc.stderr


def _lowered(task, shoulder_deg: float, elbow_deg: float):
    """``task`` with one phase that swings the MICO's shoulder (joint 2) and elbow (joint 3) to the angles given."""
    targets = (0.0, shoulder_deg, elbow_deg, 0.0, 0.0, 0.0)
    return dataclasses.replace(task, phases=(Phase(0.0, targets),))


#: the engines that report floor contact (ODE and MuJoCo Warp do not: the check then says it cannot tell)
FLOOR_REPORTING = ["mujoco", "pybullet", *(pytest.param(e, marks=pytest.mark.slow) for e in sorted(COSTLY_ENGINES))]


@pytest.mark.parametrize("engine", FLOOR_REPORTING)
def test_floor_touches_are_where_the_hand_reaches_the_floor(engine):
    """`single` never touches the floor; swung 130 deg down at the shoulder, the arm lands on it after its swing,
    in every engine that reports floor contact."""
    task = get_task("single")
    assert floor_touches(engine_or_skip(engine)(task)) == []
    spans = floor_touches(engine_or_skip(engine)(_lowered(task, -130.0, 0.0)))
    assert len(spans) >= 1
    assert 2.0 < spans[0][0] < 5.0
    assert all(a <= b < c for (a, b), (c, _) in itertools.pairwise(spans))
    # folded the other way at the elbow, the same shoulder swing stays clear
    assert floor_touches(engine_or_skip(engine)(_lowered(task, -130.0, -90.0))) == []


def test_an_engine_without_floor_contacts_says_so():
    """An engine that does not report floor contact raises rather than answering 'no touch'; the check then
    reports None (cannot tell), not an empty list."""
    from simtune.check.task import _floor_touches
    from simtune.engines.contact import generic_floor_touches

    sim = engine_or_skip("ode")(get_task("single"))
    with pytest.raises(NotImplementedError):
        sim.arm_floor_contact()
    assert _floor_touches(sim) is None and generic_floor_touches(sim) is None
    assert _floor_touches(make_engine("mujoco", get_task("cube"))) == []  # a task with an object: not asked
