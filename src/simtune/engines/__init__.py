"""Physics engines behind one interface (:class:`simtune.engines.base.Engine`), one folder per engine.

Each engine's folder holds everything simtune knows about it: the engine (``engine.py``), where it has
one the mapping of parameters onto its settings (``mapping.py``, read by the engine and its exporter
alike), its exporter (``export.py``) and the replay of an export (``replay.py``).  :data:`ENGINES`
(:mod:`simtune.engines.registry`) is the one registry of them: a new engine is one folder and one entry.  Its
parts are named by module path and imported lazily, so that a missing optional engine only matters when it is
asked for.
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

from simtune.engines.registry import ENGINES, EngineEntry
from simtune.errors import ConfigError, EngineUnavailable

if TYPE_CHECKING:
    from simtune.engines.base import COMMON_PARAMETERS, Engine, Rollout
    from simtune.tasks.spec import TaskSpec

#: the engine interface's names this package serves, imported at first use: the registry is read (by the table of
#: parameter kinds, below the engines) without importing the engines' base, which imports that table
_FROM_BASE = ("COMMON_PARAMETERS", "Engine", "Rollout")


def __getattr__(name: str) -> Any:
    if name in _FROM_BASE:
        from simtune.engines import base

        return getattr(base, name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


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
    engine: type[Engine] = entry.engine_class()
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
