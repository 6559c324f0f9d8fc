"""The arm at its first contact with each task's object: a side and a top view per task.

Drawn from the probe's joint angles with the arm's own collision boxes
(the task's robot description) and the object's outline at its position at that
instant (turned as at its start: at first contact it has not moved yet).
"""

from __future__ import annotations

import itertools
from collections.abc import Mapping

import numpy as np
from matplotlib.figure import Figure
from matplotlib.lines import Line2D
from matplotlib.patches import Polygon
from scipy.spatial import ConvexHull

from simtune.engines.contact import ContactProbe
from simtune.report.figures import PALETTE, new_figure, panel_title
from simtune.robot.description import RobotDescription
from simtune.tasks import TaskSpec, get_task

ARM_COLOR = "#9a9a9a"
HAND_COLOR = PALETTE[0]
OBJECT_COLOR = PALETTE[1]
#: the views: (name, horizontal axis, vertical axis as world coordinate indices, close to the object)
VIEWS = (("side", 0, 2, False), ("side", 0, 2, True), ("top", 0, 1, True))
_AXIS_NAMES = "xyz"
_CORNERS = np.array(list(itertools.product((-1.0, 1.0), repeat=3)))
TASKS_PER_ROW = 4
ZOOM = 0.2  # half width of the top view around the object's start [m]


def arm_boxes(robot: RobotDescription, angles: np.ndarray) -> list[tuple[str, np.ndarray]]:
    """(material, 8 world corners) of every collision box of ``robot`` at joint angles ``angles`` [rad]."""
    boxes = []
    for link in robot.links:
        pos, rot = robot.forward_kinematics(angles, link.name)
        for box in link.boxes:
            corners = pos + (np.asarray(box.center) + _CORNERS * np.asarray(box.half)) @ rot.T
            boxes.append((link.material, corners))
    return boxes


def _outline(points: np.ndarray, i: int, j: int) -> np.ndarray:
    flat = points[:, [i, j]]
    return flat[ConvexHull(flat).vertices]


def contact_figure(probes: list[ContactProbe], tasks: Mapping[str, TaskSpec] | None = None) -> Figure:
    """The arm at each probe's first contact: from the side (the whole arm, then near the object) and
    from above (near the object).  A probe without contact shows the arm's final pose.  ``tasks``: the
    probed tasks by name (default: the bundled MICO project's).
    """
    n = len(probes)
    cols = max(1, min(n, TASKS_PER_ROW))
    rows = (n + cols - 1) // cols
    fig = new_figure(3.0 * cols, 8.0 * rows + 0.4)
    grid = fig.add_gridspec(len(VIEWS) * rows, cols)
    for k, probe in enumerate(probes):
        row, col = divmod(k, cols)
        task = tasks[probe.task] if tasks is not None else get_task(probe.task)
        obj = task.object
        assert obj is not None, "a probe is made for a task with an object"
        object_points = probe.pose_object + obj.surface_points() @ obj.rotation.T
        boxes = arm_boxes(task.robot, probe.pose_angles)
        for v, (view, i, j, close) in enumerate(VIEWS):
            ax = fig.add_subplot(grid[len(VIEWS) * row + v, col])
            for material, corners in boxes:
                color = HAND_COLOR if material == "gripper" else ARM_COLOR
                ax.add_patch(
                    Polygon(
                        _outline(corners, i, j),
                        closed=True,
                        facecolor=color,
                        edgecolor="#444444",
                        linewidth=0.4,
                        alpha=0.75,
                        zorder=2,
                    )
                )
            # seen from above, the arm covers the object; from the side, the object is drawn in front
            ax.add_patch(
                Polygon(
                    _outline(object_points, i, j),
                    closed=True,
                    facecolor=OBJECT_COLOR,
                    edgecolor="#444444",
                    linewidth=0.6,
                    alpha=0.9,
                    zorder=3 if view == "side" else 1,
                )
            )
            if view == "side":
                ax.axhline(0.0, color="#222222", linewidth=0.8)
            if v == 0:
                when = (
                    f"contact at {probe.first_contact_s:.2f} s"
                    if probe.first_contact_s is not None
                    else "no contact (final pose)"
                )
                title = f"{probe.task} ({probe.engine}): {when}, moved {probe.object_displacement_m * 100:.1f} cm"
                panel_title(ax, title, cols, fontsize=8.5)
            if not close:  # the whole arm
                ax.set_xlim(-0.15, 0.85)
                ax.set_ylim(-0.05, 0.95)
            else:  # around the object (from the side: from the floor up)
                cx, cy = probe.object_start[i], probe.object_start[j]
                ax.set_xlim(cx - ZOOM, cx + ZOOM)
                ax.set_ylim(*((cy - ZOOM, cy + ZOOM) if view == "top" else (-0.02, 2 * ZOOM - 0.02)))
            ax.set_aspect("equal")
            ax.tick_params(labelsize=7)
            ax.set_xlabel(f"{_AXIS_NAMES[i]} [m]", fontsize=7.5)
            ax.set_ylabel(f"{_AXIS_NAMES[j]} [m] ({view})", fontsize=7.5)
    fig.legend(
        handles=[
            Line2D([], [], color=ARM_COLOR, linewidth=6, label="arm"),
            Line2D([], [], color=HAND_COLOR, linewidth=6, label="hand and fingers"),
            Line2D([], [], color=OBJECT_COLOR, linewidth=6, label="object"),
        ],
        loc="outside lower center",
        ncol=3,
        fontsize=8,
        frameon=False,
    )
    return fig
