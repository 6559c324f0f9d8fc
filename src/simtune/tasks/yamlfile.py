"""YAML as task and project files are read: PyYAML's safe loader, strict where YAML 1.1 is silently loose.

- A key written twice in one mapping is an error (PyYAML keeps the last one without a word; TOML refuses it).
- Numbers are read as YAML 1.2 writes them: ``8e0``, ``1.5e1`` and ``2E+0`` are numbers (YAML 1.1 wants a dot
  and a signed exponent, and PyYAML reads the others as strings).
"""

from __future__ import annotations

import re
from typing import Any

import yaml

#: floats with an exponent that YAML 1.2's core schema reads as numbers and YAML 1.1's resolver misses
_FLOAT_12 = re.compile(r"^[-+]?(?:\.[0-9]+|[0-9]+(?:\.[0-9]*)?)[eE][-+]?[0-9]+$")


class StrictLoader(yaml.SafeLoader):
    """The safe loader with duplicate keys refused and YAML 1.2's exponent numbers read as floats."""

    def construct_mapping(self, node: yaml.MappingNode, deep: bool = False) -> dict[Any, Any]:
        seen: set[Any] = set()
        for key_node, _ in node.value:
            if key_node.tag == "tag:yaml.org,2002:merge":
                continue  # ``<<: *base``: keys given beside it win over the merged ones, as YAML says
            key = self.construct_object(key_node, deep=True)
            try:
                repeated = key in seen
            except TypeError:
                continue  # an unhashable key: the safe constructor says so
            if repeated:
                raise yaml.constructor.ConstructorError(None, None, f"key {key!r} appears twice", key_node.start_mark)
            seen.add(key)
        return super().construct_mapping(node, deep=deep)


StrictLoader.add_implicit_resolver("tag:yaml.org,2002:float", _FLOAT_12, list("-+.0123456789"))


def load_yaml(text: str) -> Any:
    """The document ``text`` holds (yaml.YAMLError with the line of a problem, a repeated key among them)."""
    return yaml.load(text, Loader=StrictLoader)  # a subclass of the safe loader: no Python objects
