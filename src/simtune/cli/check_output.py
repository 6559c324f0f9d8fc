"""What ``simtune check --task`` prints: each task's data quality (its recordings, the repeats' agreement and clocks,
the motion onset, the rest poses with proposed targets) and what the recordings can inform."""

from __future__ import annotations

from rich.markup import escape

from simtune.cli.output import fmt_g, out, print_whole_table
from simtune.common.console import text_table


def print_data_quality(parts: list[dict]) -> None:
    for part in parts:
        selection = f", repeats {part['repeat_selection']}" if "repeat_selection" in part else ""
        title = (
            f"{part['task']}: {len(part['repeats'])} repeats, spread {1000 * part['repeat_spread_m']:.1f} mm "
            f"(reference: {part['reference']}{selection})"
        )
        headers = (
            "file",
            "lost frames",
            "longest gap [s]",
            "to mean [mm]",
            "as recorded [mm]",
            "start distance [mm]",
            "onset [s]",
            "shift [s]",
            "floor",
        )
        rows = [
            (
                r["file"],
                str(r["lost_frames"]),
                f"{r['longest_gap_s']:.2f}",
                f"{1000 * r['distance_to_mean_m']:.1f}" + (" (outlier)" if r["outlier"] else ""),
                f"{1000 * r['distance_to_mean_unaligned_m']:.1f}",
                f"{1000 * r['start_distance_m']:.1f}",
                fmt_g(r["onset_s"]),
                f"{r['shift_s']:+.3f}" + (" (outlier)" if r["shift_outlier"] else ""),
                "-" if r["floor_fitness"] is None else f"{r['floor_fitness']:.4f}",
            )
            for r in part["repeats"]
        ]
        print_whole_table(title, headers, rows)
        if "repeat_selection" in part:
            held = ", ".join(part["held_out"]) or "none"
            out.print(
                f"  repeats {part['repeat_selection']}: the {len(part['repeats'])} above, of "
                f"{len(part['repeats']) + len(part['held_out'])} usable; held out: {held}",
                highlight=False,
                soft_wrap=True,
            )
        for line in part["left_out"]:
            out.print(f"  {'left out' if 'left out' in line else 'warning'}: {escape(line)}")
        out.print(
            f"  repeat spread {1000 * part['repeat_spread_unaligned_m']:.1f} mm as recorded, "
            f"{1000 * part['repeat_spread_aligned_m']:.1f} mm with the clocks aligned (shifts "
            f"{part['shift_range_s'][0]:+.3f} to {part['shift_range_s'][1]:+.3f} s); "
            + (
                "no floor: one repeat, which scores 0 against itself (record two or more to know what a tuned "
                "simulation compares with)"
                if part["floor_fitness"] is None
                else f"floor: the aligned mean scores {part['floor_fitness']:.4f} against the repeats (mean), what a "
                "tuned simulation compares with"
            )
        )
        _print_onset(part)
        if touches := part.get("floor_touches_s"):
            from simtune.engines.contact import FLOOR_TOUCH_CONSEQUENCE, touch_spans_text

            out.print(
                f"  warning: the generic simulation's arm touches the floor ({touch_spans_text(touches)}): "
                + FLOOR_TOUCH_CONSEQUENCE,
                highlight=False,
                soft_wrap=True,
            )
        _print_rest_poses(part)


def _print_onset(part: dict) -> None:
    """The motion onset: the repeats' median (what the command delay is estimated from), the mean and std of those
    near it, and a line per repeat whose onset lies far from the others' (left out of the mean and std)."""
    odd = part.get("onset_outliers") or []
    median = part.get("onset_median_s", part["onset_mean_s"])  # a check stored before the median was: its mean
    kept = f" of the {len(part['repeats']) - len(odd)} near it" if odd else ""
    # a value that could not be measured is said in words, never printed as "- s" (issue 70)
    std = "" if part["onset_std_s"] is None else f", std {fmt_g(part['onset_std_s'])} s"
    recorded = (
        "  motion onset: none found (no repeat's track leaves its rest)"
        if median is None
        else f"  motion onset {fmt_g(median)} s (median; mean {fmt_g(part['onset_mean_s'])} s{std}{kept})"
    )
    simulated = part["simulated_onset_s"]
    moves = (
        "the generic simulation does not move"
        if simulated is None
        else f"the generic simulation moves at {fmt_g(simulated)} s"
    )
    delay = part["implied_command_delay_s"]
    implied = "no command delay estimated from it" if delay is None else f"command delay about {fmt_g(delay)} s"
    out.print(f"{recorded}; {moves}: {implied}", highlight=False, soft_wrap=True)
    for row in odd:
        out.print(
            f"  left out of the onset's mean and std: {escape(row['file'])} moves at {row['onset_s']:.3f} s, "
            f"{row['from_median_s']:+.3f} s from the median (a glitch the onset is read at, or a recording started "
            f"late; its clock shift onto the others' is {row['shift_s']:+.3f} s): the median and the delay are not "
            "carried by it",
            highlight=False,
            soft_wrap=True,
        )


def _residuals(proposal: dict) -> str:
    """A proposal's residual before -> after: position [mm], and orientation [deg] where it was fitted (with the
    marker's point in the link's frame the rests near place, where the check measured one)."""
    text = f"{1000 * proposal['residual_before_m']:.1f} -> {1000 * proposal['residual_after_m']:.1f} mm"
    if proposal.get("orientation_before_deg") is not None:
        text += f", {proposal['orientation_before_deg']:.1f} -> {proposal['orientation_after_deg']:.1f} deg"
    offset = proposal.get("marker_offset_m")
    at = "" if offset is None else f"; the marker at {'/'.join(f'{1000 * v:.0f}' for v in offset)} mm in the link"
    return f"{text} (kinematics of the wrist's {proposal.get('fit', 'position only')}{at})"


