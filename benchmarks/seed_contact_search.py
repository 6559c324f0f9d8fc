"""Evidence for docs/seed-tasks.md: do the seed tasks' schedules reach their objects, and what fixes them.

    python benchmarks/seed_contact_search.py [--tasks 3,5,7,9] [--limit 30] [--engines mujoco,...]

1. For each pushing schedule as the authors' code gives it (``simtune.tasks.seed.published_task``):
   the generic MuJoCo run's closest approach of any arm or finger box to the object (distance, time, link).
2. The search: offsets (d2, d3) in whole degrees, added to joint_2's and joint_3's target in every
   phase, tried in order of |d2| + |d3| (then |d3|: the shoulder alone first), within +-``limit``.
   The first offset with which the generic run of every engine of ``--verify`` touches the object
   and moves it at least ``MIN_PUSH`` by the time the arm has settled (last phase + 6 s), for the
   plastic object and for its wooden replica, with no arm box below 5 mm above the floor (in
   MuJoCo's run), and with which, over the whole task, every engine's simulation stays stable and
   the object ends within ``MAX_TRAVEL`` of its start, is printed.
3. With ``--engines``: the contact table of every seed task with an object, published and fixed
   schedules, in each engine (the full task duration).
"""

from __future__ import annotations

import dataclasses
import itertools

import mujoco
import numpy as np
from common import make_parser

from simtune.engines import make_engine
from simtune.engines.contact import probe_contact, rollout_samples
from simtune.robot.generate import OBJECT_BODY
from simtune.robot.mico import LINKS, forward_kinematics
from simtune.tasks import TASKS
from simtune.tasks.seed import offset_schedule, published_task
from simtune.tasks.spec import TaskSpec

MIN_PUSH = 0.01  # [m]
MAX_TRAVEL = 1.0  # [m] by the end of the task: a pushed object stays near the arm (a lying cylinder can roll away)
FLOOR_CLEARANCE = 0.005  # [m]
SETTLE = 6.0  # [s] after the last phase starts


def closest_approach(task: TaskSpec) -> tuple[float, float, str]:
    """(distance [m], time [s], link) of the closest approach of the arm to the object in MuJoCo's generic run."""
    engine = make_engine("mujoco", task)
    m, d = engine.model, engine.data  # type: ignore[attr-defined]
    target = m.geom(OBJECT_BODY).id
    arm = [g for g in range(m.ngeom) if engine._arm_body[m.geom_bodyid[g]]]  # type: ignore[attr-defined]
    best = (np.inf, 0.0, "")
    fromto = np.zeros(6)

    def monitor(k: int, pos: np.ndarray, rot: np.ndarray) -> bool:
        nonlocal best
        for g in arm:
            dist = mujoco.mj_geomDistance(m, d, g, target, 0.5, fromto)
            if dist < best[0]:
                best = (float(dist), k * 0.05, m.body(m.geom_bodyid[g]).name)
        return False

    engine.rollout({}, rollout_samples(task.duration), monitor=monitor)
    return best


def lowest_arm_point(angles: np.ndarray) -> float:
    """Height of the lowest corner of any arm box (link_1 onwards) over the joint angle samples [m]."""
    signs = np.array(list(itertools.product((-1, 1), repeat=3)), dtype=float)
    low = np.inf
    for q in angles:
        for link in LINKS[1:]:
            pos, rot = forward_kinematics(q, link.name)
            for box in link.boxes:
                corners = pos + (np.asarray(box.center) + signs * np.asarray(box.half)) @ rot.T
                low = min(low, float(corners[:, 2].min()))
    return low


def pushes(engine_name: str, task: TaskSpec) -> bool:
    """Whether ``engine_name``'s generic run of ``task`` touches the object and moves it at least MIN_PUSH."""
    engine = make_engine(engine_name, task)
    if engine_name == "mujoco":  # a cheap first look: an object that did not move was not pushed
        moved = engine.rollout({}, rollout_samples(task.duration)).object_pos
        assert moved is not None, "a pushing task has an object"
        if np.linalg.norm(moved[-1] - moved[0]) < MIN_PUSH:
            return False
    probe = probe_contact(engine)
    return probe.touched and probe.stable and probe.object_displacement_m >= MIN_PUSH


