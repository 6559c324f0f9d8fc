"""The Python API refuses values that mean nothing with one ConfigError naming the argument (issue 50, item 10):
negative or string worker counts, worker counts past simtune.common.limits.MAX_WORKERS (10**6 used to fork until the
machine stalled), negative budgets and sample counts (sensitivity_evaluations(..., -5) returned -270), None
where a count is due."""

from pathlib import Path

import pytest

import simtune.api as st
from simtune.common.limits import MAX_WORKERS
from simtune.errors import ConfigError


@pytest.mark.parametrize("workers", [0, -1, "2", 2.0, None, True, MAX_WORKERS + 1, 10**6])
def test_worker_counts_out_of_range_or_of_the_wrong_type_are_refused(workers, tmp_path):
    with pytest.raises(ConfigError, match=rf"workers must be an integer from 1 to {MAX_WORKERS}, got"):
        st.run_config("mujoco", "cube", workers=workers)
    with pytest.raises(ConfigError, match="workers must be an integer"):
        st.uncertainty(tmp_path, workers=workers)
    with pytest.raises(ConfigError, match="workers must be an integer"):
        st.demo(tmp_path / "demo", workers=workers)


@pytest.mark.parametrize(
    ("settings", "message"),
    [
        ({"max_evaluations": -5}, "max_evaluations must be an integer of at least 1"),
        ({"max_seconds": -1.0}, "max_seconds must be a finite number of seconds above 0"),
        ({"max_seconds": float("nan")}, "max_seconds must be a finite number"),
        ({"max_generations": 0}, "max_generations must be an integer of at least 1"),
        ({"seed": None}, "seed must be an integer"),
        ({"seed": -1}, "seed must be an integer"),
        ({"target_fitness": -0.1}, "target_fitness must be a finite number of at least 0"),
    ],
)
def test_budgets_that_mean_nothing_are_refused_before_anything_runs(settings, message):
    with pytest.raises(ConfigError, match=message):
        st.run_config("mujoco", "cube", **settings)


def test_sample_counts_seeds_and_budgets_of_the_studies_are_checked(tmp_path):
    with pytest.raises(ConfigError, match="samples must be an integer of at least 2, got -5"):
        st.sensitivity_evaluations("mujoco", "shared", "morris", -5)
    assert st.sensitivity_evaluations("mujoco", "shared", "morris", 2) > 0
    with pytest.raises(ConfigError, match="budget must be an integer of at least 1"):
        st.compare("mujoco", "cube", out=tmp_path / "c", budget=-3)
    with pytest.raises(ConfigError, match="seeds must be an integer of at least 1"):
        st.compare("mujoco", "cube", out=tmp_path / "c", seeds="3")
    with pytest.raises(ConfigError, match="max_seconds must be a finite number of seconds above 0"):
        st.demo(tmp_path / "demo", max_seconds=-3)
    assert not (tmp_path / "c").exists() and not (tmp_path / "demo").exists()


def test_only_parameters_that_change_no_rollout_are_refused_before_the_search(tmp_path):
    """`tune --only P` with P inactive used to run its whole budget, then blame --keep-inactive, a flag not given."""
    from simtune.errors import RecordingWarning
    from simtune.run_plan import plan_run

    config = st.run_config("mujoco", "cube", only="max_velocity_joint_1", max_seconds=30)
    with pytest.raises(ConfigError, match=r"--only: it changes no rollout of cube \(max_velocity_joint_1: task 'cube'"):
        st.start(config, tmp_path / "run")
    assert not (tmp_path / "run").exists()
    mixed = plan_run(st.run_config("mujoco", "cube", only="max_velocity_joint_1,command_delay"))
    with pytest.warns(RecordingWarning, match="max_velocity_joint_1 change"):
        assert mixed.search_space().names == ["max_velocity_joint_1", "command_delay"]


# --- probe 5 (issue 71) #21-#24, #43: every public function names the argument it refuses -----------------------

MJCF_ARM = Path(__file__).resolve().parent / "fixtures" / "mjcf_arm" / "arm.xml"


