"""The keys of one table of a task or project file, read with one-line errors naming the file and the key.

Its own module so that the task-file reader (files.py) and the LeRobot schedule (lerobot.py), which each read
keys through it, do not import each other.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

from simtune.errors import ProjectError


def kind_of(value: object) -> str:
    """How a value read from a file is named in an error: a number, a string, a table ..."""
    if isinstance(value, bool):
        return "true/false"
    if isinstance(value, int | float):
        return "number"
    if isinstance(value, str):
        return "string"
    if isinstance(value, list | tuple):
        return "list"
    if isinstance(value, dict):
        return "table"
    return type(value).__name__


class Keys:
    """One table of a file, read key by key with one-line errors naming the file and the key's full name."""

    def __init__(self, path: Path, data: Mapping[str, Any], known: Sequence[str], prefix: str = ""):
        self.path = path
        self.data = data
        self.prefix = prefix
        for key in data:
            if key not in known:
                raise self.error(str(key), f"unknown key (known here: {', '.join(known)})")

    def error(self, key: str, what: str) -> ProjectError:
        return ProjectError(f"{self.path}: {self.prefix}{key}: {what}")

    def has(self, key: str) -> bool:
        return key in self.data

    def _get(self, key: str, required: bool) -> Any:
        if key not in self.data and required:
            raise self.error(key, "missing (required)")
        return self.data.get(key)

    def string(self, key: str, default: str | None = None, required: bool = False) -> str | None:
        value = self._get(key, required)
        if value is None:
            return default
        if not isinstance(value, str):
            raise self.error(key, f"expected a string, got a {kind_of(value)}")
        return value

    def flag(self, key: str, default: bool) -> bool:
        value = self._get(key, False)
        if value is None:
            return default
        if not isinstance(value, bool):
            raise self.error(key, f"expected true or false, got a {kind_of(value)}")
        return value

    def number(self, key: str, default: float | None = None, required: bool = False, above: float | None = None):
        value = self._get(key, required)
        if value is None:
            return default
        return self.check_number(key, value, above)

    def check_number(self, key: str, value: Any, above: float | None = None) -> float:
        if isinstance(value, bool) or not isinstance(value, int | float):
            raise self.error(key, f"expected a number, got a {kind_of(value)}")
        if not math.isfinite(value):
            raise self.error(key, f"expected a finite number, got {value}")
        if above is not None and not value > above:
            raise self.error(key, f"must be above {above:g}, got {value:g}")
        return float(value)

    def numbers(self, key: str, length: int | None = None, of: str = "", required: bool = False):
        """A list of finite numbers; ``length`` checked, ``of`` says what each entry stands for in the message."""
        value = self._get(key, required)
        if value is None:
            return None
        if not isinstance(value, list):
            raise self.error(key, f"expected a list of numbers, got a {kind_of(value)}")
        if length is not None and len(value) != length:
            raise self.error(key, f"expected {length} numbers{of}, got {len(value)}")
        return tuple(self.check_number(f"{key}[{i}]", v) for i, v in enumerate(value))

    def strings(self, key: str, required: bool = False) -> tuple[str, ...] | None:
        value = self._get(key, required)
        if value is None:
            return None
        if not isinstance(value, list) or not all(isinstance(v, str) for v in value):
            raise self.error(key, f"expected a list of strings, got {value!r}")
        return tuple(value)

    def table(self, key: str, known: Sequence[str], required: bool = False) -> Keys | None:
        value = self._get(key, required)
        if value is None:
            return None
        if not isinstance(value, dict):
            raise self.error(key, f"expected a table of keys, got a {kind_of(value)}")
        return Keys(self.path, value, known, f"{self.prefix}{key}.")

    def tables(self, key: str, known: Sequence[str]) -> list[Keys] | None:
        """A list of tables (TOML's ``[[key]]``)."""
        value = self._get(key, False)
        if value is None:
            return None
        if not isinstance(value, list) or not all(isinstance(v, dict) for v in value):
            raise self.error(key, "expected a list of tables (TOML: [[" + key + "]] sections)")
        return [Keys(self.path, v, known, f"{self.prefix}{key}[{i}].") for i, v in enumerate(value)]
