"""simtune's cache folder, one for everything it keeps between runs (converted meshes, the activity probe's
results), each kind in its own sub-folder and keyed by content, never by a path."""

from __future__ import annotations

import os
import warnings
from pathlib import Path

#: the environment variable that moves the cache (a folder shared between clones, or a throwaway one in tests)
CACHE_ENV = "SIMTUNE_CACHE_DIR"
#: its former name, which the mesh cache read: a deprecated alias, still honoured (with a warning) where CACHE_ENV
#: is not set
FORMER_CACHE_ENV = "SIMTUNE_CACHE"


def cache_root() -> Path:
    """The cache folder.

    Returns:
        ``$SIMTUNE_CACHE_DIR``, else the former ``$SIMTUNE_CACHE`` (with a FutureWarning naming the new name),
        else ``$XDG_CACHE_HOME/simtune``, else ``~/.cache/simtune``.
    """
    if os.environ.get(CACHE_ENV):
        return Path(os.environ[CACHE_ENV]).expanduser()
    if os.environ.get(FORMER_CACHE_ENV):
        warnings.warn(
            f"{FORMER_CACHE_ENV} is deprecated: set {CACHE_ENV}={os.environ[FORMER_CACHE_ENV]} instead (the same "
            "cache; the former name will stop being read)",
            FutureWarning,
            stacklevel=2,
        )
        return Path(os.environ[FORMER_CACHE_ENV]).expanduser()
    xdg = os.environ.get("XDG_CACHE_HOME")
    return (Path(xdg).expanduser() if xdg else Path.home() / ".cache") / "simtune"
