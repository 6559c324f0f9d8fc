"""What every engine's exporter is handed and shares: the export context (plain values), the robot as exporters see
it, the header comment, number formatting.

The context is built above the engines (``simtune/export/``: the run read and checked, its provenance) and passed
down: an exporter (``engines/<name>/export.py``) reads the tuned parameters, the tasks, the robot and the provenance
from it and imports nothing above the engine layer.  Every exported file names where it comes from: XML files and
scripts in a header comment (:func:`header_lines`), JSON sidecars in a ``provenance`` member.
"""

from __future__ import annotations

import hashlib
import json
import re
import shutil
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from simtune.engines._shapes import cone_hull
from simtune.engines.base import Engine
from simtune.errors import SimtuneError
from simtune.robot import description, generate
from simtune.tasks.spec import ObjectSpec, TaskSpec


@dataclass(frozen=True)
class RobotDescription:
    """The robot as export sees it: names and the generic model files, never the engines' internals.

    Every exporter takes the robot from here, so a robot described another way (a
    URDF of the user's) needs only another constructor, not other exporters.
    Tuning parameter ``<kind>_<i>`` of a joint or link (``joint_damping_3``,
    ``mass_link_3``) belongs to the i-th driven joint and to that joint's child link.
    """

    name: str
    driven_joints: tuple[str, ...]
    driven_links: tuple[str, ...]  # the child link of each driven joint
    wrist_link: str
    base_link: str
    base_position: tuple[float, float, float]
    urdf: str  # the robot alone, with generic values, base frame at the origin
    link_materials: dict[str, str]  # link -> material group of the friction/restitution parameters
    floor: str  # names of the floor and object elements in the scenes the engines build
    object: str
    description: description.RobotDescription  # the robot the engines built

    def scene_mjcf(self, obj: ObjectSpec | None) -> str:
        """The MuJoCo scene (robot, floor, the task's object) with generic values."""
        return generate.scene_mjcf(self.description, obj)


def exported_robot(robot: description.RobotDescription) -> RobotDescription:
    """The robot as exporters see it, from the description the engines built the run's tasks with."""
    return RobotDescription(
        name=robot.name,
        driven_joints=tuple(robot.arm_joints),
        driven_links=robot.driven_links,
        wrist_link=robot.tracked_link,
        base_link=robot.root,
        base_position=tuple(float(v) for v in robot.base_position),  # type: ignore[arg-type]
        urdf=generate.robot_urdf(robot),
        link_materials={link.name: link.material for link in robot.links},
        floor=generate.FLOOR,
        object=generate.OBJECT_BODY,
        description=robot,
    )


def num(value: float) -> str:
    """A float written so that parsing it gives the same double back (Python's shortest round-trip form)."""
    return repr(float(value))


def nums(values) -> str:
    return " ".join(num(v) for v in np.asarray(values, dtype=float).ravel())


def header_lines(prov: dict, what: str) -> list[str]:
    """The provenance as comment lines (without comment markers); values are JSON, so they parse back exactly."""
    j = json.dumps
    fitness = prov["fitness"]
    lines = [
        f"{what}",
        f"Exported by {prov['exported_by']} on {prov['date']} from a tuned run; provenance.json has the full record.",
        f"run: {j(prov['run'])}",
        f"engine: {j(prov['engine'])} {j(prov['engine_version'])} (run tuned with {j(prov['engine_version_of_run'])})",
        f"simtune: {j(prov['simtune_version'])}",
        f"tasks: {j(prov['tasks'])}  space: {j(prov['space'])}  seed: {j(prov['seed'])}  "
        f"optimizer: {j(prov['optimizer'])}  evaluations: {prov['evaluations']}",
        f"tuned fitness: {j(fitness)} m (wrist {j(prov['wrist_error'])} m, object {j(prov['object_error'])} m; "
        f"generic {j(prov['generic_fitness'])} m)",
        f"command: {j(prov['command'])}",
        f"data: {j(prov['data'])} ({prov['data_note']})",
    ]
    for task, files in prov["data_files"].items():
        lines += [f"data file: {j(task + '/' + f['file'])} {f['bytes']} bytes sha256 {f['sha256']}" for f in files]
    return lines


