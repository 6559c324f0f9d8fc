"""Drive-train recovery: armature, Coulomb friction, controller gain and servo gain of every driven joint, from
synthetic recordings of the SO-101 and the Franka Panda of the robot corpus, in each engine that has the kinds.

Everything goes through the command line, as a user would run it:

1. ``simtune init --robot <URDF> --out P`` (the corpus robot's URDF, used in place), and a task ``drive``
   added to P: every driven joint steps between poses around the example's start pose, each joint on its
   own schedule, with a velocity clamp fast enough that the servos reach their force limits at every step.
   The example ``reach`` (+20 deg and back at 30 deg/s) cannot identify armature: its velocity changes are
   too small for the reflected inertia to show against 0.05 deg of encoder noise; ``drive``'s steps start
   and stop at up to ``MAX_VELOCITY_DEG`` (the robot's own speed class), where the servo's force limit
   makes each joint's acceleration its torque over its inertia (armature included).  A phase whose steps drive
   the hand into the floor (MuJoCo's floor-contact probe, with the generic parameters and with the truth) is
   mirrored, then halved, until the arm stays clear: a task without an object is tuned as if it never touched.
2. Per engine: the truth (``truth()``: each joint's armature and Coulomb friction at chosen shares of their
   ranges, its ``kp``, and its servo gain at a fraction of the drive task's generic one; only the kinds that engine
   has) is synthesised by that engine: ``simtune synth
   --format csv`` (markers and joint angles), 2 mm marker noise, 0.05 deg encoder noise, +-0.05 s start
   jitter, 10 repeats.
3. ``simtune tune --only <the truth's parameters> --max-seconds S`` (optimizer auto) in the same engine;
   the 95 % intervals are the run's Gauss-Newton uncertainty (``simtune uncertainty`` where the run left it
   out for its time budget), or with ``--bootstrap N`` ``simtune uncertainty --bootstrap N``'s (refits against
   N draws of the repeats where the simulation is not smooth).
4. Per parameter: truth, estimate, error as % of its range, the 95 % interval, and whether it holds the
   truth.  Done-when: every error within 5 % and the truth inside at least 80 % of the intervals.
5. Per joint whose armature, friction and servo gain are all tuned (MuJoCo): the truth's fitness with the three
   scaled together by 0.8 and 1.25 (:func:`scale_symmetry`); a joint whose scaled truth fits as well as the truth
   cannot have them told apart by any estimator, and the done-when is also counted without such joints.

    python benchmarks/drivetrain_recovery.py [--robots so101,panda] [--engines mujoco,pybullet,ode,dart,drake]
        [--max-seconds 150] [--delay-s 0.4] [--jitter-s 0.05] [--bootstrap 30] [--kinds K1,K2] [--servo-scale 1]
        [--out DIR]
        [--results benchmarks/results]

``--delay-s 0`` holds the command delay at 0 (the truth's) instead of tuning it with the drive train.

Writes ``drivetrain-recovery-<date>.md`` (the tables) and ``.json`` to --results; prints the tables.
"""

from __future__ import annotations

import json
import sys
import tempfile
import time
from pathlib import Path

from common import (
    add_engines_option,
    add_results_option,
    last_json,
    make_parser,
    simtune,
    write_json_result,
    write_result,
)

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
from robot_corpus import CORPUS

