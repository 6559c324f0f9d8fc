"""No import runs from a lower layer to a higher one: the layer table of docs/architecture.md, checked with `ast`.

Every import is read, at module level, inside functions and under ``TYPE_CHECKING``
alike, relative imports resolved; every module under src/simtune must be placed in
the table, and every name in the table must be a module.

The layers allow imports within a layer, so they cannot see a loop between two modules of one layer; a
package and a module outside it importing each other (``tasks/__init__`` reading ``project`` inside a function,
``project`` importing ``tasks.files``) is such a loop, and is checked on its own: taking each package as one
unit, no chain of imports leads from a unit back to itself.
"""

import ast
import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
PACKAGE = ROOT / "src" / "simtune"
ARCHITECTURE = ROOT / "docs" / "architecture.md"


def read_layers(text: str) -> dict[str, int]:
    """Table name (``data/`` for a package, ``fitness`` for a module) -> layer, from the marked table."""
    block = re.search(r"<!-- layers:.*?-->(.*?)<!-- end layers -->", text, re.S)
    assert block, "docs/architecture.md has no layer table between <!-- layers: ... --> and <!-- end layers -->"
    layers: dict[str, int] = {}
    for line in block.group(1).splitlines():
        cells = [c.strip() for c in line.strip().strip("|").split("|")]
        if len(cells) >= 2 and cells[0].isdigit():
            for name in re.findall(r"`([^`]+)`", cells[1]):
                assert name not in layers, f"{name} is placed twice in the layer table"
                layers[name] = int(cells[0])
    return layers


def module_path(dotted: str) -> str | None:
    """``simtune.report.figures`` -> ``report/figures``; a package -> ``x/__init__``; None if no such module."""
    parts = dotted.split(".")[1:]
    if not parts:
        return "__init__"
    if PACKAGE.joinpath(*parts).with_suffix(".py").is_file():
        return "/".join(parts)
    if (PACKAGE.joinpath(*parts) / "__init__.py").is_file():
        return "/".join([*parts, "__init__"])
    return None


def imported_modules(source: str, module: str, is_package: bool) -> list[tuple[int, str]]:
    """(line, dotted name) of every simtune module ``module`` imports, wherever the import statement is."""
    found = []
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, ast.Import):
            found += [(node.lineno, a.name) for a in node.names if a.name.split(".")[0] == "simtune"]
        elif isinstance(node, ast.ImportFrom):
            if node.level:  # relative: from the module's package, one level up per extra dot
                package = module.split(".") if is_package else module.split(".")[:-1]
                base = ".".join(package[: len(package) - node.level + 1] + ([node.module] if node.module else []))
            else:
                base = node.module or ""
            if base.split(".")[0] != "simtune":
                continue
            for alias in node.names:  # `from pkg import mod` imports pkg.mod; `from mod import name`, mod
                sub = f"{base}.{alias.name}"
                found.append((node.lineno, sub if module_path(sub) is not None else base))
    return found


def layer_of(path: str, layers: dict[str, int]) -> int | None:
    if path in layers:
        return layers[path]
    packages = [name for name in layers if name.endswith("/") and path.startswith(name)]
    return layers[max(packages, key=len)] if packages else None


def modules() -> list[tuple[str, Path]]:
    out = []
    for file in sorted(PACKAGE.rglob("*.py")):
        rel = file.relative_to(PACKAGE).with_suffix("")
        out.append(("/".join(rel.parts), file))
    return out


LAYERS = read_layers(ARCHITECTURE.read_text())


def test_the_table_places_every_module_and_names_only_modules():
    unplaced = [path for path, _ in modules() if layer_of(path, LAYERS) is None]
    assert not unplaced, f"modules missing from the layer table of docs/architecture.md: {unplaced}"
    for name in LAYERS:
        target = PACKAGE / name if name.endswith("/") else PACKAGE / f"{name}.py"
        assert target.exists(), f"the layer table names {name!r}, which is not in src/simtune"


