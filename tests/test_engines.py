"""Engines behind one interface: every task runs, runs are deterministic, blow-ups are caught,
and every tunable parameter of every engine acts on a rollout (or is declared inactive, with why).

Every test runs over the engine registry (`simtune.engines.ENGINES`), so a new engine is tested
as soon as it is registered; an engine that is not installed is skipped with its install command.
"""

import dataclasses
import re

import numpy as np
import pytest
from conftest import COSTLY_ENGINES, SLOWEST_ENGINES, engine_or_skip, every_engine

from simtune.engines import ENGINES, engine_class
from simtune.engines.base import GROUP_KINDS, Rollout
from simtune.errors import ConfigError
from simtune.fitness import marker_positions
from simtune.params import get_space
from simtune.tasks import TASKS, get_task
from simtune.tasks.spec import MATERIALS, SHAPES, Phase, TaskSpec


@pytest.mark.parametrize("engine", every_engine(slow=SLOWEST_ENGINES))
def test_every_task_runs_with_generic_parameters(engine):
    cls = engine_or_skip(engine)
    for task in TASKS.values():
        sim = cls(task)
        n = int(min(task.duration, 10.0) * 20) + 1
        roll = sim.rollout({"timestep": 0.005}, n)
        assert roll.stable, f"{engine} {task.name}: {roll.message}"
        assert roll.wrist_pos.shape == (n, 3)
        assert (roll.object_pos is None) == (task.object is None)
        sim.close()


@pytest.mark.parametrize("engine", every_engine(slow=SLOWEST_ENGINES))
def test_cube_rollout_is_deterministic(engine):
    """Same parameters, same trajectory, whatever the engine simulated before (no state
    such as cached contacts may leak from one rollout into the next)."""
    sim = engine_or_skip(engine)(get_task("cube"))
    params = {"timestep": 0.004, "lateral_friction_plastic": 0.8, "command_delay": 0.5}
    a = sim.rollout(params, 401)
    generic = sim.rollout({}, 401)
    space = get_space("extended", sim.supported())
    rng = np.random.default_rng(0)
    for _ in range(5):
        sim.rollout({p.name: rng.uniform(p.low, p.high) for p in space.parameters}, 81)
    # a whole rollout on a slippery floor: the cube still slides at its end (DART's sleep clocks outlived it)
    floor = {p.name: p.low for p in space.parameters if p.name == "lateral_friction_floor"}
    sim.rollout(floor, 401)
    again = sim.rollout({}, 401)
    b = sim.rollout(params, 401)
    for first, second in ((a, b), (generic, again)):
        np.testing.assert_array_equal(first.wrist_pos, second.wrist_pos)
        np.testing.assert_array_equal(first.object_pos, second.object_pos)
    # and as from a fresh engine: what an engine keeps from one reset to the next (ODE its hull geoms, PyBullet an
    # object-free scene, DART its world) changes nothing
    fresh = engine_or_skip(engine)(get_task("cube"))
    alone = fresh.rollout({}, 401)
    np.testing.assert_array_equal(alone.wrist_pos, again.wrist_pos)
    np.testing.assert_array_equal(alone.object_pos, again.object_pos)
    fresh.close()
    sim.close()


# --- every tunable parameter acts --------------------------------------------------------------------
#: The smallest change [m] of the marker, of a point 10 cm out on the hand, or of the object, at any
#: sample, that counts as the rollout changing: far above rounding (two runs with one parameter set
#: agree exactly; a parameter an engine's model overrides moves things by 1e-11 m or less), far
#: below what motion capture resolves.
TOLERANCE = 1e-7
#: 2 s at 20 Hz: the arm probe moves every joint, the push probes touch their object after 0.2-0.35 s.
SAMPLES = 41

#: Every joint at once from the zero pose, nothing to touch: the per-joint parameters act here.
ARM_PROBE = TaskSpec(
    name="probe-arm",
    description="all six joints move at once, no object",
    duration=2.0,
    phases=(Phase(0.0, (30, -60, 40, 60, 60, 60)),),
    kp=10.0,
)


