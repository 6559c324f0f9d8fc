"""simtune's cache folder, one for everything it keeps between runs (converted meshes, the activity probe's
results), each kind in its own sub-folder and keyed by content, never by a path."""

from __future__ import annotations

import os
from pathlib import Path

#: the environment variable that moves the cache (a folder shared between clones, or a throwaway one in tests)
CACHE_ENV = "SIMTUNE_CACHE_DIR"
#: its former name, which the mesh cache read: still honoured where CACHE_ENV is not set
FORMER_CACHE_ENV = "SIMTUNE_CACHE"


def cache_root() -> Path:
    """``$SIMTUNE_CACHE_DIR`` (else the former ``$SIMTUNE_CACHE``), else ``$XDG_CACHE_HOME/simtune``, else
    ``~/.cache/simtune``."""
    for name in (CACHE_ENV, FORMER_CACHE_ENV):
        if os.environ.get(name):
            return Path(os.environ[name]).expanduser()
    xdg = os.environ.get("XDG_CACHE_HOME")
    return (Path(xdg).expanduser() if xdg else Path.home() / ".cache") / "simtune"