ROBOTS = {"so101": "SO-101", "panda": "Franka Panda"}
KINDS = ("armature_joint", "friction_joint", "kp_joint", "servo_gain_joint")
#: the velocity clamp of the drive task [deg/s]: an STS3215 hobby servo turns about 200 deg/s unloaded, a
#: Panda's joints 150-180 deg/s
MAX_VELOCITY_DEG = {"so101": 180.0, "panda": 120.0}
#: each joint's offsets from the start pose [deg], phase by phase (joint i takes the pattern rotated by i)
PATTERN = (35.0, -15.0, 25.0, -30.0, 10.0, 0.0)
PHASE_S = 1.0
#: the arm rests at its start pose this long before the first step [s] (so each recording's motion onset, which
#: aligns the repeats' clocks, can be seen)
REST_S = 0.5
#: mirrorings and halvings of the phases that touch the floor before giving up
FLOOR_TRIES = 8
#: the truth, as shares of each range (armature, friction), as gains (kp) and as multiples of the servo's generic gain
#: for the drive task (a softer servo: a stiffer one than the task's generic gain would clip on a light link at the
#: drive's command steps), cycled over the joints
ARMATURE_SHARE = (0.4, 0.6, 0.3, 0.5, 0.7, 0.35, 0.45)
FRICTION_SHARE = (0.25, 0.15, 0.35, 0.2, 0.3, 0.1, 0.4)
SERVO_GAIN_FACTOR = (0.6, 0.4, 0.8, 0.5, 0.7, 0.45, 0.65)
KP = (6.0, 14.0, 9.0, 18.0, 12.0, 7.0, 16.0)
#: the true command delay [s], tuned with the drive train: every repeat's start is jittered about it and the
#: aligned reference sits on the repeats' median clock, so a delay held at the truth would leave the median
#: jitter (up to tens of ms) to be absorbed by the gains and the armature (0.4: its remainder by the 20 Hz
#: control period is exactly 0 in floating point)
DELAY_S = 0.4
NOISE_MM = 2.0
JOINT_NOISE_DEG = 0.05
JITTER_S = 0.05
REPEATS = 10
WITHIN = 5.0  # [% of the range]
#: each joint's armature, friction and servo gain scaled together by these, to test their scale symmetry
SYMMETRY_SCALES = (0.8, 1.25)
#: a fitness change [%] under which a joint's scaled truth counts as fitting as well as the truth
SYMMETRIC = 0.5
COVERAGE = 0.8


def drive_task(
    joints: list[str], start: list[float], limits: list[tuple[float, float]], robot: str, scales: list[float]
) -> str:
    """The ``drive`` task file: each joint steps through :data:`PATTERN` (rotated by its index) around ``start``,
    each phase's offsets times its entry of ``scales``, kept 5 deg inside the joints' limits."""
    phases = [f"[[phases]]\nstart = 0.0\ntargets_deg = {json.dumps(start)}\n"]
    for k in range(len(PATTERN)):
        targets = []
        for i, (s, (lo, hi)) in enumerate(zip(start, limits, strict=True)):
            offset = PATTERN[(k + i) % len(PATTERN)] * (1.0 if i % 2 == 0 else -1.0) * scales[k]
            targets.append(round(min(max(s + offset, lo + 5.0), hi - 5.0), 2))
        phases.append(f"[[phases]]\nstart = {REST_S + k * PHASE_S:g}\ntargets_deg = {json.dumps(targets)}\n")
    return (
        'name = "drive"\n'
        'description = "every driven joint steps fast between poses, each on its own schedule"\n'
        f"duration = {REST_S + len(PATTERN) * PHASE_S + 0.5:g}\n"
        f"joints = {json.dumps(joints)}\n"
        f"start_pose_deg = {json.dumps(start)}\n\n"
        '[controller]\nlaw = "clamped-p-velocity"\ngain = 10.0\n'
        f"max_velocity_deg = {MAX_VELOCITY_DEG[robot]:g}\n\n"
        '[mocap]\nlink = "{link}"\nbody = "hand"\n\n' + "\n".join(phases)
    )