#: Where each shape lies for the push [m]: in the hand's path (the lying cone is low, so further
#: out); the cube 2 cm off the hand's centre line, so that the push also turns it (spinning friction
#: acts: the cube is the object of the probes for the surface parameters).
PUSH_AT = {"cube": (0.5, 0.02), "cylinder": (0.5, 0.0), "cone": (0.56, 0.0), "cuboid": (0.5, 0.0)}


def push_probe(shape: str, material: str) -> TaskSpec:
    """The last move of `cube` made short (it starts where that move starts) and hard: the hand
    drives forward and down through the seed tasks' ``material`` ``shape`` into the floor, so the
    object is pushed and pressed and the motors reach their force limits."""
    cube = get_task("cube")
    obj = next(
        t.object for t in TASKS.values() if t.object and (t.object.shape, t.object.material) == (shape, material)
    )
    return dataclasses.replace(
        cube,
        name=f"probe-push-{shape}-{material}",
        description=f"the gripper pushes the {material} {shape} and presses into the floor",
        duration=2.0,
        start_pose_deg=(0, -60, 65, 90, 0, 0),
        phases=(Phase(0.0, (0, -90, 30, 90, 0, 0)),),
        object=dataclasses.replace(obj, xy=PUSH_AT[shape]),
    )


PUSH_PROBES = {(shape, material): push_probe(shape, material) for shape in SHAPES for material in MATERIALS}


def probes_for(name: str) -> list[TaskSpec]:
    """The probe tasks where parameter ``name`` can act: a push of its object (a plastic cube when the
    parameter names no object), then the arm probe."""
    shape, material = "cube", "plastic"
    for s in SHAPES:
        for m in MATERIALS:
            if name == f"mass_{s}_{m}":
                shape, material = s, m
    for m in MATERIALS:
        if name.endswith(f"_{m}"):
            material = m
    return [PUSH_PROBES[(shape, material)], ARM_PROBE]


def partners(name: str, space) -> dict[str, float]:
    """For a surface parameter, every other group's value of the same kind at its upper bound.

    Engines combine the two touching surfaces' values (product, geometric mean, smaller or larger
    of the two): with the generic partner at 0 (restitution, ODE's rolling friction) a surface
    cannot act at all, so it is also tried against partners that let it.
    """
    kind = next((k for k in GROUP_KINDS if name.startswith(f"{k}_")), None)
    if kind is None:
        return {}
    return {p.name: p.high for p in space.parameters if p.name.startswith(f"{kind}_") and p.name != name}


def seen(roll: Rollout, params: dict[str, float]) -> np.ndarray:
    """What a rollout shows: marker track (offset included), a point 10 cm out on the hand along
    each hand axis (so turning the hand about the wrist shows), object track."""
    parts = [marker_positions(roll, params), roll.wrist_rot.reshape(len(roll.times), 9) * 0.1]
    if roll.object_pos is not None:
        parts.append(roll.object_pos)
    return np.hstack(parts)


class Probe:
    """One engine on one probe task, with the rollouts it starts from cached."""

    def __init__(self, cls, task: TaskSpec, space):
        self.sim, self.space = cls(task), space
        self._references: dict[tuple, np.ndarray] = {}

    def seen(self, params: dict[str, float]) -> np.ndarray:
        return seen(self.sim.rollout(params, SAMPLES), params)

    def largest_change(self, name: str) -> float:
        """The largest change [m] of what the rollout shows when ``name`` goes to either bound, from
        generic values and, for a surface parameter that shows nothing there, from partners that let it act."""
        param = next(p for p in self.space.parameters if p.name == name)
        change = 0.0
        together = partners(name, self.space)
        for base in [{}, together] if together else [{}]:
            if change > TOLERANCE:
                break
            key = tuple(sorted(base.items()))
            if key not in self._references:
                self._references[key] = self.seen(base)
            for value in (param.low, param.high):
                moved = np.abs(self.seen({**base, name: value}) - self._references[key]).max()
                change = max(change, float(moved))
        return change


