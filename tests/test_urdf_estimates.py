"""Robots whose URDF leaves things out: masses estimated from geometry where no ``<inertial>`` gives them, visual
geometry standing in where no ``<collision>`` exists, ``package://NAME`` mapped to a folder of another name, and
each warning given once (issue 46, items 1, 2, 5 and 8).

Fixtures are written here per case; the public descriptions are rtb-data's as installed (the Robotics Toolbox's
data package: a kinematic-only, visual-only Puma 560 and a kinematic-only ABB arm whose meshes are named
``package://abb_irb140_support`` in a folder ``abb_irb140_description``), used in place.
"""

from __future__ import annotations

import itertools
import math
import tomllib
import warnings
from pathlib import Path

import numpy as np
import pytest
from conftest import engine_or_skip
from robot_corpus import ENGINES, FK_TOLERANCE_M, cli, fk_error

from simtune.errors import ProjectError, RobotError, RobotWarning
from simtune.params.space import robot_spaces
from simtune.project import load_project
from simtune.robot.inertia import DEFAULT_DENSITY
from simtune.robot.urdf import FLOOR_MASS, load_urdf
from simtune.tasks.init_project import init_project

pytest.importorskip("yourdfpy")
trimesh = pytest.importorskip("trimesh")

LIMIT = '<limit lower="-2" upper="2" effort="20" velocity="2"/>'


def arm(links: dict[str, str], name: str = "kin") -> str:
    """A chain base -> links[0] -> links[1] ... (revolute joints 0.3 m apart about y, the first about z), each link
    with the inner XML given (geometry, inertial, or nothing)."""
    names = list(links)
    body = "".join(f'<link name="{n}">{inner}</link>' for n, inner in links.items())
    joints = "".join(
        f'<joint name="j{k}" type="revolute"><parent link="{parent}"/><child link="{child}"/>'
        f'<origin xyz="0 0 {0.1 if k == 1 else 0.3}"/><axis xyz="{"0 0 1" if k == 1 else "0 1 0"}"/>{LIMIT}</joint>'
        for k, (parent, child) in enumerate(itertools.pairwise(names), start=1)
    )
    return f'<robot name="{name}">{body}{joints}</robot>'


def geometry(kind: str, shape: str, origin: str = "") -> str:
    return f"<{kind}>{origin}<geometry>{shape}</geometry></{kind}>"


BOX = '<box size="0.06 0.08 0.3"/>'
CYLINDER = '<cylinder radius="0.04" length="0.3"/>'
SPHERE = '<sphere radius="0.05"/>'
UP = '<origin xyz="0 0 0.15"/>'


def write(folder: Path, text: str, name: str = "arm.urdf") -> Path:
    path = folder / name
    path.write_text(text)
    return path


def kinematic_arm(folder: Path, kind: str = "collision") -> Path:
    """No <inertial> anywhere: a base box, an upper arm box, a forearm cylinder, a hand sphere."""
    return write(
        folder,
        arm(
            {
                "base": geometry(kind, BOX),
                "upper": geometry(kind, BOX, UP),
                "fore": geometry(kind, CYLINDER, UP),
                "hand": geometry(kind, SPHERE),
            }
        ),
    )


def loaded(path: Path, **options):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RobotWarning)
        return load_urdf(path, **options)


# --------------------------------------------------------------------------- masses from geometry


def test_a_kinematic_description_gets_the_masses_and_inertias_of_its_shapes(tmp_path):
    robot = load_urdf(kinematic_arm(tmp_path))  # no placeholder: no warning at all
    assert robot.estimated_masses == ("base", "upper", "fore", "hand") and robot.placeholder_masses == ()
    rho = DEFAULT_DENSITY
    box = robot.link_by_name["upper"]
    m = rho * 0.06 * 0.08 * 0.3
    assert box.mass == pytest.approx(m) and box.com == pytest.approx((0, 0, 0.15))
    assert box.inertia == pytest.approx((m / 12 * (0.08**2 + 0.3**2), m / 12 * (0.06**2 + 0.3**2), m / 12 * 0.01))
    cylinder = robot.link_by_name["fore"]
    m = rho * math.pi * 0.04**2 * 0.3
    side = m * (3 * 0.04**2 + 0.3**2) / 12
    assert cylinder.mass == pytest.approx(m) and cylinder.inertia == pytest.approx((side, side, m * 0.04**2 / 2))
    sphere = robot.link_by_name["hand"]
    m = rho * 4 / 3 * math.pi * 0.05**3
    assert sphere.mass == pytest.approx(m) and sphere.inertia == pytest.approx((0.4 * m * 0.05**2,) * 3)
    # init says in one line which links and how
    (note,) = [c for c in robot.choices if c.startswith("masses estimated")]
    assert "2700 kg/m^3" in note and all(name in note for name in robot.estimated_masses)