def test_driven_joints_given_as_one_string_are_names_joined_by_commas_and_an_empty_list_is_refused(tmp_path):
    """A str used to be read letter by letter ("joint 'j' is not a joint of the MJCF"), [] as "no hinge joint to
    drive": a str is names joined by commas, as ``--driven-joints`` and the API's other name lists read it."""
    loaded: list = []
    st.init_project(MJCF_ARM, tmp_path / "one", driven_joints="j1, j2,j3,j4", loaded=loaded)
    assert list(loaded[0].arm_joints) == ["j1", "j2", "j3", "j4"]
    for empty in ([], "", " , "):
        with pytest.raises(ConfigError, match=r"^driven_joints: names nothing"):
            st.init_project(MJCF_ARM, tmp_path / "none", driven_joints=empty)
    assert not (tmp_path / "none").exists()


@pytest.mark.parametrize(
    ("call", "message"),
    [
        (lambda tmp: st.check_project(None), r"^path: expected a file or folder"),
        (lambda tmp: st.check_project(5), r"^path: expected a file or folder"),
        (lambda tmp: st.check_project(tmp, engines=5), r"^engines: expected names"),
        (lambda tmp: st.init_project(None, tmp / "p"), r"^urdf: expected a file or folder"),
        (lambda tmp: st.init_project(5, tmp / "p"), r"^urdf: expected a file or folder"),
        (lambda tmp: st.init_project(MJCF_ARM, None), r"^out: expected a file or folder"),
        (lambda tmp: st.init_project(MJCF_ARM, tmp / "p", driven_joints=5), r"^driven_joints: expected names"),
        (lambda tmp: st.init_project(MJCF_ARM, tmp / "p", package_path=5), r"^package_path: expected folders"),
        (lambda tmp: st.init_project(MJCF_ARM, tmp / "p", tracked_link=5), r"^tracked_link: expected a link name"),
        (lambda tmp: st.init_project(MJCF_ARM, tmp / "p", density="1"), r"^density must be a finite number, got '1'"),
        (lambda tmp: st.export(None, tmp / "e"), r"^run_dirs: expected a run folder"),
        (lambda tmp: st.export([tmp], None), r"^out: expected a file or folder"),
        (lambda tmp: st.export(tmp, tmp / "e", force="yes"), r"^force must be True or False"),
        (lambda tmp: st.plan_grid(None), r"^spec: expected a GridSpec"),
        (lambda tmp: st.grid(None, tmp / "g"), r"^spec: expected a GridSpec"),
        (lambda tmp: st.start(None, tmp / "r"), r"^config: expected a RunConfig"),
        (lambda tmp: st.synth(out=tmp / "s", repeats="2"), r"^repeats must be an integer from 1 to 1000"),
        (lambda tmp: st.synth(out=tmp / "s", repeats=2.5), r"^repeats must be an integer from 1 to 1000"),
        (lambda tmp: st.synth(out=tmp / "s", noise_m="0.002"), r"^noise_m must be a finite number"),
        (lambda tmp: st.evaluate(params={"kp_joint_2": 10**400}), r"^params: parameter 'kp_joint_2' = an integer"),
    ],
    ids=[
        "check_project-None",
        "check_project-5",
        "check_project-engines",
        "init_project-None",
        "init_project-5",
        "init_project-out-None",
        "init_project-driven_joints-5",
        "init_project-package_path-5",
        "init_project-tracked_link-5",
        "init_project-density-str",
        "export-None",
        "export-out-None",
        "export-force-yes",
        "plan_grid-None",
        "grid-None",
        "start-None",
        "synth-repeats-str",
        "synth-repeats-float",
        "synth-noise_m-str",
        "evaluate-10**400",
    ],
)
def test_an_argument_of_the_wrong_type_is_a_config_error_naming_it_not_a_raw_type_error(call, message, tmp_path):
    with pytest.raises(ConfigError, match=message):
        call(tmp_path)
    assert not [p.name for p in tmp_path.iterdir()]  # refused before anything is written


def test_synth_takes_its_own_keywords_alone():
    """synth's recording settings are its own keyword arguments: an unknown one is python's TypeError naming synth
    (it used to name make_synthetic, a function the caller never called)."""
    with pytest.raises(TypeError, match=r"^synth\(\) got an unexpected keyword argument 'bogus'"):
        st.synth(out="unused", bogus=1)