def make_project(folder: Path, robot: str, servo_scale: float = 1.0) -> Path:
    from simtune.project import load_project

    (entry,) = [r for r in CORPUS if r.name == ROBOTS[robot]]
    if entry.path is None:
        sys.exit(f"{entry.name}: its package {entry.package} is not installed")
    project = folder / robot
    simtune("init", "--robot", entry.path, "--out", project)
    reach = load_project(project).task("reach")
    description = reach.robot
    joints = list(description.arm_joints)
    limits = []
    for name in joints:
        joint = description.joint_by_name[name]
        lo = -180.0 if joint.lower is None else float(joint.lower) * 57.29577951308232
        hi = 180.0 if joint.upper is None else float(joint.upper) * 57.29577951308232
        limits.append((lo, hi))
    start = [round(float(v), 2) for v in reach.start_pose_deg]
    file = project / "simtune.toml"
    file.write_text(
        file.read_text().replace('tasks = ["tasks/reach.toml"]', 'tasks = ["tasks/reach.toml", "tasks/drive.toml"]')
    )
    # a phase whose steps drive the hand into the floor is mirrored, then halved, until the arm stays clear of it
    # with the generic parameters and with MuJoCo's truth: a touch makes the fitness jump
    # wherever a parameter moves it by one physics step (docs/parameters.md)
    scales = [1.0] * len(PATTERN)
    for _ in range(FLOOR_TRIES):
        text = drive_task(joints, start, limits, robot, scales).replace("{link}", description.tracked_link)
        (project / "tasks" / "drive.toml").write_text(text)
        true = truth(ranges(project, "mujoco"), task_servo_gains(project), servo_scale)
        touched = phases_touching_floor(project, {}) | phases_touching_floor(project, true)
        if not touched:
            return project
        for k in touched:
            scales[k] = -scales[k] if scales[k] > 0 else -scales[k] / 2
        print(f"{robot}: the drive task's phase(s) {sorted(touched)} touch the floor; scales now {scales}", flush=True)
    sys.exit(f"{robot}: the drive task still touches the floor after {FLOOR_TRIES} tries")


