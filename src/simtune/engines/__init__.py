"""Physics engines behind one interface (:class:`simtune.engines.base.Engine`).

Engines are imported lazily so that a missing optional engine only matters
when it is asked for.
"""

from __future__ import annotations

import importlib

from simtune.engines.base import COMMON_PARAMETERS, Engine, Rollout
from simtune.errors import ConfigError, EngineUnavailable
from simtune.tasks.spec import TaskSpec

#: engine name -> (module, class, install hint)
ENGINES: dict[str, tuple[str, str, str]] = {
    "mujoco": ("simtune.engines.mujoco_engine", "MujocoEngine", "pip install mujoco"),
    "pybullet": ("simtune.engines.pybullet_engine", "PybulletEngine", "pip install 'simtune[pybullet]'"),
    "ode": ("simtune.engines.ode_engine", "OdeEngine", "apt-get install libode8; pip install 'simtune[ode]'"),
    "dart": ("simtune.engines.dart_engine", "DartEngine", "pip install 'simtune[dart]'"),
    "drake": ("simtune.engines.drake_engine", "DrakeEngine", "pip install 'simtune[drake]'"),
}


def engine_class(name: str) -> type[Engine]:
    """The engine class called ``name``; a clear error if unknown or not installed."""
    try:
        module, cls, hint = ENGINES[name]
    except KeyError:
        raise ConfigError(f"unknown engine {name!r} (known: {', '.join(ENGINES)})") from None
    engine = getattr(importlib.import_module(module), cls)
    if engine.version() == "not installed":
        raise EngineUnavailable(f"engine {name!r} is not installed: {hint}")
    return engine


def make_engine(name: str, task: TaskSpec) -> Engine:
    return engine_class(name)(task)


__all__ = ["COMMON_PARAMETERS", "ENGINES", "Engine", "Rollout", "engine_class", "make_engine"]