def test_a_mesh_link_gets_its_volume_and_inertia_and_an_open_mesh_its_hull(tmp_path):
    """A closed mesh: trimesh's volume integrals (a box mesh weighs what the box does, its offset is the centre
    of mass); a mesh that does not close a volume (a face missing): its convex hull, the same box."""
    solid = trimesh.creation.box(extents=(0.06, 0.08, 0.3))
    solid.apply_translation((0.01, 0.0, 0.15))
    solid.export(tmp_path / "closed.stl")
    trimesh.Trimesh(vertices=solid.vertices, faces=solid.faces[:-2], process=False).export(tmp_path / "open.stl")
    for mesh in ("closed.stl", "open.stl"):
        urdf = arm({"base": geometry("collision", BOX), "upper": geometry("collision", f'<mesh filename="{mesh}"/>')})
        link = loaded(write(tmp_path, urdf)).link_by_name["upper"]
        m = DEFAULT_DENSITY * 0.06 * 0.08 * 0.3
        assert link.mass == pytest.approx(m, rel=1e-6), mesh
        assert link.com == pytest.approx((0.01, 0.0, 0.15), abs=1e-6), mesh  # STL: float32
        expected = (m / 12 * (0.08**2 + 0.3**2), m / 12 * (0.06**2 + 0.3**2), m / 12 * (0.06**2 + 0.08**2))
        assert link.inertia == pytest.approx(expected, rel=1e-6), mesh
    # a scaled mesh: the volume scales with it
    urdf = arm(
        {
            "base": geometry("collision", BOX),
            "upper": geometry("collision", '<mesh filename="closed.stl" scale="2 1 1"/>'),
        }
    )
    assert loaded(write(tmp_path, urdf)).link_by_name["upper"].mass == pytest.approx(2 * m, rel=1e-6)


def test_density_and_total_mass_choose_the_scale(tmp_path):
    urdf = kinematic_arm(tmp_path)
    light = load_urdf(urdf, density=1000.0)
    default = load_urdf(urdf)
    for name in default.estimated_masses:
        assert light.link_by_name[name].mass == pytest.approx(default.link_by_name[name].mass * 1000 / 2700)
    spread = load_urdf(urdf, total_mass=12.0)
    masses = {n: spread.link_by_name[n].mass for n in spread.estimated_masses}
    assert sum(masses.values()) == pytest.approx(12.0)
    ratio = masses["upper"] / masses["fore"]  # by volume
    assert ratio == pytest.approx(default.link_by_name["upper"].mass / default.link_by_name["fore"].mass)
    assert any("12 kg (total_mass) shared by volume" in c for c in spread.choices)
    with pytest.raises(RobotError, match="density and total_mass both given"):
        load_urdf(urdf, density=1000.0, total_mass=12.0)
    with pytest.raises(RobotError, match=r"density -1 kg/m\^3 is not possible"):
        load_urdf(urdf, density=-1.0)
    given = write(tmp_path, arm({"base": "", "upper": '<inertial><mass value="1"/><inertia ixx="0.01" iyy="0.01" '
                                 'izz="0.01" ixy="0" ixz="0" iyz="0"/></inertial>' + geometry("collision", BOX)}),
                  "given.urdf")  # fmt: skip
    with pytest.raises(RobotError, match="total_mass 12 kg: no link lacks an <inertial>") as info:
        load_urdf(given, total_mass=12.0)
    assert str(given) in str(info.value) and "\n" not in str(info.value)


def test_only_a_link_without_any_geometry_gets_a_placeholder(tmp_path):
    """No <inertial> and no geometry: the placeholder, with one warning naming the links; check says the robot
    cannot be simulated as described (a problem where no moving link has a mass of its own)."""
    urdf = write(tmp_path, arm({"base": "", "upper": "", "fore": geometry("collision", BOX, UP)}))
    with pytest.warns(RobotWarning, match="link 'upper' moves but has no mass") as caught:
        robot = load_urdf(urdf)
    assert len(caught) == 1 and "cannot be simulated as described" in str(caught[0].message)
    assert robot.placeholder_masses == ("upper",) and robot.estimated_masses == ("fore",)
    assert robot.link_by_name["upper"].mass == FLOOR_MASS

    from simtune.check.project import check_project

    bare = write(tmp_path, arm({"base": "", "upper": "", "fore": ""}), "bare.urdf")
    for file, level in ((urdf, "warning"), (bare, "problem")):
        project = tmp_path / f"project-{file.stem}"
        loaded_ = []
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", RobotWarning)
            init_project(file, project, loaded=loaded_)
            findings = check_project(project, engines=("mujoco",))
        said = [f for f in findings if "cannot be simulated as described" in f.message]
        assert len(said) == 1 and said[0].level == level, findings
        assert "upper" in said[0].message and str(file) in said[0].message


