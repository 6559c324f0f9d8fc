import pytest

from simtune.engines import engine_class
from simtune.errors import ConfigError
from simtune.params import SPACES, get_space, read_params_file, validate_params


def test_space_sizes_match_the_paper():
    assert len(SPACES["shared"]) == 31
    assert len(SPACES["individual"]) == 57
    assert len(SPACES["extended"]) == 61
    assert len(SPACES["calibrated"]) == 72  # extended + 6 encoder offsets + 5 compliances (joint 1 never loaded)
    # the MICO's drive train (per joint the armature, Coulomb friction, controller gain and servo gain) only in its
    # own space, so that its other spaces and every number measured with them stay as they were
    assert len(SPACES["drivetrain"]) == 72 + 4 * 6
    assert {p.name for p in SPACES["drivetrain"][72:]} >= {
        "armature_joint_1",
        "friction_joint_6",
        "kp_joint_3",
        "servo_gain_joint_2",
    }


def test_gains_is_calibrated_plus_the_gains_in_the_drive_train_s_order():
    calibrated, gains, drivetrain = (SPACES[s] for s in ("calibrated", "gains", "drivetrain"))
    assert gains[:72] == calibrated
    assert {p.name for p in gains[72:]} == {f"{k}_joint_{i}" for k in ("kp", "servo_gain") for i in range(1, 7)}
    assert list(gains) == [p for p in drivetrain if p in gains]  # a run of drivetrain --only these is the same search
    assert list(SPACES).index("gains") == list(SPACES).index("calibrated") + 1
    assert get_space("gains", engine_class("pybullet").supported()).names[-6:] == [f"kp_joint_{i}" for i in range(1, 7)]


def test_the_drive_train_is_in_extended_for_an_own_robot():
    from dataclasses import replace

    from simtune.params.space import robot_spaces
    from simtune.robot.mico import MICO

    own = replace(MICO, name="my_arm")  # any robot but the bundled MICO
    names = [p.name for p in robot_spaces(own)["extended"]]
    assert "armature_joint_1" in names and "kp_joint_6" in names and "servo_gain_joint_4" in names
    assert len(robot_spaces(own)["drivetrain"]) == len(robot_spaces(own)["calibrated"])
    assert robot_spaces(own)["gains"] == robot_spaces(own)["calibrated"]


def test_ranges_of_table_one():
    p = {x.name: x for x in SPACES["extended"]}
    assert (p["timestep"].low, p["timestep"].high) == (0.001, 0.05)
    assert p["mass_link_1"].low == pytest.approx(0.7 * 0.7477)
    assert p["mass_cube_wood"].high == pytest.approx(1.3 * 0.46)
    assert (p["max_torque_joint_3"].low, p["max_torque_joint_3"].high) == (100, 9000)
    assert (p["max_velocity_joint_6"].low, p["max_velocity_joint_6"].high) == (10, 40)
    assert p["restitution_wood"].high == 0.9 and p["rolling_friction_floor"].high == 1.25
    assert (p["command_delay"].low, p["command_delay"].high) == (0, 3)


def test_engines_leave_out_what_they_lack():
    mujoco_space = get_space("individual", engine_class("mujoco").supported())
    assert "restitution_plastic" not in mujoco_space.names
    assert "lateral_friction_plastic" in mujoco_space.names
    bullet_space = get_space("individual", engine_class("pybullet").supported())
    assert "restitution_plastic" in bullet_space.names
    assert "linear_damping_floor" not in bullet_space.names
    assert len(get_space("shared", engine_class("pybullet").supported())) == 31


def test_only_restricts_and_checks_names():
    assert get_space("extended", None, ["command_delay", "timestep"]).names == ["timestep", "command_delay"]
    with pytest.raises(ConfigError, match="not in space"):
        get_space("shared", None, ["command_delay"])
    with pytest.raises(ConfigError, match="unknown parameter"):
        get_space("shared", None, ["gravity"])


def test_validation_names_the_problem(tmp_path):
    supported = engine_class("mujoco").supported()
    with pytest.raises(ConfigError, match="unknown parameter 'gravity'"):
        validate_params({"gravity": 1.0}, supported, "mujoco")
    with pytest.raises(ConfigError, match="no parameter 'restitution_wood'"):
        validate_params({"restitution_wood": 0.5}, supported, "mujoco")
    with pytest.raises(ConfigError, match=r"outside its range \[0.001, 0.05\]"):
        validate_params({"timestep": 0.5}, supported, "mujoco")
    with pytest.raises(ConfigError, match="not a number"):
        validate_params({"timestep": "fast"}, supported, "mujoco")
    bad = tmp_path / "p.json"
    bad.write_text('{"timestep": 0.01,\n "x": }')
    with pytest.raises(ConfigError, match="p.json line 2"):
        read_params_file(bad)
    with pytest.raises(ConfigError, match="no such parameter file"):
        read_params_file(tmp_path / "missing.json")


@pytest.mark.parametrize(
    ("content", "message"),
    [
        ('{"command_delay": true}', r"parameter 'command_delay': true is not a number"),
        ('{"command_delay": "0.5"}', r"parameter 'command_delay': \"0.5\" is not a number"),
        ('{"command_delay": null}', r"parameter 'command_delay': null is not a number"),
        ('{"command_delay": [1]}', r"parameter 'command_delay': \[1\] is not a number"),
        ('{"params": {"timestep": false}}', r"parameter 'timestep': false is not a number"),
        ("{}", "no parameter values in it"),
        ('{"params": {}}', "no parameter values in it"),
        ("[0.01, 1.4]", "expected a JSON object .* got list"),
        ("0.5", "expected a JSON object .* got float"),
        ('"timestep"', "expected a JSON object .* got str"),
        ('{"params": [0.01]}', "field 'params' must be an object"),
        ('{"space": "huge", "params": {"timestep": 0.01}}', "field 'space': unknown parameter space 'huge'"),
        ('{"space": "shared", "params": {"command_delay": 1.0}}', "'command_delay' is not in space 'shared'"),
        ('{"engine": "ode", "params": {"timestep": 0.01}}', "field 'engine' says these values are for 'ode'"),
    ],
)
def test_params_files_are_refused_naming_file_and_field(content, message, tmp_path):
    path = tmp_path / "p.json"
    path.write_text(content)
    supported = engine_class("mujoco").supported()
    with pytest.raises(ConfigError, match=message) as caught:
        validate_params(read_params_file(path, "mujoco"), supported, "mujoco", where=str(path))
    assert str(caught.value).startswith(str(path))


def test_params_file_of_its_own_engine_and_space_and_with_a_bom_is_read(tmp_path):
    path = tmp_path / "best_params.json"
    text = '{"engine": "mujoco", "space": "extended", "parameters": ["timestep"], "params": {"timestep": 0.01}}'
    path.write_bytes(b"\xef\xbb\xbf" + text.encode())
    assert read_params_file(path, "mujoco") == {"timestep": 0.01}
