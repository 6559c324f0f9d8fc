"""The report's figures, drawn with matplotlib's Agg canvas (no pyplot, no display, no global state).

Each function returns a :class:`matplotlib.figure.Figure`; :func:`save` writes
it as PNG and SVG and returns the PNG bytes for embedding.
"""

from __future__ import annotations

import io
import textwrap
from pathlib import Path

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure
from matplotlib.lines import Line2D
from matplotlib.ticker import MaxNLocator

from simtune.data.clock import spread_per_sample
from simtune.report.collect import Group
from simtune.report.simulate import GroupSimulation
from simtune.report.tables import GenericEntry, experiment_generic

PNG_DPI = 110
RECORDED = "#222222"
UNTUNED = "#d62728"
TUNED = "#1f77b4"
SPACE_STYLES = {
    "shared": ":",
    "individual": "--",
    "extended": "-",
    "calibrated": "-.",
    "gains": (0, (3, 1, 1, 1, 1, 1)),
    "drivetrain": (0, (5, 1, 1, 1)),
}
PALETTE = ("#1f77b4", "#ff7f0e", "#2ca02c", "#d62728", "#9467bd", "#8c564b", "#e377c2", "#7f7f7f", "#bcbd22", "#17becf")


def new_figure(width: float, height: float) -> Figure:
    fig = Figure(figsize=(width, height), layout="constrained")
    FigureCanvasAgg(fig)  # the Agg backend, attached to this figure only
    return fig


def save(fig: Figure, folder: Path, stem: str) -> bytes:
    """Write ``folder/stem.png`` and ``folder/stem.svg``; return the PNG bytes."""
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=PNG_DPI, metadata={"Software": None})
    png = buf.getvalue()
    (folder / f"{stem}.png").write_bytes(png)
    fig.savefig(folder / f"{stem}.svg", format="svg", metadata={"Date": None})
    return png


#: average width of a glyph of matplotlib's default font (DejaVu Sans), in ems: enough to wrap a title
#: before it runs past its figure or panel (a narrower estimate would let wide titles clip)
GLYPH_EM = 0.62
TITLE_PT = 14.4  # matplotlib's default title size ("large" of 12 pt)


def fit_text(text: str, width_in: float, fontsize: float = TITLE_PT) -> str:
    """``text`` wrapped into lines that fit ``width_in`` inches at ``fontsize`` points."""
    chars = max(16, int(width_in * 72 / (fontsize * GLYPH_EM)))
    return "\n".join(textwrap.wrap(text, chars, break_on_hyphens=False)) or text


def suptitle(fig: Figure, text: str, fontsize: float = TITLE_PT) -> None:
    """The figure's title, wrapped to the figure's width (a long title is never cut at the edges)."""
    fig.suptitle(fit_text(text, 0.94 * fig.get_figwidth(), fontsize), fontsize=fontsize)


def panel_title(ax, text: str, columns: int = 1, fontsize: float = 12.0) -> None:
    """A panel's title, wrapped to the width of one of ``columns`` panels side by side."""
    ax.set_title(fit_text(text, 0.85 * ax.figure.get_figwidth() / max(1, columns), fontsize), fontsize=fontsize)


def engine_colors(engines: list[str]) -> dict[str, str]:
    return {e: PALETTE[i % len(PALETTE)] for i, e in enumerate(sorted(set(engines)))}


def _grid(n: int, ncols: int = 2) -> tuple[int, int]:
    ncols = max(1, min(n, ncols))
    return (n + ncols - 1) // ncols, ncols


def _maybe_log(ax, values) -> None:
    v = np.asarray([x for x in values if np.isfinite(x) and x > 0])
    if v.size and v.max() / v.min() > 20:
        ax.set_yscale("log")


# --- 3. convergence ---------------------------------------------------------------------------------
CONVERGENCE_AXES = {
    "generation": "generation",
    "evaluations": "evaluations",
    "time": "wall time [s]",
}


Curve = tuple[np.ndarray, np.ndarray]  # x values, best fitness so far


