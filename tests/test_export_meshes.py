"""An export carries the meshes its robot's files name (issue 70 item 5): copied into OUT/meshes/ and named relative
to the export, so the folder loads on another machine - here, moved away with the robot's own meshes deleted."""

import re
import shutil
import subprocess
import sys

import pytest
from conftest import engine_or_skip
from test_run_read_back import ARM_URDF as READ_BACK_ARM

import simtune.api as st
from simtune.tasks.init_project import init_project

#: a 4-cm cube as an OBJ, the robot's one mesh
CUBE_OBJ = "\n".join(
    [*(f"v {x} {y} {z}" for x in (-0.02, 0.02) for y in (-0.02, 0.02) for z in (0.0, 0.04))]
    + ["f 1 3 4 2", "f 5 6 8 7", "f 1 2 6 5", "f 3 7 8 4", "f 1 5 7 3", "f 2 4 8 6"]
)

#: test_run_read_back's two-joint arm, its hand a mesh in a folder beside the URDF
ARM_URDF = READ_BACK_ARM.replace(
    '<collision><origin xyz="0 0 0.05"/><geometry><box size="0.04 0.04 0.1"/></geometry></collision>',
    '<collision><geometry><mesh filename="meshes/hand.obj"/></geometry></collision>',
)
assert "hand.obj" in ARM_URDF


@pytest.fixture(scope="module")
def meshed_project(tmp_path_factory):
    root = tmp_path_factory.mktemp("meshed")
    (root / "robot" / "meshes").mkdir(parents=True)
    (root / "robot" / "meshes" / "hand.obj").write_text(CUBE_OBJ + "\n")
    (root / "robot" / "arm.urdf").write_text(ARM_URDF)
    project = root / "project"
    init_project(root / "robot" / "arm.urdf", project)
    st.synth("mujoco", "reach", out=project / "recordings", project=project, repeats=2)
    return root, project


@pytest.mark.parametrize("engine", ["mujoco", pytest.param("pybullet", marks=pytest.mark.slow)])
def test_a_moved_export_loads_without_the_robots_own_meshes(meshed_project, tmp_path, engine):
    engine_or_skip(engine)
    root, project = meshed_project
    run = tmp_path / "run"
    st.tune(engine, "reach", project=project, space="shared", out=run, optimizer="random", max_evaluations=2)
    st.export(run, tmp_path / "export")
    texts = [p.read_text() for p in (tmp_path / "export").iterdir() if p.suffix in (".xml", ".urdf", ".sdf")]
    # every file a model names is named relative to the export (the header's provenance names the run's paths)
    named = [m for text in texts for m in re.findall(r'\bfile(?:name)?="([^"]+)"', text)]
    assert named and not any(name.startswith(("/", "file:")) for name in named), named
    carried = sorted((tmp_path / "export" / "meshes").iterdir())
    assert [p.suffix for p in carried] == [".obj"] and carried[0].read_text().startswith("v ")
    # another machine: the export moved, the robot's meshes (and simtune's cache of their hulls) nowhere
    moved = tmp_path / "elsewhere" / "export"
    shutil.copytree(tmp_path / "export", moved)
    shutil.rmtree(tmp_path / "export")
    shutil.rmtree(root / "robot" / "meshes")
    script = {"mujoco": "load_mujoco.py", "pybullet": "load_pybullet.py"}[engine]
    loaded = subprocess.run([sys.executable, script, "reach"], cwd=moved, capture_output=True, text=True, timeout=120)
    assert loaded.returncode == 0 and loaded.stdout.startswith("reach wrist at"), loaded.stderr
    (root / "robot" / "meshes").mkdir()  # the module's fixture for the next engine
    (root / "robot" / "meshes" / "hand.obj").write_text(CUBE_OBJ + "\n")
