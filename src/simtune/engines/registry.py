"""The registry of the physics engines: each engine's name, where its parts are and how to install it.

It is data only (module paths as strings, imported when asked for), below the engines and the table of parameter
kinds, so that the kinds table takes the engines' names from here (:data:`simtune.params.kinds.ALL_ENGINES`) and
the names are written once: a new engine is one folder (``simtune/engines/<name>/``) and one entry here.
:mod:`simtune.engines` serves it with the engine classes.
"""

from __future__ import annotations

import importlib
from typing import Any, NamedTuple


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

    def engine_class(self) -> Any:
        """The engine class, a :class:`simtune.engines.base.Engine` (installed or not: its ``version()`` says)."""
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