def run_curve(run, axis: str) -> Curve:
    """Best fitness so far against ``axis`` for one run (generation 0 = best of the initial population)."""
    xs, ys = [], []
    if run.record.initial_fitness and axis != "time":  # the initial population's wall time is not stored on its own
        xs.append(0 if axis == "generation" else len(run.record.initial_fitness))
        ys.append(min(run.record.initial_fitness))
    key = {"generation": "generation", "evaluations": "evaluations", "time": "elapsed_s"}[axis]
    for g in run.record.generations:
        xs.append(g[key])
        ys.append(g["best_fitness"])
    return np.asarray(xs, dtype=float), np.minimum.accumulate(np.asarray(ys, dtype=float)) if ys else np.array([])


def aggregate_curves(curves: list[Curve]) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Mean, min and max over repeats on the union of their x values.

    Between its points a repeat keeps its best so far, and after its last one its
    final value (it stopped).  The curve starts where every repeat has a value,
    so a repeat joining later never lifts the mean.
    """
    curves = [(x, y) for x, y in curves if x.size]
    if not curves:
        empty = np.array([])
        return empty, empty, empty, empty
    grid = np.unique(np.concatenate([x for x, _ in curves]))
    grid = grid[grid >= max(x[0] for x, _ in curves)]
    table = np.full((len(curves), grid.size), np.nan)
    for i, (x, y) in enumerate(curves):
        idx = np.searchsorted(x, grid, side="right") - 1
        table[i, idx >= 0] = y[idx[idx >= 0]]
    return grid, np.nanmean(table, axis=0), np.nanmin(table, axis=0), np.nanmax(table, axis=0)


def convergence_figure(groups: list[Group], axis: str) -> Figure:
    experiments = sorted({g.tasks for g in groups})
    spaces = sorted({g.space for g in groups})
    colors = engine_colors([g.engine for g in groups])
    nrows, ncols = _grid(len(experiments))
    fig = new_figure(6.4 * ncols, 3.9 * nrows + 0.4)
    axes = fig.subplots(nrows, ncols, squeeze=False)
    for k, tasks in enumerate(experiments):
        ax = axes[k // ncols][k % ncols]
        every: list[float] = []
        for g in (g for g in groups if g.tasks == tasks):
            x, mean, lo, hi = aggregate_curves([run_curve(r, axis) for r in g.runs])
            if not x.size:
                continue
            label = g.engine if len(spaces) == 1 else f"{g.engine} ({g.space})"
            style = SPACE_STYLES.get(g.space, "-.")
            ax.fill_between(x, lo, hi, color=colors[g.engine], alpha=0.18, linewidth=0)
            ax.plot(
                x,
                mean,
                color=colors[g.engine],
                linestyle=style,
                linewidth=1.8,
                marker="o" if x.size <= 60 else None,
                markersize=3,
                label=f"{label} (n={len(g.runs)})",
            )
            every.extend(lo)
            every.extend(hi)
        _maybe_log(ax, every)
        panel_title(ax, f"task: {tasks}", ncols)
        ax.set_xlabel(CONVERGENCE_AXES[axis])
        if axis != "time":
            ax.xaxis.set_major_locator(MaxNLocator(integer=True))
        ax.set_ylabel("best fitness so far")
        ax.grid(alpha=0.3)
        ax.legend(fontsize="small")
    for k in range(len(experiments), nrows * ncols):
        axes[k // ncols][k % ncols].set_visible(False)
    suptitle(fig, f"Convergence: best fitness vs {CONVERGENCE_AXES[axis]}")
    return fig


# --- 2. fitness overview ------------------------------------------------------------------------------
def fitness_overview_figure(groups: list[Group], entries: list[GenericEntry]) -> Figure:
    keys = sorted({(g.tasks, g.space) for g in groups})
    colors = engine_colors([g.engine for g in groups])
    nrows, ncols = _grid(len(keys))
    fig = new_figure(6.4 * ncols, 3.8 * nrows + 0.4)
    axes = fig.subplots(nrows, ncols, squeeze=False)
    for k, (tasks, space) in enumerate(keys):
        ax = axes[k // ncols][k % ncols]
        mine = [g for g in groups if (g.tasks, g.space) == (tasks, space)]
        names = mine[0].task_names
        generic = experiment_generic(entries, names, None)
        labels = [g.engine for g in mine] + sorted(lbl for lbl in generic if lbl.endswith("(published)"))
        every = []
        for i, label in enumerate(labels):
            if label in generic:
                ax.bar(
                    i,
                    generic[label],
                    width=0.6,
                    color="#cccccc",
                    edgecolor="#888888",
                    hatch="//" if label.endswith("(published)") else None,
                )
                every.append(generic[label])
            group = next((g for g in mine if g.engine == label), None)
            if group is not None:
                tuned = [r.best_fitness for r in group.runs]
                jitter = np.linspace(-0.15, 0.15, len(tuned)) if len(tuned) > 1 else np.zeros(1)
                ax.scatter(i + jitter, tuned, color=colors[label], zorder=3, s=22, edgecolor="black", linewidth=0.4)
                ax.hlines(np.mean(tuned), i - 0.28, i + 0.28, color=colors[label], linewidth=2, zorder=3)
                every.extend(tuned)
        _maybe_log(ax, every)
        ax.set_xticks(range(len(labels)))
        ax.set_xticklabels(
            [lbl.replace(" (published)", "\n(published)") for lbl in labels],
            fontsize="small",
            rotation=35,
            ha="right",
            rotation_mode="anchor",
        )
        ax.set_ylabel("fitness [m]")
        panel_title(ax, f"task: {tasks}, space: {space}", ncols)
        ax.grid(axis="y", alpha=0.3)
    for k in range(len(keys), nrows * ncols):
        axes[k // ncols][k % ncols].set_visible(False)
    handles = [
        Line2D(
            [],
            [],
            color="#cccccc",
            marker="s",
            markersize=10,
            linestyle="",
            markeredgecolor="#888888",
            label="generic (untuned)",
        ),
        Line2D([], [], color="#555555", marker="o", linestyle="", label="tuned, one dot per repeat"),
        Line2D([], [], color="#555555", linewidth=2, label="tuned mean"),
    ]
    fig.legend(handles=handles, loc="outside lower center", ncols=3, fontsize="small")
    suptitle(fig, "Fitness: generic vs tuned (lower is better)")
    return fig


# --- 4. parameter distributions --------------------------------------------------------------------------
def _boxplot(ax, data, positions) -> None:
    kwargs = dict(
        positions=positions,
        widths=0.6,
        patch_artist=True,
        showfliers=False,
        whis=(0, 100),
        boxprops=dict(facecolor="#dde8f5", edgecolor="#335"),
        medianprops=dict(color="#335"),
    )
    try:
        ax.boxplot(data, orientation="horizontal", **kwargs)
    except TypeError:  # matplotlib < 3.10
        ax.boxplot(data, vert=False, **kwargs)


def parameters_figure(groups: list[Group], nominal: dict[str, dict[str, float]]) -> Figure:
    """Tuned values of one (tasks, space) across repeats, one panel per engine, each normalised to its range."""
    names: list[str] = []
    for g in groups:
        names.extend(n for n in g.parameters if n not in names)
    colors = engine_colors([g.engine for g in groups])
    fig = new_figure(2.6 + 3.3 * len(groups), 1.4 + 0.3 * len(names))
    axes = fig.subplots(1, len(groups), sharey=True, squeeze=False)[0]
    positions = np.arange(len(names))[::-1]  # first parameter on top
    for ax, g in zip(axes, groups):
        data, where = [], []
        for name, y in zip(names, positions):
            if name not in g.parameters:
                continue
            low, high = g.bounds(name)
            values = (np.asarray(g.values(name)) - low) / ((high - low) or 1.0)
            data.append(values)
            where.append(y)
            jitter = np.linspace(-0.18, 0.18, values.size) if values.size > 1 else np.zeros(1)
            ax.scatter(values, y + jitter, s=16, color=colors[g.engine], zorder=3, edgecolor="black", linewidth=0.3)
            nom = nominal.get(g.engine, {}).get(name)
            if nom is not None and low <= nom <= high:
                ax.scatter(
                    [(nom - low) / ((high - low) or 1.0)],
                    [y],
                    marker="D",
                    s=22,
                    facecolor="none",
                    edgecolor=UNTUNED,
                    zorder=4,
                )
        if data:
            _boxplot(ax, data, where)
        ax.set_xlim(-0.03, 1.03)
        panel_title(ax, f"{g.engine} (n={len(g.runs)})", len(groups))
        ax.set_xlabel("tuned value, normalised to [low, high]")
        ax.grid(axis="x", alpha=0.3)
    axes[0].set_yticks(positions)
    axes[0].set_yticklabels(names, fontsize="small")
    axes[0].set_ylim(-0.7, len(names) - 0.3)
    handles = [
        Line2D([], [], marker="o", linestyle="", color="#555555", markersize=4, label="one repeat"),
        Line2D(
            [],
            [],
            marker="D",
            linestyle="",
            markerfacecolor="none",
            markeredgecolor=UNTUNED,
            label="generic (nominal) value",
        ),
    ]
    fig.legend(handles=handles, loc="outside lower center", ncols=2, fontsize="small")
    suptitle(fig, f"Tuned parameters across repeats: task {groups[0].tasks}, space {groups[0].space}")
    return fig


# --- 6. trajectories (the paper's Figure 1) -----------------------------------------------------------------
def _path_panel(fig: Figure, cell, traj, wrist: tuple[np.ndarray, np.ndarray], lines: tuple, ncols: int) -> None:
    """The end effector's path in 3-D: the recorded repeats and mean (``wrist``), untuned and tuned."""
    wrist_mean, wrist_repeats = wrist
    n = len(traj.reference.times)
    ax3 = fig.add_subplot(cell, projection="3d")
    for k, rep in enumerate(wrist_repeats):
        ax3.plot(*rep.T, color="#999999", linewidth=0.5, alpha=0.5, label="recorded repeats" if k == 0 else None)
    ax3.plot(*wrist_mean.T, color=RECORDED, linewidth=2.0, label="recorded mean")
    for label, marker, color, style in lines:
        ax3.plot(*marker[:n].T, color=color, linestyle=style, linewidth=1.5, label=label)
    ax3.scatter(*wrist_mean[0], color=RECORDED, marker="o", s=20)
    # equal scales on the three axes (true geometry, as the arm moved), with room for the labels
    pts = np.vstack([wrist_repeats.reshape(-1, 3), traj.untuned_marker[:n], traj.tuned_marker[:n]])
    centre, half = (pts.min(axis=0) + pts.max(axis=0)) / 2, max(float(np.ptp(pts, axis=0).max()), 0.05) * 0.52
    ax3.set_xlim(centre[0] - half, centre[0] + half)
    ax3.set_ylim(centre[1] - half, centre[1] + half)
    ax3.set_zlim(centre[2] - half, centre[2] + half)
    ax3.set_box_aspect((1, 1, 1), zoom=0.88)
    ax3.set_xlabel("x [m]")
    ax3.set_ylabel("y [m]")
    ax3.set_zlabel("z [m]")
    panel_title(ax3, "end-effector path", ncols)
    ax3.legend(fontsize="small", loc="upper left")