# PyBullet's (11 s) and ODE's (5 s) in the slow tier too: MuJoCo's keeps the default tier under its 4 minutes
@pytest.mark.parametrize("engine", every_engine(slow=COSTLY_ENGINES | {"pybullet", "ode"}))
def test_every_parameter_changes_a_rollout_where_it_can_act_or_is_declared_inactive(engine):
    """For each parameter of the engine's `calibrated` space (`extended` and calibration): going to a
    bound changes the rollout on a probe task where the engine does not declare it inactive, or the
    engine declares it inactive on every probe; and where it is declared inactive, it really changes nothing."""
    cls = engine_or_skip(engine)
    space = get_space("calibrated", cls.supported())
    probes: dict[str, Probe] = {}
    silent, false_claims = [], []
    for param in space.parameters:
        measured, acts, everywhere_declared = [], False, True
        for task in probes_for(param.name):
            if task.name not in probes:
                probes[task.name] = Probe(cls, task, space)
            change = probes[task.name].largest_change(param.name)
            measured.append(f"{change:.1e} m on {task.name}")
            why = cls.inactive_parameters(task).get(param.name)
            if why is None:
                everywhere_declared = False
                acts = change > TOLERANCE
                if acts:
                    break
            elif change > TOLERANCE:
                false_claims.append(f"{param.name} on {task.name}: declared inactive ({why}), yet moves {change:.1e} m")
        if not acts and not everywhere_declared:
            silent.append(f"{param.name}: {', '.join(measured)}")
    for probe in probes.values():
        probe.sim.close()
    assert not false_claims, f"{engine}: declared inactive, but acting:\n" + "\n".join(false_claims)
    assert not silent, f"{engine}: changing nothing, not declared inactive:\n" + "\n".join(silent)


@pytest.mark.parametrize("engine", every_engine())
def test_inactive_parameters_are_named_and_supported(engine):
    cls = engine_or_skip(engine)
    for task in [*TASKS.values(), ARM_PROBE, *PUSH_PROBES.values()]:
        for name, why in cls.inactive_parameters(task).items():
            assert name in cls.supported() and why.strip(), (engine, task.name, name)
    single = cls.inactive_parameters(get_task("single"))
    assert "mass_cube_plastic" in single and "lateral_friction_gripper" in single
    cube = cls.inactive_parameters(get_task("cube"))
    assert "mass_cube_plastic" not in cube and "mass_cube_wood" in cube
    assert not {f"{kind}_plastic" for kind in GROUP_KINDS} & set(cube)
    assert {f"{kind}_wood" for kind in GROUP_KINDS} & cls.supported() <= set(cube)


# --- generic values, motors, blow-ups ----------------------------------------------------------------
#: Each engine's own generic values of some parameters, read from its library or documentation (a newly
#: registered engine adds its own here, under its registry name).
OWN_GENERIC = {
    "mujoco": {"timestep": 0.002, "lateral_friction_plastic": 1.0},
    "pybullet": {"timestep": 1 / 240, "lateral_friction_plastic": 0.5},
    # ODE has neither a default step nor a default surface: simtune's generic values
    "ode": {"timestep": 0.005, "lateral_friction_plastic": 1.0, "restitution_floor": 0.0},
    # World's step, DynamicsAspect's friction
    "dart": {"timestep": 0.001, "lateral_friction_plastic": 1.0, "restitution_floor": 0.0},
    # MultibodyPlantConfig, the URDF parser's friction
    "drake": {"timestep": 0.001, "lateral_friction_gripper": 1.0},
}


def generic_values(engine: str) -> dict[str, float]:
    """``engine``'s generic values: its own, or, for an engine the registry exports as another's model (MuJoCo
    Warp: the MuJoCo engine's model and mapping), that engine's."""
    exporter = ENGINES[engine].exporter
    if engine not in OWN_GENERIC:
        model = next((name for name in OWN_GENERIC if ENGINES[name].exporter == exporter), None)
        assert model is not None, f"add {engine}'s own generic values to OWN_GENERIC in {__file__}"
        return OWN_GENERIC[model]
    return OWN_GENERIC[engine]


