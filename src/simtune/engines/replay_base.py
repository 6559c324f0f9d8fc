"""What each engine's replay (``engines/<name>/replay.py``) builds on: an engine that loads an export folder's files.

Nothing here builds a model from simtune's robot description: a :class:`FromFiles` loads only the files of an
export folder (the model files, the sidecar, controller.yaml).  It is an `Engine` so that simtune's shared control
loop (`Engine.rollout`: the 20 Hz controller, its phase, the step counting) drives it exactly as it drove the tuned
run; ``simtune.export.replay`` drives and scores it (the round trip of `simtune export`).
"""

from __future__ import annotations

import importlib.util
from pathlib import Path

import yaml

from simtune.engines.base import Engine
from simtune.errors import SimtuneError
from simtune.tasks.spec import TaskSpec


def controller(folder: Path) -> dict:
    return yaml.safe_load((folder / "controller.yaml").read_text())


def load_script(folder: Path, name: str):
    """An export's example script, imported as a module."""
    spec = importlib.util.spec_from_file_location(f"exported_{Path(name).stem}", folder / name)
    if spec is None or spec.loader is None:
        raise SimtuneError(f"{folder / name}: cannot load the export's script")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


class FromFiles(Engine):
    """An engine that loads nothing but an export folder's files (each engine's ``replay.py`` has one)."""

    engine_parameters = frozenset()

    def __init__(self, task: TaskSpec, folder: Path):
        super().__init__(task)
        ctl = controller(folder)
        self.folder = folder
        self.joints = ctl["control"]["joints"]
        self.wrist = ctl["tracking"]["link"]
        self.has_object = ctl["tasks"][task.name]["object"] is not None

    def defaults(self) -> dict[str, float]:
        return {}