def _time_panels(fig: Figure, gs, traj, wrist: tuple[np.ndarray, np.ndarray], lines: tuple, ncols: int) -> None:
    """The end effector's x, y and z against time, one panel each: recorded min-max and mean, untuned, tuned."""
    wrist_mean, wrist_repeats = wrist
    t = traj.reference.times
    n = len(t)
    lo, hi = wrist_repeats.min(axis=0), wrist_repeats.max(axis=0)
    for i, axis in enumerate("xyz"):
        ax = fig.add_subplot(gs[i, 1])
        ax.fill_between(t, lo[:, i], hi[:, i], color="#999999", alpha=0.35, linewidth=0, label="recorded min-max")
        ax.plot(t, wrist_mean[:, i], color=RECORDED, linewidth=1.6, label="recorded mean")
        for label, marker, color, style in lines:
            ax.plot(t, marker[:n, i], color=color, linestyle=style, linewidth=1.3, label=label)
        ax.set_ylabel(f"{axis} [m]")
        ax.grid(alpha=0.3)
        if i == 0:
            panel_title(ax, "end effector against time", ncols)
            ax.legend(fontsize="x-small", ncols=2)


def _error_panel(fig: Figure, cell, traj, wrist: tuple[np.ndarray, np.ndarray], lines: tuple) -> None:
    """Each simulation's distance from the recorded mean against time, over the repeats' own spread about it, with
    the schedule's phase starts."""
    wrist_mean, wrist_repeats = wrist
    t = traj.reference.times
    n = len(t)
    ax = fig.add_subplot(cell)
    # on a log scale: the untuned error is often 100 x the tuned one, and the repeats' spread 10 x below that
    floor = 0.1  # mm: the scale's bottom, well below any motion-capture repeatability
    spread = spread_per_sample(wrist_repeats)
    ax.fill_between(t, floor, np.maximum(1000.0 * spread, floor), color="#999999", alpha=0.35, linewidth=0)
    ax.plot([], [], color="#999999", alpha=0.6, linewidth=6, label="repeat spread")
    for label, marker, color, style in lines:
        error = np.linalg.norm(marker[:n] - wrist_mean, axis=1)
        ax.plot(t, np.maximum(1000.0 * error, floor), color=color, linestyle=style, linewidth=1.3, label=label)
    for _, start, _ in traj.spans[1:]:
        ax.axvline(start, color="#555555", linestyle=":", linewidth=0.9)
    ax.set_yscale("log")
    ax.set_ylim(bottom=floor)
    ax.set_ylabel("wrist error [mm]")
    ax.set_xlabel("time [s]")
    ax.grid(alpha=0.3)
    ax.legend(fontsize="x-small", ncols=3)