# --------------------------------------------------------------------------- visual-only descriptions


def test_a_visual_only_description_collides_with_its_visual_geometry(tmp_path):
    robot = load_urdf(kinematic_arm(tmp_path, kind="visual"))
    collision = load_urdf(kinematic_arm(tmp_path))
    for name in ("upper", "fore", "hand"):
        assert robot.link_by_name[name].shapes == collision.link_by_name[name].shapes
        assert robot.link_by_name[name].mass == pytest.approx(collision.link_by_name[name].mass)
    (note,) = [c for c in robot.choices if c.startswith("no <collision> in the robot")]
    assert "base, upper, fore, hand" in note
    assert robot.gripper_surface


def test_a_link_without_collision_among_links_with_one_keeps_none_but_weighs_its_visual(tmp_path):
    """Only a description with no <collision> at all is visual-only: elsewhere a link without one stays so (its
    publisher's choice), and only its mass comes from its visual geometry."""
    urdf = arm(
        {
            "base": geometry("collision", BOX),
            "upper": geometry("visual", BOX, UP),
            "fore": geometry("collision", SPHERE),
        }
    )
    robot = loaded(write(tmp_path, urdf))
    assert robot.link_by_name["upper"].shapes == ()
    assert robot.link_by_name["upper"].mass == pytest.approx(DEFAULT_DENSITY * 0.06 * 0.08 * 0.3)
    assert any("from visual geometry: upper" in c for c in robot.choices)
    assert not any(c.startswith("no <collision>") for c in robot.choices)


def test_a_task_without_an_object_needs_no_gripper_surface_and_one_with_an_object_says_what_to_add(tmp_path):
    urdf = write(tmp_path, arm({"base": "", "upper": "", "fore": ""}))  # no geometry anywhere
    project = tmp_path / "project"
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RobotWarning)
        init_project(urdf, project)  # the reach touches nothing: init used to refuse
        task = (project / "tasks" / "reach.toml").read_text()
        obj = '[object]\nshape = "cube"\nmaterial = "plastic"\nmass = 0.1\nsize = [0.06, 0.06, 0.06]\nxy = [0.5, 0.0]\n'
        (project / "tasks" / "reach.toml").write_text(task.replace("[[phases]]", obj + "\n[[phases]]", 1))
        with pytest.raises(ProjectError) as info:
            load_project(project)
    message = str(info.value)
    assert "\n" not in message and "reach.toml" in message and "object" in message
    assert "no gripper link (fore) has a collision shape" in message and "add a <collision>" in message


# --------------------------------------------------------------------------- package NAME=DIR


def test_a_package_name_maps_to_a_folder_of_another_name(tmp_path, monkeypatch):
    monkeypatch.setenv("SIMTUNE_CACHE_DIR", str(tmp_path / "cache"))
    folder = tmp_path / "ws" / "my_arm_description"
    (folder / "meshes").mkdir(parents=True)
    trimesh.creation.box(extents=(0.04, 0.04, 0.2)).export(folder / "meshes" / "upper.stl")
    mesh = geometry("collision", '<mesh filename="package://my_arm_support/meshes/upper.stl"/>')
    urdf = write(tmp_path, arm({"base": geometry("collision", BOX), "upper": mesh}))
    with pytest.raises(RobotError, match="--package-path my_arm_support=DIR"):
        loaded(urdf, package_path=[tmp_path / "ws"])  # a folder of packages: no my_arm_support in it
    robot = loaded(urdf, package_path=[f"my_arm_support={folder}"])
    assert robot.link_by_name["upper"].mass == pytest.approx(DEFAULT_DENSITY * 0.04 * 0.04 * 0.2, rel=1e-6)
    monkeypatch.setenv("SIMTUNE_PACKAGE_PATH", f"my_arm_support={folder}")  # the variable takes it too
    assert loaded(urdf).link_by_name["upper"].shapes == robot.link_by_name["upper"].shapes
    monkeypatch.delenv("SIMTUNE_PACKAGE_PATH")

    # init writes it into the project, which loads the robot the same way
    project = tmp_path / "project"
    result = cli("init", "--robot", urdf, "--out", project, "--package-path", f"my_arm_support={folder}")
    assert result.returncode == 0, result.stderr
    table = tomllib.loads((project / "simtune.toml").read_text())["robot"]
    assert table["package_path"] == [f"my_arm_support={folder}"] and table["density"] == 2700
    assert load_project(project).robot.description.link_by_name["upper"] == robot.link_by_name["upper"]
    # a folder that is not there: one line naming it, exit 2
    bad = cli("init", "--robot", urdf, "--out", tmp_path / "p2", "--package-path", f"my_arm_support={tmp_path}/nope")
    assert bad.returncode == 2 and bad.stderr.count("\n") == 1 and "Traceback" not in bad.stderr
    assert f"no folder {tmp_path}/nope for package 'my_arm_support'" in bad.stderr
    text = (project / "simtune.toml").read_text().replace(str(folder), "nope")
    (project / "simtune.toml").write_text(text)
    with pytest.raises(ProjectError, match=r"package_path\[0\].*no folder .*nope for package 'my_arm_support'"):
        load_project(project)


