"""Physics engines behind one interface (:class:`simtune.engines.base.Engine`).

Engines are imported lazily so that a missing optional engine only matters
when it is asked for.
"""

from __future__ import annotations

import importlib
from typing import NamedTuple

from simtune.engines.base import COMMON_PARAMETERS, Engine, Rollout
from simtune.errors import ConfigError, EngineUnavailable
from simtune.tasks.spec import TaskSpec


class EngineEntry(NamedTuple):
    module: str
    cls: str
    #: the command that installs what the engine needs: the one place it is written
    #: (``simtune engines`` and every "not installed" error show it)
    install: str


ENGINES: dict[str, EngineEntry] = {
    "mujoco": EngineEntry("simtune.engines.mujoco_engine", "MujocoEngine", "pip install mujoco"),
    "pybullet": EngineEntry("simtune.engines.pybullet_engine", "PybulletEngine", "pip install 'simtune[pybullet]'"),
    "ode": EngineEntry(
        "simtune.engines.ode_engine", "OdeEngine", "apt-get install libode8; pip install 'simtune[ode]'"
    ),
    "dart": EngineEntry("simtune.engines.dart_engine", "DartEngine", "pip install 'simtune[dart]'"),
    "drake": EngineEntry("simtune.engines.drake_engine", "DrakeEngine", "pip install 'simtune[drake]'"),
    # a whole population as one batch of MuJoCo Warp worlds, on a CUDA GPU when there is one (else the CPU)
    "mujoco-warp": EngineEntry("simtune.engines.mujoco_warp_engine", "MujocoWarpEngine", "pip install 'simtune[gpu]'"),
}


def not_installed(name: str) -> EngineUnavailable:
    """The error for engine ``name`` whose library is missing, with the command that installs it."""
    return EngineUnavailable(f"engine {name!r} is not installed: {ENGINES[name].install}")


def engine_class(name: str) -> type[Engine]:
    """The engine class called ``name``; a clear error if unknown or not installed."""
    try:
        entry = ENGINES[name]
    except KeyError:
        raise ConfigError(f"unknown engine {name!r} (known: {', '.join(ENGINES)})") from None
    engine = getattr(importlib.import_module(entry.module), entry.cls)
    if engine.version() == "not installed":
        raise not_installed(name)
    return engine


def make_engine(name: str, task: TaskSpec) -> Engine:
    return engine_class(name)(task)


__all__ = [
    "COMMON_PARAMETERS",
    "ENGINES",
    "Engine",
    "EngineEntry",
    "Rollout",
    "engine_class",
    "make_engine",
    "not_installed",
]