def _object_panel(fig: Figure, cell, traj, finals: np.ndarray, objects: tuple[np.ndarray, np.ndarray], ncols: int):
    """The object seen from above: the recorded final positions and start, the untuned and tuned paths."""
    ref = traj.reference
    untuned_object, tuned_object = objects
    n = len(ref.times)
    ax = fig.add_subplot(cell)
    ax.scatter(finals[:, 0], finals[:, 1], s=14, color="#999999", label=f"recorded repeats ({len(finals)})")
    mean = finals.mean(axis=0)
    ax.scatter([mean[0]], [mean[1]], s=60, color=RECORDED, marker="x", label="recorded mean")
    if ref.object_start is not None:
        start = ref.object_start.mean(axis=0)
        ax.scatter(
            [start[0]], [start[1]], s=40, facecolor="none", edgecolor=RECORDED, marker="s", label="recorded start"
        )
    for label, obj, color, symbol in (
        ("untuned", untuned_object, UNTUNED, "v"),
        ("tuned", tuned_object, TUNED, "^"),
    ):
        ax.plot(obj[:n, 0], obj[:n, 1], color=color, linewidth=0.8, alpha=0.7)
        ax.scatter(
            [obj[n - 1, 0]],
            [obj[n - 1, 1]],
            s=50,
            color=color,
            marker=symbol,
            label=f"{label} final ({np.linalg.norm(obj[n - 1] - mean) * 1000:.1f} mm off)",
        )
    ax.set_aspect("equal", adjustable="datalim")
    ax.xaxis.set_major_locator(MaxNLocator(4))
    ax.yaxis.set_major_locator(MaxNLocator(6))
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    panel_title(ax, "object, seen from above", ncols)
    ax.grid(alpha=0.3)
    ax.legend(fontsize="x-small", loc="best")