@pytest.mark.parametrize("path,file", modules(), ids=[p for p, _ in modules()])
def test_no_import_runs_upwards(path, file):
    module = "simtune" if path == "__init__" else "simtune." + path.removesuffix("/__init__").replace("/", ".")
    own = layer_of(path, LAYERS)
    problems = []
    for line, dotted in imported_modules(file.read_text(), module, file.name == "__init__.py"):
        target = module_path(dotted)
        if target is None:
            problems.append(f"line {line}: {dotted} is not a module of simtune")
            continue
        theirs = layer_of(target, LAYERS)
        if theirs is None or own is None or theirs > own:
            problems.append(f"line {line}: imports {dotted} (layer {theirs}) from layer {own}")
    assert not problems, f"{file.relative_to(ROOT)}: " + "; ".join(problems)


def test_imports_are_found_in_functions_under_type_checking_and_relative():
    source = """
from typing import TYPE_CHECKING
import simtune.errors
from simtune.report import figures as F
from . import sections
from .collect import Group
from .. import fitness
if TYPE_CHECKING:
    from simtune.runs import RunConfig
def f():
    from simtune.grid import run_grid
    import numpy
"""
    found = {name for _, name in imported_modules(source, "simtune.report.builder", is_package=False)}
    assert found == {
        "simtune.errors",
        "simtune.report.figures",
        "simtune.report.sections",
        "simtune.report.collect",
        "simtune.fitness",
        "simtune.runs",
        "simtune.grid",
    }


def test_an_upward_import_is_caught():
    """The check itself can fail: the robot importing the tasks (as it once did) is a violation."""
    robot, tasks = layer_of("robot/generate", LAYERS), layer_of("tasks/spec", LAYERS)
    found = imported_modules("from simtune.tasks.spec import ObjectSpec", "simtune.robot.generate", False)
    assert found == [(1, "simtune.tasks.spec")]
    assert robot is not None and tasks is not None and tasks > robot


def unit_of(path: str) -> str:
    """The unit a module belongs to for the loop check: the layer table's name for it, a package (``tasks/``) or the
    module itself (``project``, ``engines/mujoco/export``)."""
    if path in LAYERS:
        return path
    packages = [name for name in LAYERS if name.endswith("/") and path.startswith(name)]
    return max(packages, key=len) if packages else path


def import_graph() -> dict[str, set[str]]:
    """Unit -> the other units its modules import (wherever the import statement is)."""
    graph: dict[str, set[str]] = {}
    for path, file in modules():
        module = "simtune" if path == "__init__" else "simtune." + path.removesuffix("/__init__").replace("/", ".")
        edges = graph.setdefault(unit_of(path), set())
        for _, dotted in imported_modules(file.read_text(), module, file.name == "__init__.py"):
            target = module_path(dotted)
            if target is not None and target != "__init__" and unit_of(target) != unit_of(path):
                edges.add(unit_of(target))
    return graph


def loops(graph: dict[str, set[str]]) -> list[list[str]]:
    """Each unit's shortest import chain back to itself (breadth first), for every unit that has one."""
    found = []
    for start in sorted(graph):
        paths = {start: [start]}
        queue = [start]
        while queue:
            unit = queue.pop(0)
            for target in sorted(graph.get(unit, ())):
                if target == start:
                    found.append([*paths[unit], start])
                    queue = []
                    break
                if target not in paths:
                    paths[target] = [*paths[unit], target]
                    queue.append(target)
    return found


def test_no_package_and_module_import_each_other():
    found = loops(import_graph())
    assert not found, "import loops (a package counts as one unit): " + "; ".join(" -> ".join(c) for c in found)


def test_a_loop_through_a_lazy_import_is_caught():
    """The loop the layers missed: tasks/__init__ reading the project inside a function, the project importing a
    task module; both in layer 4."""
    graph = {"tasks/": {"project"}, "project": {"tasks/"}, "errors": set()}
    assert loops(graph) == [["project", "tasks/", "project"], ["tasks/", "project", "tasks/"]]
    lazy = "def _project():\n    from simtune.project import get_project\n"
    assert imported_modules(lazy, "simtune.tasks", is_package=True) == [(2, "simtune.project")]