def _far(row: dict, by: str) -> str:
    """`` (far)`` where ``row`` lies far by ``by`` (position or orientation); rows of older checks name none."""
    return " (far)" if by in row.get("far_in", ["position"] if row["far"] else []) else ""


def _print_rest_poses(part: dict) -> None:
    from simtune.check.task import moved_joints  # on use: the check module brings the engines

    orientation = part.get("orientation") or {}
    table = text_table(
        f"{part['task']}: rest poses - where each phase's targets put the marker (generic simulation) against the "
        "recorded wrist over the phase's last second",
        ("stretch", "ends [s]", "simulated [mm]", "recorded [mm]", "apart [mm]", "turned [deg]"),
    )
    for r in part["rest_poses"]:
        table.add_row(
            r["stretch"],
            f"{r['end_s']:g}",
            " ".join(f"{1000 * v:.0f}" for v in r["simulated_m"]),
            " ".join(f"{1000 * v:.0f}" for v in r["recorded_m"]),
            f"{1000 * r['distance_m']:.1f}" + _far(r, "position"),
            "-" if r.get("orientation_deg") is None else f"{r['orientation_deg']:.1f}" + _far(r, "orientation"),
        )
    out.print(table)
    if orientation:
        out.print(f"  {escape(orientation['note'])}", highlight=False, soft_wrap=True)
    for r in part["rest_poses"]:
        _print_out_of_reach(r)
        proposal = r.get("proposal")
        if proposal is None:
            continue
        moved = moved_joints(proposal)
        out.print(
            f"  proposed for {r['stretch']}: {moved or 'no joint change helps'} "
            f"(targets {' '.join(f'{v:g}' for v in proposal['targets_deg'])} deg): {_residuals(proposal)}; "
            "`--write-task FILE` writes the task file with it",
            highlight=False,
            soft_wrap=True,
        )
    _print_start_pose(part.get("start_pose") or {})
    far = [r["stretch"] for r in part["rest_poses"] if r["far"]]
    if far and len(far) < len(part["rest_poses"]):
        out.print(
            f"  note: the real arm rested elsewhere than the targets of {', '.join(far)} put it, while the other rests "
            "agree: check those targets (a tuned calibration moves every pose at once and cannot take this up)",
            highlight=False,
            soft_wrap=True,
        )


def _print_out_of_reach(row: dict) -> None:
    """One warning for a far rest that no joint targets place (JSON ``out_of_reach``): nothing is proposed for it,
    and ``--write-task`` leaves its targets as they are."""
    left = row.get("out_of_reach")
    if not left:
        return
    out.print(
        f"  warning: {row['stretch']}: no joint targets place the recorded rest (the inverse kinematics of the "
        f"wrist's {left['fit']} leave {1000 * left['residual_after_m']:.1f} of its "
        f"{1000 * left['residual_before_m']:.1f} mm): it lies out of the arm's reach - the recordings may be in "
        "another frame or unit than the robot, or the marker on another body; nothing proposed, and --write-task "
        "leaves its targets",
        highlight=False,
        soft_wrap=True,
    )


def _print_start_pose(start: dict) -> None:
    _print_out_of_reach(start)
    if not start.get("proposal"):
        return
    from simtune.check.task import moved_joints  # on use: the check module brings the engines

    proposal = start["proposal"]
    turned = "" if start.get("orientation_deg") is None else f" and turned {start['orientation_deg']:.1f} deg"
    out.print(
        f"  the recorded rest at the start lies {1000 * start['distance_m']:.1f} mm{turned} from the start pose's: "
        f"proposed start_pose_deg {' '.join(f'{v:g}' for v in proposal['targets_deg'])} "
        f"({moved_joints(proposal) or 'no joint change helps'}; {_residuals(proposal)})",
        highlight=False,
        soft_wrap=True,
    )


def print_informed(result: dict) -> None:
    jac = result["jacobian"]
    shown = ", ".join(f"{v:.3g}" for v in jac["singular_values"])
    out.print(
        f"Jacobian at the generic point: rank {jac['rank']} of {jac['searched']} active parameters "
        f"({jac['cutoff']}); singular values: {shown}"
    )
    table = text_table("what the recordings can inform", ("parameter", "informed", "sensitivity", "note"))
    for p in sorted(result["parameters"], key=lambda p: -p["sensitivity"]):
        table.add_row(
            p["name"],
            "yes" if p["informed"] else "no",
            f"{p['sensitivity']:.3g}",
            f"inactive: {p['inactive']}" if "inactive" in p else "",
        )
    out.print(table)


def print_identifiability(section: dict) -> None:
    """The check's identifiability section (``section``: the result's ``identifiability``): each combination of
    parameters the recordings cannot tell apart, its sensitivity and the motion that would separate it."""
    directions = section["directions"]
    where = "the generic point" if section["point"] == "generic" else section["point"]
    if not directions:
        out.print(f"identifiability at {where}: the recordings tell every searched parameter apart", highlight=False)
        return
    out.print(
        f"identifiability at {where}: the recordings cannot tell apart ({section['rule']}):",
        highlight=False,
        soft_wrap=True,
    )
    for d in directions:
        if d["flat"]:
            how = "moves no residual"
        else:
            width = "" if d["interval_share"] is None else f", 95 % interval {d['interval_share']:.2g} x the ranges"
            how = f"relative sensitivity {d['relative_sensitivity']:.2g}{width}"
        out.print(f"  {escape(d['combination'])} ({how})", highlight=False, soft_wrap=True)
        out.print(f"    would separate them: {escape(d['separate_by'])}", highlight=False, soft_wrap=True)