# --------------------------------------------------------------------------- init, the project file, warnings once


def test_init_records_how_masses_were_estimated_and_warns_once(tmp_path):
    urdf = write(tmp_path, arm({"base": "", "upper": "", "fore": geometry("collision", BOX, UP)}))
    project = tmp_path / "project"
    result = cli("init", "--robot", urdf, "--out", project, "--total-mass", "3")
    assert result.returncode == 0, result.stderr
    assert result.stderr.count("moves but has no mass") == 1  # the placeholder of 'upper', said once
    notes = [line for line in result.stdout.splitlines() if "masses estimated" in line]
    assert len(notes) == 1 and "fore 3 kg" in notes[0]
    table = tomllib.loads((project / "simtune.toml").read_text())["robot"]
    assert table["total_mass"] == 3 and "density" not in table
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RobotWarning)
        assert load_project(project).robot.description.link_by_name["fore"].mass == pytest.approx(3.0)
    # through the API too: init loaded the robot twice, and each load warned
    with pytest.warns(RobotWarning) as caught:
        init_project(urdf, tmp_path / "again")
    assert len([w for w in caught if "moves but has no mass" in str(w.message)]) == 1
    # options that cannot be: one line each, exit 2, nothing written
    for args, words in (
        (("--density", "-5"), "--density -5: not possible"),
        (("--density", "1000", "--total-mass", "3"), "--density and --total-mass: give one"),
    ):
        bad = cli("init", "--robot", urdf, "--out", tmp_path / "bad", *args)
        assert bad.returncode == 2 and words in bad.stderr and "Traceback" not in bad.stderr, bad.stderr
        assert not (tmp_path / "bad").exists()


def test_the_project_file_keys_are_checked(tmp_path):
    project = tmp_path / "project"
    init_project(kinematic_arm(tmp_path), project)
    file = project / "simtune.toml"
    text = file.read_text()
    assert "density = 2700" in text
    file.write_text(text.replace("density = 2700", "density = 1000"))
    assert load_project(project).robot.description.link_by_name["upper"].mass == pytest.approx(1000 * 0.06 * 0.08 * 0.3)
    for new, words in (
        ("density = -3", r"robot\.density.*above 0"),
        ("density = 1000\ntotal_mass = 4", "robot.total_mass.*not both"),
    ):
        file.write_text(text.replace("density = 2700", new))
        with pytest.raises(ProjectError, match=words):
            load_project(project)


def test_estimated_masses_are_tuned_over_a_wider_range(tmp_path):
    robot = load_urdf(kinematic_arm(tmp_path))
    masses = {p.name: p for p in robot_spaces(robot)["extended"] if p.name.startswith("mass_link_")}
    for i, link in enumerate(robot.driven_links, start=1):
        m = robot.link_by_name[link].mass
        assert (masses[f"mass_link_{i}"].low, masses[f"mass_link_{i}"].high) == pytest.approx((0.25 * m, 2.0 * m))


# --------------------------------------------------------------------------- engines


@pytest.mark.parametrize("engine", ENGINES)
def test_a_kinematic_visual_only_arm_loads_in_every_engine(tmp_path, engine):
    engine_or_skip(engine)
    robot = load_urdf(kinematic_arm(tmp_path, kind="visual"))
    assert fk_error(robot, engine, np.array([[0.3, -0.4, 0.5]])) < FK_TOLERANCE_M