@pytest.mark.parametrize(
    ("settings", "message"),
    [
        ({"repeats": 10**7}, r"^repeats must be an integer from 1 to 1000, got 10000000"),
        ({"seed": -1}, rf"^seed must be an integer from 0 to {2**32 - 1}, got -1"),
        ({"seed": 2**40}, rf"^seed must be an integer from 0 to {2**32 - 1}"),
        ({"force": "yes"}, r"^force must be True or False, got 'yes'"),
        ({"noise_m": -1}, r"^noise_m must be zero or more"),
        ({"noise_m": 1000.0}, r"^noise_m: 1e\+06 mm of marker noise"),
        ({"jitter_s": 100.0}, r"^jitter_s: 100 s of jitter"),
        ({"delay_s": -1}, r"^delay_s: parameter 'command_delay' = -1 is outside its range"),
        ({"delay_s": "1.5"}, r"""^delay_s: parameter 'command_delay': "1.5" is not a number"""),
    ],
    ids=[
        "repeats-10**7",
        "seed-negative",
        "seed-2**40",
        "force-yes",
        "noise_m-negative",
        "noise_m-1000",
        "jitter_s-100",
        "delay_s-negative",
        "delay_s-str",
    ],
)
def test_synth_refuses_settings_out_of_range_naming_its_own_argument(settings, message, tmp_path):
    """No upper bound on repeats used to simulate for hours; seeds past the command line's 0..2^32-1 and a force of
    "yes" were taken; the noise and delay were refused as --noise-mm and --delay-s, options the API has not."""
    with pytest.raises(ConfigError, match=message):
        st.synth("mujoco", "single", out=tmp_path / "s", **settings)
    assert not (tmp_path / "s").exists()


def test_the_command_line_bounds_synth_repeats_alike(tmp_path, capsys):
    from test_joint_logs import cli

    code, err = cli("synth", "--task", "single", "--repeats", "1001", "--out", str(tmp_path / "s"), capsys=capsys)
    assert code == 2 and "--repeats" in err and "1000" in err, err
    assert not (tmp_path / "s").exists()


@pytest.mark.parametrize(
    ("call", "message"),
    [
        (lambda: st.sensitivity_evaluations("mujoco", "shared", "nope", 10), r"^method: unknown sensitivity method"),
        (
            lambda: st.sensitivity_evaluations("mujoco", "shared", "sobol", 3),
            r"^samples: Sobol sampling needs a power of two .*, got 3$",
        ),
        (
            lambda: st.sensitivity_evaluations("mujoco", "shared", "morris", 1),
            r"^samples must be an integer of at least 2, got 1",
        ),
        (lambda: st.grid_spec(max_seconds_per_run=-1), r"^max_seconds_per_run must be a finite number of seconds"),
        (lambda: st.grid_spec(repeats="3"), r"^repeats must be an integer"),
        (lambda: st.grid_spec(keep_inactive="no"), r"^keep_inactive must be True or False"),
    ],
    ids=["method", "sobol-samples", "samples", "max_seconds_per_run", "grid-repeats", "keep_inactive"],
)
def test_study_arguments_out_of_range_are_refused_naming_them(call, message):
    with pytest.raises(ConfigError, match=message):
        call()
    assert st.sensitivity_evaluations("mujoco", "shared", "sobol", 4) > 0


def test_an_empty_task_name_in_a_list_is_named_by_its_position():
    with pytest.raises(ConfigError, match=r"^tasks: the name at index 1 of \['single', ''\] is empty"):
        st.evaluate("mujoco", ["single", ""])


@pytest.mark.parametrize(
    ("settings", "message"),
    [
        (
            {"max_seconds": 10**400},
            "run.sqlite: max_seconds must be a finite number of seconds above 0, got an integer of about 401 digits",
        ),
        ({"seed": 10**5000}, "run.sqlite: seed must be an integer from 0 to 4294967295, got an integer of about 5001"),
        ({"workers": True}, f"run.sqlite: workers must be an integer from 1 to {MAX_WORKERS}, got True"),
        (
            {"target_fitness": 10**400},
            "run.sqlite: target_fitness must be a finite number of at least 0, got an integer of about 401 digits",
        ),
    ],
)
def test_a_stored_runs_settings_are_checked_as_the_apis_arguments_are(settings, message):
    """A run's settings (RunConfig.check: a stored run, a grid's cell) and the API's arguments share one set of
    checks (simtune.common.checks): 10**400 seconds used to raise OverflowError from math.isfinite, a seed of
    10**5000 a ValueError from its repr, instead of the one line the API gives."""
    from simtune.run_config import RunConfig

    with pytest.raises(ConfigError, match=message.replace("(", r"\(")) as refused:
        RunConfig(engine="mujoco", tasks="cube", **settings).check("run.sqlite")
    assert len(str(refused.value)) < 200
