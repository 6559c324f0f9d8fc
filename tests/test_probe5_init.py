"""Probe 5, row 42: the example reach `simtune init` writes for a long chain keeps every link off the floor."""

import pytest
from test_urdf_defects import chain, write

from simtune.check.project import _floor_findings, check_project
from simtune.project import get_project
from simtune.robot.load import load_robot
from simtune.tasks.init_project import CLEARANCE_M, _ChainHeights, _lowest_on_the_way, init_project, reach_poses


@pytest.mark.parametrize("links", [40, 200])
def test_a_long_chains_example_reach_keeps_every_link_clear_of_the_floor_on_the_way(tmp_path, links):
    """The reach kept the tracked link (the chain's end) clear but swung the middle of a 40-link chain 42 cm
    through the floor; now no moving frame comes nearer the floor than the clearance, at the target or on the
    way, and the reach still moves."""
    robot = load_robot(write(tmp_path, chain(links)))
    start, target = reach_poses(robot)
    assert start != target
    heights = _ChainHeights(robot)
    assert heights.lowest(start) >= CLEARANCE_M  # the start pose's search lifts this chain clear
    assert _lowest_on_the_way(heights, start, target) >= CLEARANCE_M


@pytest.mark.slow  # the default tier's 4 minutes
def test_the_project_check_warns_of_a_task_whose_arm_lies_on_the_floor(tmp_path):
    """synth warned of the 40-link chain's arm on the floor and `simtune check DIR` said nothing: it sags onto the
    floor under its own weight (2 m of 1-kg links against 5 N m motors) whatever the reach does.  The project check
    now runs each task without an object in MuJoCo and says so, as `check --task` and synth do; the bundled MICO's
    tasks stay clear."""
    small = chain(40).replace('box size="0.05 0.05 0.3"', 'box size="0.04 0.04 0.04"')
    init_project(write(tmp_path, small), tmp_path / "project")
    findings = check_project(tmp_path / "project", engines=("mujoco",))
    touching = [f for f in findings if "touches the floor" in str(f)]
    assert len(touching) == 1 and touching[0].level == "warning"
    assert "task reach" in str(touching[0]) and "tuned as if it never did" in str(touching[0])
    assert _floor_findings(get_project(None), ["mujoco"]) == []
