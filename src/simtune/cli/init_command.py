"""``simtune init``: a project for a new robot (from its URDF or MJCF, optionally with a LeRobot dataset whose
every episode becomes a task), a call into :func:`simtune.api.init_project`."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from simtune.cli.options import out_option, path
from simtune.cli.output import out, split
from simtune.errors import SimtuneError

RobotOpt = Annotated[
    Path,
    typer.Option(
        "--robot",
        help="The robot's URDF (meshes beside it) or MJCF file (MuJoCo Menagerie's layout), used in place.",
        callback=path,
    ),
]
InitOutOpt = Annotated[Path, out_option("The new project folder (must not exist, or be empty).")]
TrackedLinkOpt = Annotated[
    str | None,
    typer.Option(
        "--tracked-link",
        help="The link the motion capture follows (default: the end of the longest chain of arm joints).",
    ),
]
DrivenJointsOpt = Annotated[
    str | None,
    typer.Option(
        "--driven-joints",
        help="The joints the controller drives, in order, joined by commas (default: the arm joints up to "
        "the tracked link; gripper joints are held).",
    ),
]
PackagePathOpt = Annotated[
    list[str] | None,
    typer.Option(
        "--package-path",
        help="A folder where the URDF's package:// names are found (a package, or a folder of packages), or "
        "NAME=DIR: package NAME is folder DIR (whatever DIR is called); repeat for several. Also read: "
        "$SIMTUNE_PACKAGE_PATH, $ROS_PACKAGE_PATH.",
    ),
]
DensityOpt = Annotated[
    float | None,
    typer.Option(
        "--density",
        help="[kg/m^3] Links without an `<inertial>` get the mass and inertia of their collision (else visual) "
        "geometry as solids of this density (default 2700, aluminium).",
    ),
]
TotalMassOpt = Annotated[
    float | None,
    typer.Option("--total-mass", help="[kg] Instead of --density: spread this mass over those links by volume."),
]
DatasetOpt = Annotated[
    Path | None,
    typer.Option(
        "--dataset",
        help="A LeRobot dataset: the project's task is every episode of it, each its own task driven by its "
        "actions (joints mapped by name, the angle unit checked), instead of the example reach.",
    ),
]


def init(
    robot: RobotOpt,
    out_dir: InitOutOpt,
    tracked_link: TrackedLinkOpt = None,
    driven_joints: DrivenJointsOpt = None,
    package_path: PackagePathOpt = None,
    density: DensityOpt = None,
    total_mass: TotalMassOpt = None,
    dataset: DatasetOpt = None,
) -> None:
    """Start a project for your robot: a commented simtune.toml and an example task `reach` (or, with --dataset,
    every episode of a LeRobot dataset).

    Prints what it chose (tracked link, driven and held joints) and why.
    Example: simtune init --robot arm.urdf --out myproject (or --robot panda.xml, an MJCF); then simtune check
    myproject. From a dataset: simtune init --robot so101.urdf --dataset teleop --out so101
    """
    from simtune import api

    joints = None if driven_joints is None else split(driven_joints)
    if joints is not None and not joints:
        raise SimtuneError("init: --driven-joints names no joint (joint names joined by commas)")
    loaded: list = []
    made: list = []
    file = api.init_project(
        robot,
        out_dir,
        tracked_link=tracked_link,
        driven_joints=joints,
        package_path=package_path or (),
        loaded=loaded,
        density=density,
        total_mass=total_mass,
        dataset=dataset,
        made=made,
    )
    description = loaded[0]
    out.print(f"robot {description.name!r} from {robot}:", highlight=False, soft_wrap=True)
    out.print(f"  driven joints: {', '.join(description.arm_joints)}", highlight=False, soft_wrap=True)
    for note in description.choices:
        out.print(f"  {note}", highlight=False, soft_wrap=True, markup=False)
    if made:
        task = made[0]
        out.print(
            f"  dataset {dataset}: {task.episodes} episodes, tasks {task.name}.ep0 ... (--task {task.name}: all of "
            f"them); joints {', '.join(task.joints)} by name; units {task.units!r} (fit the joints' limits); "
            f"duration {task.duration_s:g} s (the shortest episode covers it)",
            highlight=False,
            soft_wrap=True,
            markup=False,
        )
    written = out_dir / "tasks" / f"{made[0].name if made else 'reach'}.toml"
    out.print(f"wrote {file} and {written}", highlight=False, soft_wrap=True)
    out.print(f"next: simtune check {out_dir}", highlight=False, soft_wrap=True)
