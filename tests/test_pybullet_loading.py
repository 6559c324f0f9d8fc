"""PyBullet loads a robot as its description says (the file's inertias, no link damping of Bullet's own) unless a run
loads it as the seed paper did (``--paper-exact``, ``--loading paper``): issue 69.  Runs stored before the choice
were loaded as the paper did, and keep that loading."""

import subprocess
import sys

import numpy as np
import pytest

from simtune import api
from simtune.errors import ConfigError
from simtune.run_config import RunConfig
from simtune.run_plan import plan_run
from simtune.runs import fingerprint_differences
from simtune.tasks import get_task

pybullet = pytest.importorskip("pybullet")

#: measured on commit 4a27093, before the choice (PyBullet then always loaded as the paper did), with the generic
#: parameters: `single` against two MuJoCo-synthesised repeats (the fixture's), `cube` against its bundled recordings
OLD_SINGLE_FITNESS = 0.0037041648676468743
OLD_CUBE_FITNESS = 0.11047064481044411
#: and the tracked link after 100 control periods of each task's rollout at every generic value (engine.defaults())
OLD_WRIST = {
    "single": [0.5328455567359924, 0.06706199795007706, 0.23477579653263092],
    "cube": [0.10637889802455902, -0.00700131431221962, 0.5075855255126953],
}


@pytest.fixture(scope="module")
def single_data(tmp_path_factory):
    """Two MuJoCo-synthesised repeats of `single` (as tests/test_paper_exact.py makes them)."""
    from simtune.data import write_qualisys_tsv
    from simtune.reference.make import synthesize

    root = tmp_path_factory.mktemp("data")
    (root / "single").mkdir()
    for rec in synthesize("mujoco", get_task("single"), {}, repeats=2, noise_m=0.002, jitter_s=0.0, seed=3):
        write_qualisys_tsv(root / "single" / rec.source.name, rec, header=True)
    return root


def test_loaded_as_the_paper_pybullet_scores_exactly_what_it_scored_before(single_data):
    assert api.evaluate("pybullet", "single", data=single_data, loading="paper").fitness == OLD_SINGLE_FITNESS
    assert api.evaluate("pybullet", "cube", loading="paper").fitness == OLD_CUBE_FITNESS
    # loaded as the MICO's description says, the same arm moves otherwise (its file's inertias, no link damping)
    assert api.evaluate("pybullet", "single", data=single_data).fitness != OLD_SINGLE_FITNESS


@pytest.mark.parametrize("task_name", list(OLD_WRIST))
def test_loaded_as_the_paper_every_generic_value_rolls_out_as_before(task_name):
    from simtune.engines import make_engine

    sim = make_engine("pybullet", get_task(task_name, loading="paper"))
    try:
        assert sim.defaults()["linear_damping_gripper"] == 0.04  # as before: the value a full space sets
        assert sim.rollout(sim.defaults(), 100).wrist_pos[-1].tolist() == OLD_WRIST[task_name]
    finally:
        sim.close()


def test_a_paper_exact_run_loads_as_the_paper_and_a_new_run_as_the_description():
    paper = plan_run(RunConfig(engine="pybullet", tasks="single", paper_exact=True))
    assert paper.config.loading == "paper" and [t.loading for t in paper.tasks] == ["paper"]
    new = plan_run(RunConfig(engine="pybullet", tasks="single,cube"))
    assert new.config.loading == "description" and {t.loading for t in new.tasks} == {"description"}
    with pytest.raises(ConfigError, match="--paper-exact loads the robot as the paper did: drop --loading"):
        RunConfig(engine="pybullet", tasks="single", paper_exact=True, loading="description").check()


def test_pybullet_takes_the_files_inertias_and_no_link_damping():
    from simtune.engines import make_engine

    described = make_engine("pybullet", get_task("single"))
    paper = make_engine("pybullet", get_task("single", loading="paper"))
    try:
        robot = described.task.robot
        for name in robot.driven_links:
            link = described._arm[robot.driven_links.index(name)]
            principal = np.sort(np.linalg.eigvalsh(robot.link_by_name[name].inertia_matrix()))
            loaded = np.sort(pybullet.getDynamicsInfo(described.robot, link, physicsClientId=described.client)[2])
            assert np.allclose(loaded, principal, rtol=1e-6), name
            shapes = np.sort(pybullet.getDynamicsInfo(paper.robot, link, physicsClientId=paper.client)[2])
            assert not np.allclose(shapes, principal, rtol=1e-2), name  # the paper's: from the collision shapes
            # a tuned mass scales the file's inertia (Bullet alone would compute it from the shapes again)
            values = described.defaults()
            values[f"mass_link_{robot.driven_links.index(name) + 1}"] *= 2
            described.reset(values)
            scaled = np.sort(pybullet.getDynamicsInfo(described.robot, link, physicsClientId=described.client)[2])
            assert np.allclose(scaled, 2 * principal, rtol=1e-6), name
        assert described.defaults()["linear_damping_gripper"] == 0.0
        dynamics = described._loaded_dynamics[(described.robot, described._arm[0])]
        assert dynamics["linearDamping"] == dynamics["angularDamping"] == 0.0
    finally:
        described.close()
        paper.close()


def test_a_store_without_the_loading_was_loaded_as_the_paper_and_keeps_it():
    stored = {"engine": "pybullet", "tasks": "single", "space": "shared", "data": None}
    config = RunConfig.from_stored(stored, "run.sqlite")
    assert config.loading == "paper" and [t.loading for t in plan_run(config).tasks] == ["paper"]
    assert "loading" not in RunConfig(loading="paper").record()  # so a store made before compares equal
    assert RunConfig().record()["loading"] == "description"
    # a fingerprint without it: the paper's (every run stored before); the tasks' own fingerprints leave it out
    now = {"data": {}, "tasks": {}, "engine": "pybullet 3"}
    assert fingerprint_differences(dict(now), now) == []
    assert fingerprint_differences(dict(now), {**now, "loading": "description"}) == [
        "the robot's loading changed from paper to description"
    ]
    with pytest.raises(ConfigError, match="run.sqlite: loading must be one of description, paper"):
        RunConfig.from_stored({**stored, "loading": "urdf"}, "run.sqlite")


def test_a_loading_of_neither_kind_is_one_line():
    with pytest.raises(ConfigError, match="loading must be one of description, paper"):
        api.evaluate("pybullet", "cube", loading="file")
    result = subprocess.run(
        [sys.executable, "-m", "simtune.cli", "evaluate", "--engine", "pybullet", "--loading", "file"],
        capture_output=True,
        text=True,
    )
    assert result.returncode == 2 and "--loading" in result.stderr and "Traceback" not in result.stderr