def test_estimated_masses_make_synth_stable_in_mujoco(tmp_path):
    """The kinematic-only arm through the new user's path: init, then synth in MuJoCo with the generic parameters
    is stable (with 1 g placeholders on every link it was refused as unstable, naming no cause)."""
    engine_or_skip("mujoco")
    project = tmp_path / "project"
    assert cli("init", "--robot", kinematic_arm(tmp_path), "--out", project).returncode == 0
    synth = cli("synth", "--project", project, "--engine", "mujoco", "--task", "reach", "--repeats", "2", "--out",
                project / "recordings")  # fmt: skip
    assert synth.returncode == 0, synth.stderr
    assert "unstable" not in synth.stderr


def rtb_data() -> Path:
    try:
        import rtbdata
    except ImportError:
        pytest.skip("rtb-data is not installed (pip install -e '.[test]')")
    return Path(rtbdata.__file__).parent / "xacro"


@pytest.mark.slow
def test_public_kinematic_visual_only_puma_560_is_estimated_and_synthesised(tmp_path):
    """rtb-data's Puma 560: no <inertial> and no <collision> anywhere (init refused it: no gripper surface)."""
    engine_or_skip("mujoco")
    urdf = rtb_data() / "unimation_puma560_description" / "urdf" / "puma560_robot.urdf"
    project = tmp_path / "puma"
    init = cli("init", "--robot", urdf, "--out", project)
    assert init.returncode == 0, init.stderr
    assert "stands in for its collisions" in init.stdout and "masses estimated from geometry" in init.stdout
    synth = cli("synth", "--project", project, "--engine", "mujoco", "--task", "reach", "--repeats", "2", "--out",
                project / "recordings")  # fmt: skip
    assert synth.returncode == 0, synth.stderr


def test_public_support_package_in_a_description_folder_loads_with_name_equals_dir():
    """rtb-data's ABB arm names its meshes package://abb_irb140_support/... in abb_irb140_description/."""
    folder = rtb_data() / "abb_irb140_description"
    urdf = folder / "urdf" / "irb140.urdf"
    with pytest.raises(RobotError, match="--package-path abb_irb140_support=DIR"):
        loaded(urdf)
    robot = loaded(urdf, package_path=[f"abb_irb140_support={folder}"])
    assert robot.n_joints == 6 and robot.placeholder_masses == ()
    assert set(robot.estimated_masses) >= set(robot.driven_links)


# --------------------------------------------------------------------------- the start-up cache


def test_a_urdf_is_read_once_until_it_or_a_mesh_it_names_changes(tmp_path, monkeypatch):
    """load_robot reads a URDF back from the start-up cache (no yourdfpy, no walk of the file) while the file, the
    options and every mesh it names are unchanged; a changed mesh is read anew, and the load's warnings come back
    with every read."""
    from simtune.robot import load, urdf

    monkeypatch.setenv("SIMTUNE_CACHE_DIR", str(tmp_path / "cache"))
    reads = []
    monkeypatch.setattr(urdf, "load_urdf", lambda *a, **k: reads.append(1) or load_urdf(*a, **k))
    (tmp_path / "meshes").mkdir()
    trimesh.creation.box(extents=(0.04, 0.04, 0.2)).export(tmp_path / "meshes" / "upper.stl")
    mesh = geometry("collision", '<mesh filename="meshes/upper.stl"/>')
    text = arm({"base": geometry("collision", BOX), "upper": mesh}).replace(
        '<link name="upper">', '<link name="upper" drake:x="1">'
    )
    path = write(tmp_path, text)  # an undeclared prefix (as some UR descriptions have): read, with a warning

    def mass() -> float:
        with warnings.catch_warnings(record=True) as said:
            warnings.simplefilter("always")
            robot = load.load_robot(path)
        assert any("namespace prefix drake used without a declaration" in str(w.message) for w in said)
        assert any("masses estimated from geometry" in note for note in robot.choices)
        return robot.link_by_name["upper"].mass

    first = mass()
    assert first == pytest.approx(DEFAULT_DENSITY * 0.04 * 0.04 * 0.2, rel=1e-6)
    assert mass() == first and reads == [1]  # read back
    assert load.load_robot(path, density=1000.0).link_by_name["upper"].mass != first and len(reads) == 2
    trimesh.creation.box(extents=(0.04, 0.04, 0.4)).export(tmp_path / "meshes" / "upper.stl")
    assert mass() == pytest.approx(2 * first, rel=1e-6) and len(reads) == 3  # the mesh changed
    path.write_text(path.read_text().replace('name="kin"', 'name="kin2"'))
    assert load.load_robot(path).name != "kin" and len(reads) == 4  # the file changed