def phases_touching_floor(project: Path, params: dict[str, float]) -> set[int]:
    """The phases of :data:`PATTERN` (0-based) during which the arm touches the floor in MuJoCo with ``params``."""
    from simtune.engines import make_engine
    from simtune.engines.contact import floor_touches
    from simtune.project import load_project

    task = load_project(project).task("drive")
    engine = make_engine("mujoco", task)
    try:
        spans = floor_touches(engine, params)
    finally:
        engine.close()
    # a touch that goes on after a phase's end belongs to the phase that drove the hand down
    return {min(max(int((t0 - REST_S) // PHASE_S), 0), len(PATTERN) - 1) for t0, _ in spans}


def ranges(project: Path, engine: str, kinds: tuple[str, ...] = KINDS) -> dict[str, tuple[float, float]]:
    """The parameters of ``kinds`` that ``engine`` has for the project's robot, with their ranges."""
    from simtune.engines import engine_class
    from simtune.params import get_space
    from simtune.project import load_project

    robot = load_project(project).task("drive").robot
    space = get_space("extended", engine_class(engine).supported(robot), robot=robot)
    return {p.name: (p.low, p.high) for p in space.parameters if p.name.rsplit("_", 1)[0] in kinds}


def task_servo_gains(project: Path) -> tuple[float, ...]:
    """MuJoCo's generic servo gain of each driven joint for the drive task (set for its command steps)."""
    from simtune.project import load_project
    from simtune.robot.generate import command_step, servo_gains

    task = load_project(project).task("drive")
    return servo_gains(task.robot, command_step(task.max_velocity_deg))


def truth(
    bounds: dict[str, tuple[float, float]], servo: tuple[float, ...] = (), servo_scale: float = 1.0
) -> dict[str, float]:
    out = {}
    for name, (lo, hi) in bounds.items():
        kind, index = name.rsplit("_", 1)
        i = int(index) - 1
        if kind == "kp_joint":
            out[name] = KP[i % len(KP)]
        elif kind == "servo_gain_joint":
            gain = servo_scale * SERVO_GAIN_FACTOR[i % len(SERVO_GAIN_FACTOR)] * servo[i]
            out[name] = round(min(max(gain, lo), hi), 6)
        else:
            share = (ARMATURE_SHARE if kind == "armature_joint" else FRICTION_SHARE)[i % len(ARMATURE_SHARE)]
            out[name] = round(lo + share * (hi - lo), 6)
    return out


def intervals(run: Path, bootstrap: int = 0) -> dict[str, dict]:
    """The run's 95 % intervals by parameter (computed by ``simtune uncertainty`` where the run left them out, or
    with ``bootstrap`` draws of the repeats)."""
    from simtune.store import RunStore

    store = RunStore(run)
    try:
        stored = store.get("uncertainty") or {}
    finally:
        store.close()
    if not stored.get("parameters") or bootstrap:
        stored = last_json(simtune("uncertainty", run, "--json", "--workers", 2, "--bootstrap", bootstrap))
    return {e["name"]: e for e in stored.get("parameters", [])}


def recover(
    project: Path,
    work: Path,
    engine: str,
    max_seconds: float,
    jitter_s: float = JITTER_S,
    delay_s: float = DELAY_S,
    bootstrap: int = 0,
    kinds: tuple[str, ...] = KINDS,
    servo_scale: float = 1.0,
) -> dict:
    """Synthesise the truth in ``engine``, tune it back, and compare per parameter (the command delay tuned with
    the drive train unless ``delay_s`` is 0: then it is held at 0, the truth's); the kinds left out of ``kinds``
    stay at their generic values in the truth and in the tune."""
    bounds = ranges(project, engine, kinds)
    true = truth(bounds, task_servo_gains(project), servo_scale)
    truth_file = work / f"truth-{engine}.json"
    truth_file.write_text(json.dumps({"command_delay": delay_s, **true}))
    data = work / f"recordings-{engine}"
    simtune("synth", "--project", project, "--engine", engine, "--task", "drive", "--truth", truth_file,
            "--format", "csv", "--noise-mm", NOISE_MM, "--joint-noise-deg", JOINT_NOISE_DEG, "--jitter-s", jitter_s,
            "--repeats", REPEATS, "--delay-s", delay_s, "--out", data)  # fmt: skip
    generic = drive_fitness(project, engine, data)
    floor = drive_fitness(project, engine, data, truth_file)
    symmetric = scale_symmetry(project, engine, data, {"command_delay": delay_s, **true}, bounds, work, floor)
    run = work / f"tune-{engine}"
    only = ",".join(["command_delay", *true] if delay_s > 0 else true)
    started = time.monotonic()
    simtune("tune", "--project", project, "--engine", engine, "--task", "drive", "--data", data,
            "--only", only, "--max-seconds", max_seconds, "--out", run, "--quiet", "--json")  # fmt: skip
    wall = time.monotonic() - started
    best = json.loads((run / "best_params.json").read_text())
    values = best.get("params", best)
    found = intervals(run, bootstrap)
    rows = []
    for name, value in true.items():
        lo, hi = bounds[name]
        entry = found.get(name, {})
        low, high = entry.get("low"), entry.get("high")
        rows.append(
            {
                "name": name,
                "truth": value,
                "estimate": float(values[name]),
                "error_pct": 100.0 * abs(float(values[name]) - value) / (hi - lo),
                "low": low,
                "high": high,
                "holds": low is not None and high is not None and low <= value <= high,
                "range": [lo, hi],
            }
        )
    tuned = float(best.get("fitness", float("nan"))) if isinstance(best, dict) else float("nan")
    delay = {"truth": delay_s, "estimate": float(values.get("command_delay", 0.0)), **found.get("command_delay", {})}
    return {"engine": engine, "wall_s": round(wall, 1), "generic": generic, "floor": floor, "tuned": tuned,
            "rows": rows, "delay": delay, "scale_symmetry": symmetric}  # fmt: skip


def drive_fitness(project: Path, engine: str, data: Path, params_file: Path | None = None) -> float:
    """``simtune evaluate``'s fitness of the drive task on ``data``: generic, or with ``params_file``."""
    chosen = ("--params-file", params_file) if params_file is not None else ()
    return last_json(simtune("evaluate", "--project", project, "--engine", engine, "--task", "drive",
                             "--data", data, *chosen, "--json"))["fitness"]  # fmt: skip


def scale_symmetry(
    project: Path,
    engine: str,
    data: Path,
    true: dict[str, float],
    bounds: dict[str, tuple[float, float]],
    work: Path,
    floor: float,
) -> dict[str, list[float | None]]:
    """Per joint whose armature, Coulomb friction and servo gain are all tuned: the truth's (``true``, its command
    delay included) fitness change [%] with the three scaled together by each of :data:`SYMMETRY_SCALES`.

    Below its force limit a velocity servo moves its joint by (link inertia + armature) / gain and friction / gain
    alone, so where the link's own inertia is small and gravity does not load the joint (a wrist roll) the scaled
    truth fits as well as the truth: no recording of such motion can tell the three apart, and an unbounded interval
    is the right answer.  None where a scaled value leaves its range (a truth at the edge of it)."""
    out: dict[str, list[float | None]] = {}
    joints = sorted({name.rsplit("_", 1)[1] for name in true if name.startswith("servo_gain_joint_")}, key=int)
    for j in joints:
        names = [f"{kind}_{j}" for kind in ("armature_joint", "friction_joint", "servo_gain_joint")]
        if any(name not in true for name in names):
            continue
        changes: list[float | None] = []
        for scale in SYMMETRY_SCALES:
            values = {name: true[name] * scale for name in names}
            if any(not bounds[name][0] <= value <= bounds[name][1] for name, value in values.items()):
                changes.append(None)
                continue
            scaled = work / f"symmetry-{engine}-{j}-{scale:g}.json"
            scaled.write_text(json.dumps({**true, **values}))
            changes.append(round(100.0 * (drive_fitness(project, engine, data, scaled) / floor - 1.0), 3))
        out[j] = changes
    return out


def _change(change: float | None) -> str:
    return "out of range" if change is None else f"{change:+.2f} %"


def table(robot: str, result: dict) -> list[str]:
    rows = result["rows"]
    within = sum(r["error_pct"] <= WITHIN for r in rows)
    holds = sum(r["holds"] for r in rows)
    lines = [
        f"### {ROBOTS[robot]}, {result['engine']}: tune {result['wall_s']:g} s; fitness generic "
        f"{result['generic']:.5f}, truth (noise floor) {result['floor']:.5f}, tuned {result['tuned']:.5f}",
        "",
        f"{within}/{len(rows)} within {WITHIN:g} % of the range; the truth inside {holds}/{len(rows)} intervals "
        f"({'meets' if within == len(rows) and holds >= COVERAGE * len(rows) else 'misses'} the done-when); "
        f"command delay {result['delay']['estimate']:.4f} s (truth {result['delay']['truth']:g} s + the repeats' "
        "median start jitter)",
        "",
        "| parameter | range | truth | estimate | error [% of range] | 95 % interval | holds the truth |",
        "|---|---|---|---|---|---|---|",
    ]
    for r in rows:
        interval = "unbounded" if r["low"] is None else f"[{r['low']:.4g}, {r['high']:.4g}]"
        lo, hi = r["range"]
        lines.append(
            f"| `{r['name']}` | [{lo:.4g}, {hi:.4g}] | {r['truth']:.4g} | {r['estimate']:.4g} | {r['error_pct']:.2f} "
            f"| {interval} | {'yes' if r['holds'] else 'no'} |"
        )
    if symmetric := result.get("scale_symmetry"):
        blind = [j for j, changes in symmetric.items() if all(c is not None and abs(c) < SYMMETRIC for c in changes)]
        scales = " / ".join(f"x{scale:g}" for scale in SYMMETRY_SCALES)
        lines += [
            "",
            f"Scale symmetry: the truth's fitness change with a joint's armature, friction and servo gain scaled "
            f"together ({scales}): "
            + "; ".join(f"joint {j} " + " / ".join(map(_change, changes)) for j, changes in symmetric.items()),
        ]
        if blind:
            kept = [r for r in rows if r["name"].rsplit("_", 1)[1] not in blind or r["name"].startswith("kp_joint")]
            lines += [
                "",
                f"Joint(s) {', '.join(blind)}: within {SYMMETRIC:g} % at both scales, so no estimator can tell their "
                f"armature, friction and servo gain apart from these recordings; without them "
                f"{sum(r['error_pct'] <= WITHIN for r in kept)}/{len(kept)} within {WITHIN:g} %, the truth inside "
                f"{sum(r['holds'] for r in kept)}/{len(kept)} intervals",
            ]
    return lines


def main() -> None:
    parser = make_parser(__doc__)
    parser.add_argument("--robots", default="so101,panda", help="so101, panda, joined by commas")
    add_engines_option(parser, "mujoco,pybullet,ode,dart,drake")
    parser.add_argument("--max-seconds", type=float, default=150.0, help="time budget of each tune [s]")
    parser.add_argument("--out", type=Path, help="working folder (default: a temporary one)")
    parser.add_argument("--jitter-s", type=float, default=JITTER_S, help="synth's start jitter [s]")
    parser.add_argument("--delay-s", type=float, default=DELAY_S, help="the true command delay [s]; 0: held, not tuned")
    parser.add_argument(
        "--servo-scale",
        type=float,
        default=1.0,
        help="the true servo gains times this (1: 0.4-0.8 x the drive task's generic gain)",
    )
    parser.add_argument("--bootstrap", type=int, default=0, help="draws of the repeats for the intervals (0: none)")
    parser.add_argument(
        "--kinds", default=",".join(KINDS), help=f"kinds set and tuned, joined by commas (default: {','.join(KINDS)})"
    )
    add_results_option(parser)
    args = parser.parse_args()
    kinds = tuple(args.kinds.split(","))
    if unknown := set(kinds) - set(KINDS):
        parser.error(f"--kinds: unknown {', '.join(sorted(unknown))}; the kinds are {', '.join(KINDS)}")
    results: dict = {}
    lines: list[str] = []
    with tempfile.TemporaryDirectory() as tmp:
        work = args.out or Path(tmp)
        for robot in args.robots.split(","):
            folder = work / robot
            folder.mkdir(parents=True, exist_ok=True)
            project = make_project(folder, robot, args.servo_scale)
            for engine in args.engines.split(","):
                started = time.monotonic()
                result = recover(
                    project,
                    folder,
                    engine,
                    args.max_seconds,
                    args.jitter_s,
                    args.delay_s,
                    args.bootstrap,
                    kinds,
                    args.servo_scale,
                )
                result["total_s"] = round(time.monotonic() - started, 1)
                results.setdefault(robot, []).append(result)
                lines += [*table(robot, result), ""]
                print("\n".join(table(robot, result)) + "\n", flush=True)
    header = (
        f"Drive-train recovery: synthetic `drive` recordings (csv: marker and joint angles; {NOISE_MM:g} mm, "
        f"{JOINT_NOISE_DEG:g} deg, +-{args.jitter_s:g} s start jitter, {REPEATS} repeats), each engine tuned on its "
        f"own with --max-seconds {args.max_seconds:g}, optimizer auto; true command delay {args.delay_s:g} s "
        f"({'tuned with the drive train' if args.delay_s > 0 else 'held'}); intervals "
        f"{f'with {args.bootstrap} bootstrap draws' if args.bootstrap else 'Gauss-Newton'}; kinds {', '.join(kinds)}; "
        f"true servo gains {args.servo_scale:g} x (0.4-0.8 x the drive task's generic gain); the drive task clear of "
        "the floor\n"
    )
    write_result(args.results, "drivetrain-recovery", "md", header + "\n" + "\n".join(lines))
    write_json_result(args.results, "drivetrain-recovery", results)


if __name__ == "__main__":
    main()
