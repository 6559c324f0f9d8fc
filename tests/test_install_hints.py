"""A missing engine library is reported with the install command of the registry, wherever it is noticed."""

import pytest

from simtune.engines import ENGINES, engine_class
from simtune.engines.mujoco import engine as mujoco_engine
from simtune.errors import EngineUnavailable
from simtune.tasks import get_task


def test_a_missing_engine_names_the_registrys_install_command(monkeypatch):
    monkeypatch.setattr(mujoco_engine, "mujoco", None)  # as on a machine without the mujoco package
    expected = f"engine 'mujoco' is not installed: {ENGINES['mujoco'].install}"
    with pytest.raises(EngineUnavailable) as by_name:
        engine_class("mujoco")
    with pytest.raises(EngineUnavailable) as by_class:
        mujoco_engine.MujocoEngine(get_task("cube"))
    assert str(by_name.value) == str(by_class.value) == expected