def xml_comment(lines: list[str]) -> str:
    # "--" may not appear inside an XML comment: it is written as "-\u002d", which JSON reads back as "--"
    body = "\n".join("  " + line.replace("--", "-\\u002d") for line in lines)
    return f"<!--\n{body}\n-->\n"


def hash_comment(lines: list[str]) -> str:
    return "".join(f"# {line}\n" if line else "#\n" for line in lines)


#: the model files whose referenced files an export carries with it
MODEL_SUFFIXES = (".xml", ".urdf", ".sdf")
#: the export's folder of the files its model files name (meshes)
CARRIED_FOLDER = "meshes"
#: a file-naming attribute of MJCF (``file``), URDF and SDF (``filename``), its value in double quotes
_FILE_ATTRIBUTE = re.compile(r'\b(file|filename)="([^"]+)"')


@dataclass
class ExportContext:
    """One export in progress, as plain values: the tuned parameters, the run's tasks, the robot, the folder, one
    engine per task with the tuned values applied, and the provenance every file names."""

    engine: str
    robot: RobotDescription
    out: Path
    params: dict[str, float]  # the run's tuned values (the rest keep the engine's generic ones)
    tasks: list[TaskSpec]  # the run's tasks, in its order
    engines: dict[str, Engine]  # task name -> engine after reset(params)
    values: dict[str, float]  # every engine parameter in force: the engine's generic values, then the tuned
    provenance: dict
    files: list[str] = field(default_factory=list)

    def header(self, what: str) -> list[str]:
        return header_lines(self.provenance, what)

    def write(self, name: str, text: str) -> Path:
        """Write the export's file ``name``; a model file (MJCF, URDF, SDF) first gets the files it names by absolute
        path (meshes) copied into ``meshes/`` and named relative to it, so the export travels to another machine."""
        path = self.claim(name)
        if Path(name).suffix in MODEL_SUFFIXES:
            text = self._carry_files(text)
        path.write_text(text)
        return path

    def _carry_files(self, text: str) -> str:
        """``text`` with every ``file=``/``filename=`` attribute that names an existing file by absolute path (a
        mesh in the robot's package, a convex hull in simtune's cache) copied into :data:`CARRIED_FOLDER` once and
        named there, relative to the export's folder where every model file lies."""

        def carried(match: re.Match) -> str:
            source = Path(match.group(2).removeprefix("file://"))
            if not source.is_absolute() or not source.is_file():
                return match.group(0)
            # the folder's hash keeps two meshes of one name (collision/link0.obj, visual/link0.obj) apart
            tag = hashlib.sha256(str(source.parent).encode()).hexdigest()[:8]
            name = f"{CARRIED_FOLDER}/{source.stem}-{tag}{source.suffix}"
            if name not in self.files:
                target = self.claim(name)
                target.parent.mkdir(exist_ok=True)
                shutil.copyfile(source, target)
            return f'{match.group(1)}="{name}"'

        return _FILE_ATTRIBUTE.sub(carried, text)

    def claim(self, name: str) -> Path:
        """The path of the export's file ``name``, listed; a file there that this export did not write (one a
        previous export, removed before, did not list) is refused rather than overwritten."""
        path = self.out / name
        if name not in self.files and path.exists():
            raise SimtuneError(f"{path} exists and is not a file of a previous export: export never overwrites it")
        if name not in self.files:
            self.files.append(name)
        return path

    def write_json(self, name: str, about: dict, body: dict) -> Path:
        """A JSON sidecar: ``about`` (what each member means), ``provenance``, then ``body``."""
        data = {"about": about, "provenance": self.provenance, **body}
        return self.write(name, json.dumps(data, indent=2) + "\n")


def write_cone_mesh(ctx: ExportContext, obj, task: str) -> str:
    """Write the convex hull of a cone object (the run's collision shape) as ``object_<task>.obj``; its name."""
    vertices, faces, _ = cone_hull(obj)
    name = f"object_{task}.obj"
    lines = [f"v {num(x)} {num(y)} {num(z)}" for x, y, z in vertices]
    lines += ["f " + " ".join(str(int(i) + 1) for i in face) for face in faces]
    header = hash_comment(ctx.header(f"convex hull of task {task!r}'s cone (the run's collision shape)"))
    ctx.write(name, header + "\n".join(lines) + "\n")
    return name
