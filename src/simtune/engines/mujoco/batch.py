"""MuJoCo's batch path: a batch's members run in lockstep control periods, the Python between their physics
steps done once for the whole batch with NumPy (issue 33).

Each member has its own copy of the model and data (:meth:`MujocoEngine._thread_copies`), reset with its
parameters as :meth:`~simtune.engines.base.Engine.rollout_steps` resets it.  Then, period after period:

1. one gather of every member's state (its ``qpos``, body poses and warning counters, copied whole into
   batch arrays: a memory copy per array and member), then the 20 Hz sample, the state checks and the
   encoder model as NumPy operations over all members at once;
2. the members whose controller updates later in the period (``command_delay`` not a whole number of
   periods) take their steps up to that instant, and their joints are read there;
3. every member's command (clamped P velocity towards its target) in one NumPy expression, written to
   each member's ``ctrl``;
4. every member's steps of the rest of the period, shared among the threads (``mj_step`` runs without
   the GIL), with the step counts fixed in advance for each member's own time step and phase.

Every member's data sees the same MuJoCo calls, with the same values, in the same order as one rollout
alone (reset, ``mj_step`` runs of the same lengths, ``ctrl`` set between them), and every number the
rollout reports is computed by the same floating-point operations (element-wise NumPy on stacked rows),
so the rollouts equal those of :meth:`~simtune.engines.base.Engine.rollout` bit for bit
(tests/test_batch_vectorised.py).  Where a vectorised form could round differently (the squared reach of
the state check), it only screens: a member near a limit is checked by the same function as alone.

``mujoco.rollout`` (MuJoCo's own multi-threaded batch stepping) does not fit: it runs one step count for
every member of a call, sets each member's state anew at each call (dropping the solver's warm start,
which it cannot hand back, so the next call's results differ in the last bits), and ends a member at
any MuJoCo warning, where one rollout goes on.
"""

from __future__ import annotations

import threading
from collections.abc import Callable, Iterator, Sequence
from concurrent.futures import ThreadPoolExecutor
from typing import TYPE_CHECKING, Any, Protocol

import numpy as np

from simtune.engines.base import CHECK_EVERY, OBJECT_LIMIT, MarkerBudget, Monitor, Rollout, _first_bad, wrist_limit
from simtune.engines.controller import CONTROL_PERIOD, JointController

if TYPE_CHECKING:
    from simtune.tasks import TaskSpec


class Member(Protocol):
    """What a batch reads of each member engine (a MujocoEngine; declared here so that the engine, which runs its
    batches through this module, and this module do not import each other)."""

    task: TaskSpec
    model: Any
    data: Any
    _arm_qpos: Any
    _wrist: Any
    _object: Any

    @property
    def timestep(self) -> float: ...

    def diverged(self) -> str: ...


try:
    import mujoco
except ImportError:  # pragma: no cover - depends on the machine
    mujoco = None

#: A block of samples whose squared reach or flight (computed for all members at once) stays under this
#: share of its limit passes the state check; the rest are checked exactly as one rollout checks them.
SCREEN_MARGIN = 0.999


def period_steps(dts: np.ndarray, phases: np.ndarray, n_samples: int, period: float) -> tuple[np.ndarray, np.ndarray]:
    """Each member's physics steps before and after its controller's update in each control period, two arrays
    (members, n_samples - 1), counted as :meth:`Engine.rollout_steps` counts them for the member's time step
    ``dts[i]`` and update phase ``phases[i]`` (the same float operations, element-wise)."""
    n = len(dts)
    before = np.zeros((n, max(n_samples - 1, 0)), dtype=np.int64)
    after = np.zeros_like(before)
    t_sim = np.zeros(n)
    delayed = phases != 0
    for k in range(n_samples - 1):
        if delayed.any():
            ahead = np.round((k * period + phases - t_sim) / dts).astype(np.int64)
            ahead[~delayed | (ahead <= 0)] = 0
            before[:, k] = ahead
            t_sim = np.where(ahead > 0, t_sim + ahead * dts, t_sim)
        rest = np.maximum(1, np.round(((k + 1) * period - t_sim) / dts).astype(np.int64))
        after[:, k] = rest
        t_sim = t_sim + rest * dts
    return before, after