def trajectory_figure(sim: GroupSimulation, task: str) -> Figure:
    import mpl_toolkits.mplot3d  # noqa: F401  (registers the 3-D projection on old matplotlib)

    traj = sim.tasks[task]
    ref = traj.reference
    wrist_mean, wrist_repeats = ref.wrist_mean, ref.wrist_repeats
    if wrist_mean is None or wrist_repeats is None:
        raise ValueError(f"task {task}: the recordings track no wrist marker to draw")
    finals, untuned_object, tuned_object = ref.object_final, traj.untuned_object, traj.tuned_object
    has_object = finals is not None and untuned_object is not None and tuned_object is not None
    ncols = 3 if has_object else 2
    fig = new_figure(5.2 * ncols, 8.4)
    gs = fig.add_gridspec(4, ncols, width_ratios=[1.25, 1.0, 1.0][:ncols])
    lines = (("untuned", traj.untuned_marker, UNTUNED, "--"), ("tuned", traj.tuned_marker, TUNED, "-"))
    _path_panel(fig, gs[:, 0], traj, (wrist_mean, wrist_repeats), lines, ncols)
    _time_panels(fig, gs, traj, (wrist_mean, wrist_repeats), lines, ncols)
    _error_panel(fig, gs[3, 1], traj, (wrist_mean, wrist_repeats), lines)
    if finals is not None and untuned_object is not None and tuned_object is not None:
        _object_panel(fig, gs[:, 2], traj, finals, (untuned_object, tuned_object), ncols)

    g = sim.group
    suptitle(
        fig,
        f"{g.engine} on {task} (space {g.space}): fitness untuned {traj.untuned_score.fitness:.4f}, "
        f"tuned {traj.tuned_score.fitness:.4f} (best repeat: seed {sim.run.config.seed})",
    )
    return fig


