"""A published OBJ whose material (.mtl) file is missing: DART reads each mesh's convex hull as simtune writes it
(no material named), so none of its hundred lines per mesh about the missing file come; robot notes stay with the
parent process."""

import warnings
from pathlib import Path

import numpy as np
import pytest
from conftest import engine_or_skip

from simtune.common.spawn_guard import leave_robot_notes_to_parent
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


def arm_urdf(folder: Path, meshes: tuple[str, ...]) -> Path:
    """A base and one revolute link whose collision shapes are ``meshes`` (files in ``folder``)."""
    shapes = "".join(f'<collision><geometry><mesh filename="{folder / m}"/></geometry></collision>' for m in meshes)
    path = folder / "arm.urdf"
    path.write_text(
        f'<robot name="arm"><link name="base">{INERTIAL.format(1.0)}</link>'
        f'<link name="link1">{INERTIAL.format(0.5)}{shapes}</link>'
        '<joint name="joint1" type="revolute"><parent link="base"/><child link="link1"/><axis xyz="0 0 1"/>'
        '<limit lower="-1" upper="1" effort="5" velocity="1"/></joint></robot>'
    )
    return path


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


def test_workers_leave_the_robot_notes_to_their_parent():
    # a worker builds the robot's engine again: the parent has said the note (one line in a tune, not one a worker)
    with warnings.catch_warnings(record=True) as said:
        warnings.simplefilter("always")
        leave_robot_notes_to_parent()
        warnings.warn("DART could not find ...", RobotWarning, stacklevel=1)
        warnings.warn("another kind", UserWarning, stacklevel=1)
    assert [str(w.message) for w in said] == ["another kind"]