class Stepper:
    """Runs a round of a batch's members on ``threads`` threads: this one and ``pool``'s.

    The threads take the members one after the other from one shared queue (largest step counts first), so a
    thread the busy host holds back leaves its part to the others; a round ends when its queue is empty and no
    thread is still running a member it took.
    """

    def __init__(self, pool: ThreadPoolExecutor | None, threads: int):
        self.pool = pool
        self.helpers = threads - 1 if pool is not None else 0
        self.order: list[int] = []

    def divide(self, members: np.ndarray, weights: np.ndarray) -> None:
        """The members to run in each round, ``weights`` (their steps) the largest first."""
        self.order = members[np.argsort(-weights[members], kind="stable")].tolist()

    def run(self, work: Callable[[Iterator[int], int], None], k: int) -> None:
        """``work(queue, k)`` on every thread, all taking members from the same ``queue``."""
        queue = iter(self.order)  # next() on it is atomic under the GIL
        running = [threading.Lock() for _ in range(self.helpers)]
        for lock in running:
            self.pool.submit(_helping, lock, work, queue, k)  # type: ignore[union-attr]
        work(queue, k)
        for lock in running:  # a helper that took a member is holding its lock until it is done
            with lock:
                pass


def _helping(lock: threading.Lock, work: Callable[[Iterator[int], int], None], queue: Iterator[int], k: int) -> None:
    with lock:  # a helper that starts after its round ended finds the queue empty
        work(queue, k)


