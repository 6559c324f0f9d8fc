"""Physics engines behind one interface (:class:`simtune.engines.base.Engine`), one folder per engine.

Each engine's folder holds everything simtune knows about it: the engine (``engine.py``), where it has
one the mapping of parameters onto its settings (``mapping.py``, read by the engine and its exporter
alike), its exporter (``export.py``) and the replay of an export (``replay.py``).  :data:`ENGINES` is the
one registry of them: a new engine is one folder and one entry.  Its parts are named by module path and
imported lazily, so that a missing optional engine only matters when it is asked for.
"""

from __future__ import annotations

import importlib
from typing import Any, NamedTuple

from simtune.engines.base import COMMON_PARAMETERS, Engine, Rollout
from simtune.errors import ConfigError, EngineUnavailable
from simtune.tasks.spec import TaskSpec


class EngineEntry(NamedTuple):
    """One engine of the registry: where its parts are (imported only when asked for) and how to install it."""

    #: the module of the engine class, and the class's name there
    module: str
    cls: str
    #: the command that installs what the engine needs: the one place it is written
    #: (``simtune engines`` and every "not installed" error show it)
    install: str
    #: ``module:function`` that writes the engine's model files into an export folder
    exporter: str
    #: ``module:class`` that drives an export's files alone (the round trip); None where nothing can
    replay: str | None
    #: whether its velocity servo is a hard motor (a velocity constraint up to the force limit), not a gain:
    #: ``simtune check`` warns where such an engine and MuJoCo may disagree on a robot
    hard_motor: bool = False

    def engine_class(self) -> type[Engine]:
        """The engine class (installed or not: its ``version()`` says)."""
        return getattr(importlib.import_module(self.module), self.cls)


def _entry(
    folder: str, cls: str, install: str, replay: str | None, exports_as: str | None = None, hard_motor: bool = False
) -> EngineEntry:
    """The entry of the engine in ``simtune/engines/<folder>/``: engine class ``cls`` in its ``engine.py``, replay
    class ``replay`` in its ``replay.py``; ``exports_as``: the folder of the engine whose exporter writes its files
    (an engine on the same model), default its own; ``hard_motor``: :attr:`EngineEntry.hard_motor`."""
    package = f"simtune.engines.{folder}"
    exporter = f"simtune.engines.{exports_as or folder}.export:write"
    return EngineEntry(f"{package}.engine", cls, install, exporter, replay and f"{package}.replay:{replay}", hard_motor)


ENGINES: dict[str, EngineEntry] = {
    "mujoco": _entry("mujoco", "MujocoEngine", "pip install mujoco", "MujocoFiles"),
    "pybullet": _entry(
        "pybullet", "PybulletEngine", "pip install 'simtune[pybullet]'", "PybulletFiles", hard_motor=True
    ),
    # ODE has no model file format: its export is a sidecar that no program of simtune's drives
    "ode": _entry("ode", "OdeEngine", "apt-get install libode8; pip install 'simtune[ode]'", None, hard_motor=True),
    "dart": _entry("dart", "DartEngine", "pip install 'simtune[dart]'", "DartFiles", hard_motor=True),
    "drake": _entry("drake", "DrakeEngine", "pip install 'simtune[drake]'", "DrakeFiles"),
    # a whole population as one batch of MuJoCo Warp worlds, on a CUDA GPU when there is one (else the CPU);
    # the same parameters mapped onto the same MuJoCo model: a MuJoCo Warp run exports as MJCF
    "mujoco-warp": _entry("mujoco_warp", "MujocoWarpEngine", "pip install 'simtune[gpu]'", None, exports_as="mujoco"),
}


def load_part(path: str) -> Any:
    """The object a registry entry names as ``module:name``, imported now."""
    module, name = path.split(":")
    return getattr(importlib.import_module(module), name)


def not_installed(name: str) -> EngineUnavailable:
    """The error for engine ``name`` whose library is missing, with the command that installs it."""
    return EngineUnavailable(f"engine {name!r} is not installed: {ENGINES[name].install}")


def engine_class(name: str) -> type[Engine]:
    """The engine class called ``name``; a clear error if unknown or not installed."""
    try:
        entry = ENGINES[name]
    except KeyError:
        raise ConfigError(f"unknown engine {name!r} (known: {', '.join(ENGINES)})") from None
    engine = entry.engine_class()
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
    "load_part",
    "make_engine",
    "not_installed",
]