# --- 6b. joint logs: each joint's angle against time ------------------------------------------------------------
def joint_figure(sim: GroupSimulation, task: str) -> Figure:
    """Each logged joint's angle against time [deg]: the recorded repeats' min-max and mean, the untuned and the
    tuned simulation, one panel per joint; under them the mean absolute joint error against time over the repeats'
    own spread about their mean, with the schedule's phase starts (the joint-log counterpart of
    :func:`trajectory_figure`).

    Args:
        sim: the group's best run re-simulated (:func:`simtune.report.simulate.simulate_group`).
        task: one of its tasks whose recordings log joint angles.
    Returns:
        The figure.
    """
    traj = sim.tasks[task]
    ref = traj.reference
    if ref.joint_mean is None or ref.joint_repeats is None or traj.untuned_joints is None or traj.tuned_joints is None:
        raise ValueError(f"task {task}: the recordings log no joint angles to draw")
    t = ref.times
    n = len(t)
    mean, repeats = np.degrees(ref.joint_mean), np.degrees(ref.joint_repeats)
    lines = (("untuned", np.degrees(traj.untuned_joints[:n]), UNTUNED, "--"),
             ("tuned", np.degrees(traj.tuned_joints[:n]), TUNED, "-"))  # fmt: skip
    joints = ref.joint_names
    rows, ncols = _grid(len(joints), 3)
    fig = new_figure(4.6 * ncols, 2.5 * (rows + 1) + 0.8)
    gs = fig.add_gridspec(rows + 1, ncols)
    lo, hi = repeats.min(axis=0), repeats.max(axis=0)
    for k, name in enumerate(joints):
        ax = fig.add_subplot(gs[k // ncols, k % ncols])
        ax.fill_between(t, lo[:, k], hi[:, k], color="#999999", alpha=0.35, linewidth=0, label="recorded min-max")
        ax.plot(t, mean[:, k], color=RECORDED, linewidth=1.6, label="recorded mean")
        for label, angles, color, style in lines:
            ax.plot(t, angles[:, k], color=color, linestyle=style, linewidth=1.3, label=label)
        ax.set_ylabel("angle [deg]")
        ax.grid(alpha=0.3)
        panel_title(ax, name, ncols)
        if k == 0:
            ax.legend(fontsize="x-small", ncols=2)
    ax = fig.add_subplot(gs[rows, :])
    # on a log scale, as the wrist error: the untuned error is often far above the tuned one and the repeats' spread
    floor = 0.01  # deg: the scale's bottom, below a servo encoder's resolution
    spread = np.abs(repeats - mean[None]).mean(axis=(0, 2))
    ax.fill_between(t, floor, np.maximum(spread, floor), color="#999999", alpha=0.35, linewidth=0)
    ax.plot([], [], color="#999999", alpha=0.6, linewidth=6, label="repeat spread")
    for label, angles, color, style in lines:
        error = np.abs(angles - mean).mean(axis=1)
        ax.plot(t, np.maximum(error, floor), color=color, linestyle=style, linewidth=1.3, label=label)
    for _, start, _ in traj.spans[1:]:
        ax.axvline(start, color="#555555", linestyle=":", linewidth=0.9)
    ax.set_yscale("log")
    ax.set_ylim(bottom=floor)
    ax.set_ylabel("mean joint error [deg]")
    ax.set_xlabel("time [s]")
    ax.grid(alpha=0.3)
    ax.legend(fontsize="x-small", ncols=3)
    g = sim.group
    suptitle(
        fig,
        f"{g.engine} on {task} (space {g.space}): joint angles; fitness untuned {traj.untuned_score.fitness:.4g}, "
        f"tuned {traj.tuned_score.fitness:.4g} (best repeat: seed {sim.run.config.seed})",
    )
    return fig


# --- the paper's Figure 4: one parameter's tuned values, raw, engines x experiments ------------------------
def figure4(groups: list[Group], parameter: str) -> Figure:
    """The tuned values of ``parameter`` in its own units: one panel per space, the experiments along x,
    a box and one dot per repeat for each engine side by side, the tuning range as the y limits."""
    from simtune.params.space import PARAMETERS
    from simtune.report.tables import experiment_label

    mine = [g for g in groups if parameter in g.parameters]
    spaces = sorted({g.space for g in mine})
    experiments = sorted({g.tasks for g in mine}, key=_experiment_order)
    engines = sorted({g.engine for g in mine})
    colors = engine_colors(engines)
    width = max(6.4, 1.2 + 0.5 * len(experiments) * max(1, len(engines)))
    fig = new_figure(width, 3.4 * len(spaces) + 0.8)
    axes = fig.subplots(len(spaces), 1, squeeze=False)[:, 0]
    step = 0.8 / max(1, len(engines))
    for ax, space in zip(axes, spaces):
        low, high = next(g.bounds(parameter) for g in mine if g.space == space)
        for e, engine in enumerate(engines):
            for x, tasks in enumerate(experiments):
                group = next((g for g in mine if (g.engine, g.tasks, g.space) == (engine, tasks, space)), None)
                if group is None:
                    continue
                values = np.asarray(group.values(parameter))
                at = x - 0.4 + step * (e + 0.5)
                ax.boxplot(
                    [values],
                    positions=[at],
                    widths=0.8 * step,
                    patch_artist=True,
                    showfliers=False,
                    whis=(0, 100),
                    boxprops=dict(facecolor=colors[engine], alpha=0.35, edgecolor=colors[engine]),
                    medianprops=dict(color=colors[engine]),
                    whiskerprops=dict(color=colors[engine]),
                    capprops=dict(color=colors[engine]),
                )
                jitter = np.linspace(-0.25, 0.25, values.size) * step if values.size > 1 else np.zeros(1)
                ax.scatter(at + jitter, values, s=14, color=colors[engine], edgecolor="black", linewidth=0.3, zorder=3)
        ax.set_xticks(range(len(experiments)))
        ax.set_xticklabels([experiment_label(t) for t in experiments], fontsize="small")
        ax.set_xlim(-0.6, len(experiments) - 0.4)
        margin = 0.03 * (high - low)
        ax.set_ylim(low - margin, high + margin)
        unit = PARAMETERS[parameter].unit if parameter in PARAMETERS else ""
        ax.set_ylabel(f"{parameter} [{unit}]" if unit else parameter)
        ax.set_xlabel("experiment")
        ax.grid(axis="y", alpha=0.3)
        panel_title(ax, f"space: {space}")
    fig.legend(
        handles=[Line2D([], [], color=colors[e], marker="s", linestyle="", markersize=8, label=e) for e in engines],
        loc="outside lower center",
        ncols=min(len(engines), 5),
        fontsize="small",
    )
    suptitle(fig, f"Tuned {parameter} per experiment and engine (raw values; y range: the tuning range)")
    return fig


def _experiment_order(tasks: str) -> tuple[int, str]:
    """Seed tasks in the paper's order (seed-2 before seed-10), then the others by name."""
    number = tasks.removeprefix("seed-")
    return (int(number), "") if tasks.startswith("seed-") and number.isdigit() else (10**6, tasks)
