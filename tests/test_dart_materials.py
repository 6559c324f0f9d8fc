"""DART's warnings about missing material (.mtl) files: one warning line instead of a hundred per mesh, every other
line of its stderr (a mesh it cannot open, its notes on zero masses) passed on unchanged."""

import os
import warnings
from pathlib import Path

import numpy as np
import pytest
from conftest import engine_or_skip

from simtune.common.spawn_guard import leave_robot_notes_to_parent
from simtune.engines.dart.quiet import load_quietly, missing_materials
from simtune.errors import RobotWarning
from simtune.robot.urdf import load_urdf
from simtune.tasks.spec import Phase, TaskSpec

dartpy = pytest.importorskip("dartpy")

#: a tetrahedron whose material library was never shipped, as many published OBJs are
TETRAHEDRON = """mtllib missing.mtl
v 0 0 0
v 0.1 0 0
v 0 0.1 0
v 0 0 0.1
usemtl red
f 1 3 2
f 1 2 4
f 1 4 3
f 2 3 4
"""
INERTIAL = '<inertial><mass value="{}"/><inertia ixx="1e-3" iyy="1e-3" izz="1e-3" ixy="0" ixz="0" iyz="0"/></inertial>'


def arm_urdf(folder: Path, meshes: tuple[str, ...], base_mass: float = 1.0) -> Path:
    """A base and one revolute link whose collision shapes are ``meshes`` (files in ``folder``)."""
    shapes = "".join(f'<collision><geometry><mesh filename="{folder / m}"/></geometry></collision>' for m in meshes)
    path = folder / "arm.urdf"
    path.write_text(
        f'<robot name="arm"><link name="base">{INERTIAL.format(base_mass)}</link>'
        f'<link name="link1">{INERTIAL.format(0.5)}{shapes}</link>'
        '<joint name="joint1" type="revolute"><parent link="base"/><child link="link1"/><axis xyz="0 0 1"/>'
        '<limit lower="-1" upper="1" effort="5" velocity="1"/></joint></robot>'
    )
    return path


def parse(urdf: Path):
    """The skeleton DART's own URDF loader makes of ``urdf`` (None where it cannot)."""
    return dartpy.utils.DartLoader().parseSkeleton(str(urdf))


def test_the_engine_collides_with_each_meshs_hull_and_never_reads_its_material(tmp_path, capfd, recwarn):
    """DART reads each mesh as the OBJ of its convex hull (which names no material file: nothing to say about the
    source's missing one) and collides with it as a convex shape of the hull's vertices, not as a triangle mesh."""
    (tmp_path / "tetra.obj").write_text(TETRAHEDRON)
    robot = load_urdf(arm_urdf(tmp_path, ("tetra.obj",)))
    task = TaskSpec("pose", "", 0.1, (Phase(0.0, (0.0,)),), kp=1.0, start_pose_deg=(0.0,), robot=robot)
    sim = engine_or_skip("dart")(task)
    assert "missing.mtl" not in capfd.readouterr().err  # DART alone writes dozens of lines about it
    assert not [w for w in recwarn.list if issubclass(w.category, RobotWarning)]
    nodes = sim.robot.getBodyNode("link1").getShapeNodes()
    colliding = [node.getShape() for node in nodes if node.hasCollisionAspect()]
    assert [type(shape).__name__ for shape in colliding] == ["MultiSphereConvexHullShape"]
    assert colliding[0].getNumSpheres() == 4  # the tetrahedron's four corners
    meshes = [node for node in nodes if isinstance(node.getShape(), dartpy.dynamics.MeshShape)]
    assert meshes and not any(node.hasCollisionAspect() for node in meshes)
    sim.reset({})
    sim.step(10)
    assert np.isfinite(sim.joint_angles()).all()


def test_a_mesh_dart_cannot_open_and_its_other_notes_still_reach_stderr(tmp_path, capfd):
    (tmp_path / "tetra.obj").write_text(TETRAHEDRON)
    # a missing mesh (load_urdf refuses one; here DART reads the file itself) and a massless base
    urdf = arm_urdf(tmp_path, ("tetra.obj", "gone.obj"), base_mass=0.0)
    meshes = [str(tmp_path / "tetra.obj"), str(tmp_path / "gone.obj")]
    with pytest.warns(RobotWarning, match="colours only"):
        load_quietly(lambda: parse(urdf), meshes)
    err = capfd.readouterr().err
    assert "missing.mtl" not in err
    assert "gone.obj" in err  # the real failure, as DART says it
    assert "zero mass" in err
    os.write(2, b"after\n")  # the descriptor is the one it was
    assert capfd.readouterr().err == "after\n"


def test_an_exception_in_the_load_comes_after_its_stderr(tmp_path, capfd):
    (tmp_path / "tetra.obj").write_text(TETRAHEDRON)

    def failing():
        os.write(2, b"DART: something broke\n")
        raise RuntimeError("broken")

    with pytest.raises(RuntimeError, match="broken"):
        load_quietly(failing, [str(tmp_path / "tetra.obj")])
    assert capfd.readouterr().err == "DART: something broke\n"  # nothing about materials was left out: no warning


def test_meshes_whose_materials_exist_are_loaded_as_they_are(tmp_path, recwarn):
    (tmp_path / "tetra.obj").write_text(TETRAHEDRON)
    (tmp_path / "plain.obj").write_text(TETRAHEDRON.replace("missing.mtl", "present.mtl"))
    (tmp_path / "present.mtl").write_text("newmtl red\nKd 1 0 0\n")
    meshes = [str(tmp_path / name) for name in ("tetra.obj", "plain.obj", "gone.obj", "shape.stl")]
    assert missing_materials(meshes) == {meshes[0]: "missing.mtl"}
    assert load_quietly(lambda: 7, meshes[1:]) == 7
    assert not recwarn.list


def test_workers_leave_the_robot_notes_to_their_parent():
    # a worker builds the robot's engine again: the parent has said the note (one line in a tune, not one a worker)
    with warnings.catch_warnings(record=True) as said:
        warnings.simplefilter("always")
        leave_robot_notes_to_parent()
        warnings.warn("DART could not find ...", RobotWarning, stacklevel=1)
        warnings.warn("another kind", UserWarning, stacklevel=1)
    assert [str(w.message) for w in said] == ["another kind"]


def test_loads_on_two_threads_leave_stderr_as_it_was(tmp_path, capfd):
    import threading
    import time

    (tmp_path / "tetra.obj").write_text(TETRAHEDRON)
    meshes = [str(tmp_path / "tetra.obj")]

    def noisy():
        os.write(2, f"Failed opening file '{tmp_path}/missing.mtl'\n".encode())
        time.sleep(0.05)  # long enough for the other thread to start its own load meanwhile
        os.write(2, b"kept\n")

    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RobotWarning)
        threads = [threading.Thread(target=load_quietly, args=(noisy, meshes)) for _ in range(2)]
        for thread in threads:
            thread.start()
        for thread in threads:
            thread.join()
    os.write(2, b"after\n")  # fd 2 is the test's again, not one load's temporary file
    assert capfd.readouterr().err == "kept\nkept\nafter\n"