def stays(engine_name: str, task: TaskSpec) -> bool:
    """Whether ``engine_name``'s generic run of the whole task is stable and leaves the object near its start."""
    rollout = make_engine(engine_name, task).rollout({}, rollout_samples(task.duration))
    assert rollout.object_pos is not None, "a pushing task has an object"
    return rollout.stable and float(np.linalg.norm(rollout.object_pos[-1] - rollout.object_pos[0])) <= MAX_TRAVEL


def search(number: int, limit: int, verify: list[str], min_l1: int = 0) -> tuple[int, int] | None:
    """The first offset with which both materials' tasks are pushed in every engine of ``verify``."""
    settled = []
    for n in (number, number + 1):  # the plastic object, then its heavier wooden replica
        base = published_task(n)
        settled.append(dataclasses.replace(base, duration=min(base.duration, base.phases[-1].start + SETTLE)))
    candidates = sorted(
        (d for d in itertools.product(range(-limit, limit + 1), repeat=2) if abs(d[0]) + abs(d[1]) >= min_l1),
        key=lambda d: (abs(d[0]) + abs(d[1]), abs(d[1]), d),
    )
    for d2, d3 in candidates:
        tasks = [dataclasses.replace(t, phases=offset_schedule(t.phases, d2, d3)) for t in settled]
        if not all(pushes("mujoco", task) for task in tasks):
            continue
        angles = make_engine("mujoco", tasks[0]).rollout({}, rollout_samples(tasks[0].duration)).joint_angles
        if lowest_arm_point(angles[::2]) < FLOOR_CLEARANCE:
            continue
        if not all(pushes(name, task) for name in verify if name != "mujoco" for task in tasks):
            print(f"seed-{number}: offset {d2:+d}, {d3:+d} pushes in MuJoCo, not in all of {', '.join(verify)}")
            continue
        whole = [
            dataclasses.replace(published_task(n), phases=offset_schedule(published_task(n).phases, d2, d3))
            for n in (number, number + 1)
        ]
        if not all(stays(name, task) for name in verify for task in whole):
            print(
                f"seed-{number}: offset {d2:+d}, {d3:+d} pushes, but an object travels past {MAX_TRAVEL:g} m "
                "or a simulation blows up over the whole task"
            )
            continue
        probe = probe_contact(make_engine("mujoco", tasks[0]))
        print(
            f"seed-{number}: offset joint_2 {d2:+d} deg, joint_3 {d3:+d} deg: first contact "
            f"{probe.first_contact_s:.2f} s, object moved {probe.object_displacement_m * 100:.1f} cm by "
            f"{tasks[0].duration:g} s (MuJoCo, plastic)",
            flush=True,
        )
        return d2, d3
    print(f"seed-{number}: no offset within +-{limit} deg")
    return None


def main() -> None:
    ap = make_parser(__doc__, whole_doc=True)
    ap.add_argument("--tasks", default="3,5,7,9", help="odd seed task numbers (each schedule serves n and n+1)")
    ap.add_argument("--limit", type=int, default=30)
    ap.add_argument("--engines", default="", help="also print the contact table in these engines")
    ap.add_argument("--verify", default="mujoco,pybullet,ode,dart,drake", help="engines that must all push")
    ap.add_argument("--no-search", action="store_true")
    ap.add_argument("--min-l1", type=int, default=0, help="skip offsets with |d2| + |d3| below this")
    args = ap.parse_args()
    numbers = [int(n) for n in args.tasks.split(",")]
    for n in numbers:
        dist, time, link = closest_approach(published_task(n))
        print(f"seed-{n} as published: closest approach {dist * 100:.1f} cm at t={time:.2f} s ({link})")
    if not args.no_search:
        for n in numbers:
            search(n, args.limit, args.verify.split(","), args.min_l1)
    if args.engines:
        print("| task | schedule | engine | touched | first contact [s] | object moved [cm] |")
        print("|---|---|---|---|---|---|")
        for n in numbers:
            for number in (n, n + 1):
                for label, task in (("published", published_task(number)), ("fixed", TASKS[f"seed-{number}"])):
                    for engine in args.engines.split(","):
                        p = probe_contact(make_engine(engine, task))
                        when = f"{p.first_contact_s:.2f}" if p.first_contact_s is not None else "-"
                        flag = "" if p.stable else f" ({p.message})"
                        print(
                            f"| seed-{number} | {label} | {engine} | {'yes' if p.touched else 'no'} | {when} | "
                            f"{p.object_displacement_m * 100:.1f}{flag} |",
                            flush=True,
                        )


if __name__ == "__main__":
    main()
