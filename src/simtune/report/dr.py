"""Domain-randomisation ranges: what the tuned values of each engine's parameters span, as YAML."""

from __future__ import annotations

from pathlib import Path

import yaml

from simtune.params.space import PARAMETERS
from simtune.report.collect import Group


def dr_ranges(groups: list[Group], nominal: dict[str, dict[str, float]]) -> dict[str, dict[str, dict]]:
    """engine -> parameter -> {min, max, nominal, unit, bounds, runs} over all the engine's runs."""
    out: dict[str, dict[str, dict]] = {}
    for engine in sorted({g.engine for g in groups}):
        mine = [g for g in groups if g.engine == engine]
        names: list[str] = []
        for g in mine:
            names.extend(n for n in g.parameters if n not in names)
        params = {}
        for name in names:
            values = [v for g in mine if name in g.parameters for v in g.values(name)]
            bounds = next(g.bounds(name) for g in mine if name in g.parameters)
            nom = nominal.get(engine, {}).get(name)
            params[name] = {
                "min": float(min(values)),
                "max": float(max(values)),
                "nominal": None if nom is None else float(nom),
                "unit": PARAMETERS[name].unit if name in PARAMETERS else "",
                "bounds": [float(bounds[0]), float(bounds[1])],
                "runs": len(values),
            }
        out[engine] = params
    return out


def write_dr_yaml(path: Path, ranges: dict[str, dict[str, dict]], tasks_by_engine: dict[str, list[str]]) -> None:
    header = [
        "# Domain-randomisation ranges from simtune tuning runs (written by `simtune report`).",
        "# engine -> parameter -> min / max: the range the tuned values span across all the engine's",
        "# runs (repeats, tasks and spaces); nominal: the generic value (the engine's default, or the",
        "# controller's: max velocity of the task, command delay 0, marker offsets 0; null if unknown);",
        "# bounds: the tuning range; runs: how many runs tuned the parameter.",
    ]
    header += [f"# {engine}: tasks {', '.join(tasks)}" for engine, tasks in tasks_by_engine.items()]
    text = yaml.safe_dump(ranges, sort_keys=False, default_flow_style=None, width=100)
    path.write_text("\n".join(header) + "\n" + text)