class Batch:
    """The members of one batch of a task (slots 0..n-1), their samples, and the control loop over them."""

    def __init__(
        self,
        engines: Sequence[Member],
        controllers: Sequence[JointController],
        monitors: Sequence[Monitor | None],
        n_samples: int,
    ):
        first = engines[0]
        n, nj = len(engines), first.task.robot.n_joints
        self.engines, self.controllers, self.monitors, self.n_samples = engines, controllers, monitors, n_samples
        self.wrist_limit = wrist_limit(first.task.robot)
        self.period = 1.0 / (1.0 / CONTROL_PERIOD)  # as Engine.rollout computes it from its default rate
        self.times = np.arange(n_samples) * self.period
        # each member's model, data and views into its arrays (valid while the data lives)
        self._members = [(e.model, e.data, e.data.qpos, e.data.xpos, e.data.xmat, e.data.ctrl) for e in engines]
        self._warnings = [e.data.warning.number for e in engines]
        self._bad_qacc = int(mujoco.mjtWarning.mjWARN_BADQACC)
        # the state gathered at each sample, the joints at each controller update, each member's command
        self.qpos = np.zeros((n, first.model.nq))
        self.xpos = np.zeros((n, first.model.nbody, 3))
        self.xmat = np.zeros((n, first.model.nbody, 9))
        self.warned = np.zeros(n, dtype=bool)
        self.qpos_update = np.zeros((n, first.model.nq))
        self.ctrl = np.zeros((n, nj))
        self.arm, self.wrist, self.obj = first._arm_qpos, first._wrist, first._object
        self.wrist_pos = np.zeros((n, n_samples, 3))
        self.wrist_rot = np.tile(np.eye(3), (n, n_samples, 1, 1))
        self.angles = np.zeros((n, n_samples, nj))
        self.object_pos = np.zeros((n, n_samples, 3)) if self.obj is not None else None
        phases = np.array([c.phase for c in controllers], dtype=float)
        self.before, self.after = period_steps(
            np.array([e.timestep for e in engines], dtype=float), phases, n_samples, self.period
        )
        # the same counts as lists of periods of Python ints, which the stepping threads read per member
        self._before, self._after = self.before.T.tolist() + [[0] * n], [[0] * n] + self.after.T.tolist()
        self.targets = np.stack([c.targets(self.times + c.phase) for c in controllers])  # at each update instant
        self.v_max = np.stack([c.v_max for c in controllers])
        self.kp = np.stack([c.kp for c in controllers])  # each member's gains (kp_joint_<n>)
        self.calibrated = np.array([c.calibrated for c in controllers], dtype=bool)
        self.failed: dict[int, Exception] = {}  # member -> the error its simulation raised

    # --- a round: what each thread does for its share of the members -------------------------------------------
    def advance(self, share: Iterator[int], k: int) -> None:
        """Bring the members of ``share`` to sample ``k`` and on to their controller's update in period ``k``:
        the command of period k - 1 into ``ctrl``, the rest of that period's steps, the state gathered (the
        sample), the steps to the update, the joints gathered there.  The calls one rollout makes, in its order
        (``mj_step`` releases the GIL: the other threads step meanwhile)."""
        after, before, bad_qacc = self._after[k], self._before[k], self._bad_qacc
        for i in share:
            model, data, qpos, xpos, xmat, ctrl = self._members[i]
            try:
                if after[i]:
                    ctrl[:] = self.ctrl[i]
                    mujoco.mj_step(model, data, nstep=after[i])
                self.qpos[i] = qpos
                self.xpos[i] = xpos
                self.xmat[i] = xmat
                self.warned[i] = self._warnings[i][bad_qacc] > 0
                if before[i]:
                    mujoco.mj_step(model, data, nstep=before[i])
                    self.qpos_update[i] = qpos
            except Exception as exc:  # MuJoCo's error in this member's simulation is this member's, as alone
                self.failed[i] = exc

    # --- the whole batch at once, with NumPy ---------------------------------------------------------------------
    def encoders(self, qpos: np.ndarray, members: np.ndarray) -> np.ndarray:
        """What the members' encoders read [rad], (members, joints), from their rows of ``qpos``."""
        q = qpos[members][:, self.arm]
        for row in np.flatnonzero(self.calibrated[members]):
            q[row] = self.controllers[members[row]].encoder(q[row])
        return q

    def sample(self, members: np.ndarray, k: int) -> np.ndarray:
        """Record sample ``k`` of the members from the gathered state; their encoder readings."""
        q = self.encoders(self.qpos, members)
        self.angles[members, k] = q
        self.wrist_pos[members, k] = self.xpos[members, self.wrist]
        self.wrist_rot[members, k] = self.xmat[members, self.wrist].reshape(-1, 3, 3)
        if self.object_pos is not None:
            self.object_pos[members, k] = self.xpos[members, self.obj]
        return q

    def command(self, members: np.ndarray, k: int, q: np.ndarray) -> None:
        """Every member's velocity command of period ``k`` from its encoder reading ``q`` at the update, into
        ``self.ctrl`` (:meth:`JointController.velocity`'s operations, on one row per member)."""
        moved = self.before[members, k] > 0
        if moved.any():  # read at the update instant, later in the period
            q[moved] = self.encoders(self.qpos_update, members[moved])
        velocity = np.multiply(self.targets[members, k] - q, self.kp[members])
        v_max = self.v_max[members]
        self.ctrl[members] = np.minimum(np.maximum(velocity, -v_max, out=velocity), v_max, out=velocity)

    # --- the state checks ------------------------------------------------------------------------------------
    def first_bad(self, members: np.ndarray, start: int, k: int) -> dict[int, tuple[int, str]]:
        """The members whose samples ``start..k`` hold a broken state: member -> (index in the block, why),
        as :func:`_first_bad` finds them for each member alone."""
        block = slice(start, k + 1)
        pos, rot, q = self.wrist_pos[members, block], self.wrist_rot[members, block], self.angles[members, block]
        with np.errstate(invalid="ignore", over="ignore"):
            doubt = ~(np.isfinite(pos).all(axis=(1, 2)) & np.isfinite(rot).all(axis=(1, 2, 3)))
            doubt |= ~np.isfinite(q).all(axis=(1, 2))
            doubt |= ~(np.einsum("mbj,mbj->mb", pos, pos) <= SCREEN_MARGIN * self.wrist_limit**2).all(axis=1)
            if self.object_pos is not None:
                moved = self.object_pos[members, block] - self.object_pos[members, :1]
                doubt |= ~(np.einsum("mbj,mbj->mb", moved, moved) <= SCREEN_MARGIN * OBJECT_LIMIT**2).all(axis=1)
        found = {}
        for row in np.flatnonzero(doubt):
            i = members[row]
            obj, obj_start = (
                (None, None) if self.object_pos is None else (self.object_pos[i, block], self.object_pos[i, 0])
            )
            bad, why = _first_bad(
                self.wrist_pos[i, block],
                self.wrist_rot[i, block],
                self.angles[i, block],
                obj,
                obj_start,
                self.wrist_limit,
            )
            if bad is not None:
                found[int(i)] = (bad, why)
        return found

    def rollout(
        self, i: int, k: int, samples_run: int, stable: bool = True, message: str = "", pruned: bool = False
    ) -> Rollout:
        """Member ``i``'s rollout, ended at sample ``k`` with ``samples_run`` samples simulated."""
        pos, rot, angles = self.wrist_pos[i].copy(), self.wrist_rot[i].copy(), self.angles[i].copy()
        obj = self.object_pos[i].copy() if self.object_pos is not None else None
        if 0 < samples_run < self.n_samples:  # ended early: hold the last good sample for the rest
            for values in (pos, rot, angles, *([obj] if obj is not None else [])):
                values[samples_run:] = values[samples_run - 1]
        steps = int(self.before[i, :k].sum() + self.after[i, :k].sum())
        return Rollout(self.times.copy(), pos, rot, angles, obj, stable, message, steps, samples_run, pruned)

    def unstable(self, members: np.ndarray, k: int, checked: int) -> dict[int, tuple[int, str]]:
        """The members whose rollout ends unstable at sample ``k``: member -> (samples run, message), as
        :meth:`Engine.rollout_steps` checks (``checked``: the samples before it passed the checks)."""
        if not (k == self.n_samples - 1 or k - checked >= CHECK_EVERY - 1):
            members = members[self.warned[members]]  # between scheduled checks: only members MuJoCo warned of
        if not len(members):
            return {}
        found = self.first_bad(members, checked, k)
        for i in members[self.warned[members]]:
            if int(i) not in found:
                found[int(i)] = (k - checked, self.engines[i].diverged())
        return {
            i: (checked + bad, f"unstable at t={self.times[checked + bad]:.2f} s: {why}")
            for i, (bad, why) in found.items()
        }

    def ends(self, alive: np.ndarray, k: int, checked: int, ended: dict[int, Rollout | Exception]) -> None:
        """Add to ``ended`` the members whose rollout ends at sample ``k``: unstable, the last sample, or stopped
        by their monitor (``checked``: the samples before passed the checks)."""
        for i, (run, why) in self.unstable(alive, k, checked).items():
            ended.setdefault(i, self.rollout(i, k, run, False, why))
        going = [i for i in alive.tolist() if i not in ended]
        if k == self.n_samples - 1:
            for i in going:
                ended[i] = self.rollout(i, k, k + 1)
            return
        budgets = [i for i in going if isinstance(self.monitors[i], MarkerBudget)]
        if len({id(self.monitors[i].targets) for i in budgets}) > 1:
            budgets = []  # not one task's: each watched alone
        if budgets:  # one NumPy computation for all (the same sums as alone, MarkerBudget.watch_all)
            stop = MarkerBudget.watch_all(
                [self.monitors[i] for i in budgets], k, self.wrist_pos[budgets, k], self.wrist_rot[budgets, k]
            )
            for i in np.asarray(budgets)[stop].tolist():
                ended[i] = self.rollout(i, k, k + 1, pruned=True)
        watched = set(budgets)
        for i in going:
            if i in watched or (monitor := self.monitors[i]) is None:
                continue
            try:
                if monitor(k, self.wrist_pos[i, k], self.wrist_rot[i, k]):
                    ended[i] = self.rollout(i, k, k + 1, pruned=True)
            except Exception as exc:  # as alone: the member's rollout raised
                ended[i] = exc

    def run(self, stepper: Stepper) -> Iterator[tuple[int, Rollout | Exception]]:
        """Every member's rollout (slot, rollout), or the error its simulation raised, yielded as each ends (in
        slot order within a period).

        One round per control period: the threads bring every member to its sample and its update
        (:meth:`advance`), then this thread samples, checks and commands all of them.  A member that ends at
        a sample has taken its steps to that period's update too, which changes none of its results."""
        alive = np.arange(len(self.engines))
        weights = (self.before.sum(axis=1) + self.after.sum(axis=1)).astype(float)
        stepper.divide(alive, weights)
        checked = 0
        for k in range(self.n_samples):
            stepper.run(self.advance, k)
            q = self.sample(alive, k)
            ended: dict[int, Rollout | Exception] = {i: self.failed.pop(i) for i in list(self.failed)}
            self.ends(alive, k, checked, ended)
            if k == self.n_samples - 1 or k - checked >= CHECK_EVERY - 1:
                checked = k + 1
            for i in sorted(ended):
                yield i, ended[i]
            if ended:
                keep = ~np.isin(alive, list(ended))
                alive, q = alive[keep], q[keep]
                if not len(alive):
                    return
                stepper.divide(alive, weights)
            self.command(alive, k, q)