@pytest.mark.parametrize("engine", every_engine())
def test_generic_defaults_are_the_engines_own(engine):
    sim = engine_or_skip(engine)(get_task("cube"))
    defaults = sim.defaults()
    for name, value in generic_values(engine).items():
        assert defaults[name] == pytest.approx(value), name
    # a generic value for every engine parameter the task uses
    used = sim.engine_parameters - set(sim.inactive_parameters(sim.task))
    assert not used - set(defaults), f"{engine}: no generic value for {sorted(used - set(defaults))}"


@pytest.mark.parametrize("engine", every_engine())
def test_max_torque_limits_the_motor(engine):
    """With a 0.5 N m limit joint 2 cannot follow its command.

    Where the motor also holds the arm up, the arm falls ahead of the command; MuJoCo and Drake
    compensate gravity outside the motor, so there the weak motor lags behind instead.
    """
    sim = engine_or_skip(engine)(get_task("single"))
    free = np.degrees(sim.rollout({}, 61).joint_angles[-1, 1])
    weak = np.degrees(sim.rollout({"max_torque_joint_2": 0.5}, 61).joint_angles[-1, 1])
    assert free == pytest.approx(-90.0, abs=1.5)
    assert abs(weak - free) > 5.0, f"{engine}: joint 2 at {weak:.1f} deg with a 0.5 N m motor, {free:.1f} without"


def test_explosion_ends_rollout_with_a_flag_not_a_crash():
    sim = engine_class("mujoco")(get_task("cube"))
    stiff = {f"servo_gain_joint_{i}": 1e7 for i in range(1, 7)}  # a servo no integrator survives at this step
    roll = sim.rollout({"timestep": 0.05, **stiff, **{f"max_torque_joint_{i}": 100 for i in range(1, 7)}}, 100)
    assert not roll.stable and "unstable" in roll.message
    assert np.all(np.isfinite(roll.wrist_pos))


def test_state_check_finds_the_first_broken_sample_of_a_block():
    from simtune.engines.base import _first_bad

    pos = np.tile([0.3, 0.0, 0.8], (10, 1))
    rot = np.tile(np.eye(3), (10, 1, 1))
    q = np.zeros((10, 6))
    obj = np.tile([0.5, 0.0, 0.1], (10, 1))
    assert _first_bad(pos, rot, q, obj, obj[0]) == (None, "")
    pos[6] = [3.0, 0.0, 0.0]
    q[4, 2] = np.nan
    obj[2] = [9.0, 0.0, 0.1]
    assert _first_bad(pos, rot, q, obj, obj[0]) == (2, "object thrown 8.5 m")
    assert _first_bad(pos, rot, q, None, None) == (4, "non-finite arm state")
    q[4, 2] = 0.0
    assert _first_bad(pos, rot, q, None, None) == (6, "wrist 3.0 m from the base")


@pytest.mark.parametrize("engine", list(ENGINES))
def test_every_part_the_registry_names_is_there(engine):
    """Each entry's engine class, exporter and replay import by their module paths, with or without the
    engine's library (which only the engine itself needs, when it builds a scene)."""
    from simtune.engines import Engine, load_part
    from simtune.engines.replay_base import FromFiles

    entry = ENGINES[engine]
    assert issubclass(entry.engine_class(), Engine) and entry.engine_class().name == engine
    assert callable(load_part(entry.exporter))
    if entry.replay is not None:
        assert issubclass(load_part(entry.replay), FromFiles)


def test_unknown_engine_is_a_clear_error():
    with pytest.raises(ConfigError, match="unknown engine 'ode2'.*mujoco"):
        engine_class("ode2")


def test_the_tests_of_a_missing_engine_skip_with_its_install_command(monkeypatch):
    """On a machine without an engine's library (ODE without Debian's libode8, say), the engine's
    tests skip, and the reason is the registry's install command."""
    from simtune.engines.mujoco import engine as mujoco_engine

    monkeypatch.setattr(mujoco_engine, "mujoco", None)  # as on a machine without the mujoco package
    with pytest.raises(pytest.skip.Exception, match=re.escape(ENGINES["mujoco"].install)):
        engine_or_skip("mujoco")
