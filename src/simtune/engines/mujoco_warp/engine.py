"""MuJoCo Warp (MJWarp: MuJoCo's solver as NVIDIA Warp kernels) behind the engine interface.

A whole population runs as one batch: one MJWarp *world* per member, all stepped by the same kernel
launches, on a CUDA GPU when Warp finds one and on Warp's CPU device otherwise.

- The scene and the parameter mapping are the MuJoCo engine's, used as they are: each member's parameters
  are applied to a host MuJoCo model by :meth:`MujocoEngine.reset` (which also re-derives the constants
  MuJoCo computes from the masses), and the model fields that differ between members become per-world
  arrays of one MJWarp model (``put_model(batch_sizes=...)``), the time step included.
- The 20 Hz controller runs inside the batch (a Warp kernel over worlds and joints), and so does the
  sampling: samples accumulate in device arrays that are copied back once per batch.
- Time steps differ per world, so worlds take different numbers of physics steps per control period.
  Each world's step counts are fixed in advance, exactly as :meth:`Engine.rollout` counts them; the batch
  steps as often as its busiest world, and a world that has taken its steps waits with a time step of
  zero, which leaves its state as it is.  On Warp's CPU device, where a waiting world costs as much as
  a moving one, the population runs as a few batches of similar time steps instead (time_step_groups).
- Monitors (early stopping) see the samples after the batch, in the order :meth:`Engine.rollout` shows
  them, so a member's rollout is the one it would have alone; they save no simulation here.

Differences from the MuJoCo engine, all in the solver's arithmetic: MJWarp computes in 32-bit floats and
stops its solver at a tolerance of at least 1e-6 (MuJoCo: 64-bit, 1e-8).  tests/test_engine_batch_gpu.py
measures what this does to the wrist's trajectory.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator, Sequence
from functools import cache
from itertools import pairwise

import numpy as np

from simtune.engines.base import CHECK_EVERY, Engine, Monitor, Rollout, _first_bad, wrist_limit
from simtune.engines.controller import CONTROL_PERIOD, JointController
from simtune.engines.mujoco.engine import MujocoEngine, mujoco
from simtune.params.kinds import engine_parameters as kinds_of_engine
from simtune.robot.generate import OBJECT_BODY
from simtune.tasks.spec import TaskSpec

try:
    import warp as wp

    wp.config.log_level = wp.LOG_WARNING  # Warp's banner and kernel-build lines would go to stdout (--json owns it)
    import mujoco_warp as mjw
except ImportError:  # pragma: no cover - depends on the machine
    wp = None
    mjw = None

#: Contacts and constraint rows each world has room for: the cube on the floor and the hand on both,
#: with room to spare (a world that runs out is reported unstable, never simulated without its contacts).
CONTACTS_PER_WORLD = 64
CONSTRAINTS_PER_WORLD = 384


@cache
def _kernels():
    """The simtune kernels (built on first use: importing this module compiles nothing)."""

    @wp.kernel
    def mask_timestep(
        steps: wp.array2d(dtype=int),  # type: ignore[valid-type]
        segment: int,
        substep: int,
        dt: wp.array(dtype=float),  # type: ignore[valid-type]
        timestep: wp.array(dtype=float),  # type: ignore[valid-type]
    ):
        world = wp.tid()
        if substep < steps[world, segment]:
            timestep[world] = dt[world]
        else:
            timestep[world] = 0.0

    @wp.kernel
    def control(
        targets: wp.array3d(dtype=wp.float64),  # type: ignore[valid-type]
        sample: int,
        kp: wp.array2d(dtype=wp.float64),  # type: ignore[valid-type]
        v_max: wp.array2d(dtype=wp.float64),  # type: ignore[valid-type]
        arm_qpos: wp.array(dtype=int),  # type: ignore[valid-type]
        qpos: wp.array2d(dtype=float),  # type: ignore[valid-type]
        ctrl: wp.array2d(dtype=float),  # type: ignore[valid-type]
    ):
        # in 64 bits, as JointController computes it: the command is the one the step-by-step protocol sends
        world, joint = wp.tid()
        limit = v_max[world, joint]
        velocity = (targets[world, sample, joint] - wp.float64(qpos[world, arm_qpos[joint]])) * kp[world, joint]
        ctrl[world, joint] = wp.float32(wp.min(wp.max(velocity, -limit), limit))

    @wp.kernel
    def latch(
        steps: wp.array2d(dtype=int),  # type: ignore[valid-type]
        segment: int,
        substep: int,
        wrist: int,
        obj: int,
        xpos: wp.array2d(dtype=wp.vec3),  # type: ignore[valid-type]
        xmat: wp.array2d(dtype=wp.mat33),  # type: ignore[valid-type]
        wrist_pos: wp.array(dtype=wp.vec3),  # type: ignore[valid-type]
        wrist_rot: wp.array(dtype=wp.mat33),  # type: ignore[valid-type]
        object_pos: wp.array(dtype=wp.vec3),  # type: ignore[valid-type]
    ):
        # the poses a world's own last step left (segment -1: the start state); a world waiting for the
        # others recomputes its poses from its final state, which MuJoCo's stepping never shows
        world = wp.tid()
        last = 0
        if segment >= 0:
            last = steps[world, segment] - 1
        if segment < 0 or substep == last:
            wrist_pos[world] = xpos[world, wrist]
            wrist_rot[world] = xmat[world, wrist]
            if obj >= 0:
                object_pos[world] = xpos[world, obj]

    @wp.kernel
    def sample_state(
        sample: int,
        arm_qpos: wp.array(dtype=int),  # type: ignore[valid-type]
        qpos: wp.array2d(dtype=float),  # type: ignore[valid-type]
        wrist_now: wp.array(dtype=wp.vec3),  # type: ignore[valid-type]
        rot_now: wp.array(dtype=wp.mat33),  # type: ignore[valid-type]
        object_now: wp.array(dtype=wp.vec3),  # type: ignore[valid-type]
        wrist_pos: wp.array2d(dtype=wp.vec3),  # type: ignore[valid-type]
        wrist_rot: wp.array2d(dtype=wp.mat33),  # type: ignore[valid-type]
        angles: wp.array3d(dtype=float),  # type: ignore[valid-type]
        object_pos: wp.array2d(dtype=wp.vec3),  # type: ignore[valid-type]
    ):
        world = wp.tid()
        wrist_pos[world, sample] = wrist_now[world]
        wrist_rot[world, sample] = rot_now[world]
        for j in range(arm_qpos.shape[0]):
            angles[world, sample, j] = qpos[world, arm_qpos[j]]
        if object_pos.shape[1] > sample:
            object_pos[world, sample] = object_now[world]

    return mask_timestep, latch, control, sample_state


def warp_device() -> str:
    """The device Warp runs on: a CUDA GPU when one is found, else the CPU."""
    return str(wp.get_preferred_device()) if wp is not None else "none"


def step_counts(dt: float, phase: float, n_samples: int, period: float = CONTROL_PERIOD) -> np.ndarray:
    """Physics steps before and after the controller's update in each control period, (n_samples - 1, 2).

    The same counts :meth:`Engine.rollout` takes: simulated time stays within half a step of the sample
    and the controller clocks whatever the time step.
    """
    counts = np.zeros((max(n_samples - 1, 0), 2), dtype=np.int32)
    t_sim = 0.0
    for k in range(n_samples - 1):
        if phase:
            n = int(round((k * period + phase - t_sim) / dt))
            if n > 0:
                counts[k, 0] = n
                t_sim += n * dt
        n = max(1, int(round(((k + 1) * period - t_sim) / dt)))
        counts[k, 1] = n
        t_sim += n * dt
    return counts


#: What one step of a batch costs on Warp's CPU device beyond its worlds' own work, in worlds: about 15 ms
#: of kernel launches against 0.15 ms per world of `cube` (measured with benchmarks/gpu.py, 2026-11-23).
CPU_STEP_OVERHEAD_WORLDS = 100.0


def time_step_groups(timesteps: dict[int, float], overhead: float = CPU_STEP_OVERHEAD_WORLDS) -> list[list[int]]:
    """Members (index -> time step) in batches for Warp's CPU device, shortest time steps first.

    A batch steps as often as its member with the shortest time step, and a waiting world costs the CPU as
    much as a moving one; a population's time steps span 1-50 ms, so one batch may compute 50 times the
    steps it uses.  Each step of a batch also costs ``overhead`` worlds' work whatever its size.  So: bins
    of time steps within a factor 2, then neighbouring bins merged while that costs less (a step of a
    batch of n worlds costs n + ``overhead``).  (On a GPU a step costs about the same for any number of
    worlds until the GPU is full: there the population is one batch.)
    """
    bins: list[list[int]] = []
    for i in sorted(timesteps, key=lambda i: timesteps[i]):
        if not bins or timesteps[i] > 2.0 * timesteps[bins[-1][0]]:
            bins.append([])
        bins[-1].append(i)

    def cost(group: list[int]) -> float:  # steps per simulated second, times worlds plus overhead
        return (len(group) + overhead) / timesteps[group[0]]

    while len(bins) > 1:
        savings = [cost(a) + cost(b) - cost(a + b) for a, b in pairwise(bins)]
        best = int(np.argmax(savings))
        if savings[best] <= 0:
            break
        bins[best : best + 2] = [bins[best] + bins[best + 1]]
    return bins


class MujocoWarpEngine(Engine):
    name = "mujoco-warp"
    reads_mjcf = True
    #: MuJoCo's kinds less the encoder model's (simtune.params.kinds), which the batched controller kernel does not
    #: have; the armature and joint friction become MJWarp's per-world ``dof_armature`` / ``dof_frictionloss`` like
    #: any field a parameter changes, each joint's gain a row of the control kernel's gains
    engine_parameters = kinds_of_engine("mujoco-warp", 6)
    #: the engine whose code maps a member's parameters onto its world (the drive-train kinds through its
    #: ``set_armature`` / ``set_joint_friction``): each world's model is that engine's, reset with them
    host_class = MujocoEngine

    @classmethod
    def version(cls) -> str:
        return mjw.__version__ if mjw is not None and mujoco is not None else "not installed"

    @classmethod
    def device(cls) -> str:
        if wp is None:
            return "-"
        device = wp.get_device(warp_device())
        return f"GPU: {device.name} ({device.alias})" if device.is_cuda else "CPU (Warp found no GPU)"

    @classmethod
    def inactive_parameters(cls, task: TaskSpec) -> dict[str, str]:
        return MujocoEngine.inactive_parameters(task)

    def __init__(self, task: TaskSpec):
        super().__init__(task)
        #: the host model: the MuJoCo engine's scene, onto which each member's parameters are mapped
        self.host = self.host_class(task)
        m = self.host.model
        robot = task.robot
        self._arm_qpos = np.array([m.jnt_qposadr[m.joint(j).id] for j in robot.arm_joints], dtype=np.int32)
        self._wrist = int(m.body(robot.tracked_link).id)
        self._object = int(m.body(OBJECT_BODY).id) if task.object is not None else -1
        self._arm_body = np.zeros(m.nbody, dtype=bool)
        self._arm_body[[m.body(link.name).id for link in robot.links]] = True
        self._device = warp_device()
        self._tuned_fields = self._fields_parameters_change()
        # the model and data of the one-world interface, and its time step: set by reset()
        self._single: tuple | None = None
        self._single_timestep = self.host.timestep

    # --- the model fields of a population --------------------------------------------------------------------
    def _fields_parameters_change(self) -> list[str]:
        """The MJWarp model fields (batched ones, as named on MjModel) that some parameter changes.

        Found by applying every parameter at once, away from its generic value, on the host model: whatever
        the mapping or MuJoCo's re-derived constants touch shows up (the time step is handled apart).
        """
        batched = [
            f.name
            for f in mjw.Model.__dataclass_fields__.values()
            if getattr(f.type, "shape", ("",))[0] == "*" and hasattr(self.host.model, f.name)
        ]
        before = {name: np.array(getattr(self.host.model, name)) for name in batched}
        self.host.reset({name: value * 1.5 + 0.01 for name, value in self.host.defaults().items()})
        changed = [name for name in batched if not np.array_equal(before[name], getattr(self.host.model, name))]
        self.host.reset({})
        return changed

    def _batch_model(self, params: Sequence[dict[str, float]]):
        """One MJWarp model whose worlds hold the members' parameters, and the members' time steps."""
        n = len(params)
        values: dict[str, list[np.ndarray]] = {name: [] for name in self._tuned_fields}
        dts = np.empty(n)
        for i, p in enumerate(params):
            self.host.reset(p)
            dts[i] = self.host.timestep
            for name in self._tuned_fields:
                values[name].append(np.array(getattr(self.host.model, name)))
        batched = [
            name for name in self._tuned_fields if any(not np.array_equal(v, values[name][0]) for v in values[name])
        ]
        with wp.ScopedDevice(self._device):
            model = mjw.put_model(self.host.model, batch_sizes=dict.fromkeys(batched, n))
            for name in batched:
                field = getattr(model, name)
                setattr(model, name, wp.array(np.stack(values[name]), dtype=field.dtype, shape=(n, *field.shape[1:])))
            model.opt.timestep = wp.zeros(n, dtype=float)
            model.opt.warn_overflow = 0  # overflows are read from data.overflow and reported per member
            # the host's data: the start state every member shares (the last member's reset left it)
            data = mjw.put_data(
                self.host.model,
                self.host.data,
                nworld=n,
                nconmax=CONTACTS_PER_WORLD,
                njmax=CONSTRAINTS_PER_WORLD,
            )
        return model, data, dts

    # --- batches -----------------------------------------------------------------------------------------------
    def rollout_batch(
        self,
        params: Sequence[dict[str, float]],
        n_samples: int,
        monitors: Sequence[Monitor | None] | None = None,
        threads: int = 1,
    ) -> Iterator[tuple[int, Rollout | Exception]]:
        """The rollouts of a whole batch, simulated as one MJWarp batch (on a CPU: one per group of similar
        time steps, see :func:`time_step_groups`), yielded as each batch finishes.

        ``threads`` is not used: the device runs the worlds in parallel.  A member whose parameters cannot
        be applied yields that error and the rest run; an error of a batch itself is each of its members'.
        """
        good: dict[int, float] = {}  # member -> its time step
        for i, p in enumerate(params):
            try:
                JointController(self.task, p)
                self.host.reset(p)
                good[i] = self.host.timestep
            except Exception as exc:  # that member's own error, as the one-at-a-time seam gives it
                yield i, exc
        on_gpu = wp.get_device(self._device).is_cuda
        for group in [list(good)] if on_gpu else time_step_groups(good):
            if not group:
                continue
            try:
                rollouts = self._simulate([params[i] for i in group], n_samples)
            except Exception as exc:
                for i in group:
                    yield i, exc
                continue
            for i, (roll, period_steps) in zip(group, rollouts, strict=True):
                monitor = monitors[i] if monitors is not None else None
                yield i, _replay(roll, period_steps, monitor, wrist_limit(self.task.robot))

    def _simulate(self, params: Sequence[dict[str, float]], n_samples: int) -> list[tuple[Rollout, np.ndarray]]:
        """Each member's samples to the end, and its physics steps in each control period (the state checks
        and the monitor come after, in :func:`_replay`)."""
        mask_timestep, latch, control, sample_state = _kernels()
        n, nj = len(params), self.task.robot.n_joints
        model, data, dts = self._batch_model(params)
        controllers = [JointController(self.task, p) for p in params]
        times = np.arange(n_samples) * CONTROL_PERIOD
        counts = np.stack([step_counts(dt, c.phase, n_samples) for dt, c in zip(dts, controllers)])
        counts = counts.reshape(n, -1)  # (world, segment): before, after the update of each period
        busiest = counts.max(axis=0) if counts.size else np.zeros(0, dtype=np.int32)
        with wp.ScopedDevice(self._device):
            steps = wp.array(counts, dtype=int)
            dt = wp.array(dts, dtype=float)
            targets = wp.array(np.stack([c.targets(times + c.phase) for c in controllers]), dtype=wp.float64)
            v_max = wp.array(np.stack([c.v_max for c in controllers]), dtype=wp.float64)
            arm_qpos = wp.array(self._arm_qpos, dtype=int)
            wrist_pos = wp.zeros((n, n_samples), dtype=wp.vec3)
            wrist_rot = wp.zeros((n, n_samples), dtype=wp.mat33)
            angles = wp.zeros((n, n_samples, nj), dtype=float)
            object_pos = wp.zeros((n, n_samples if self._object >= 0 else 1), dtype=wp.vec3)
            wrist_now = wp.zeros(n, dtype=wp.vec3)
            rot_now = wp.zeros(n, dtype=wp.mat33)
            object_now = wp.zeros(n, dtype=wp.vec3)
            kp = wp.array(np.stack([c.kp for c in controllers]), dtype=wp.float64)  # each joint's own gain

            def poses(segment: int, substep: int) -> None:
                wp.launch(
                    latch,
                    dim=n,
                    inputs=[steps, segment, substep, self._wrist, self._object, data.xpos, data.xmat],
                    outputs=[wrist_now, rot_now, object_now],
                )

            def advance(segment: int) -> None:
                for substep in range(int(busiest[segment])):
                    wp.launch(mask_timestep, dim=n, inputs=[steps, segment, substep, dt, model.opt.timestep])
                    mjw.step(model, data)
                    poses(segment, substep)

            poses(-1, 0)
            for k in range(n_samples):
                wp.launch(
                    sample_state,
                    dim=n,
                    inputs=[k, arm_qpos, data.qpos, wrist_now, rot_now, object_now],
                    outputs=[wrist_pos, wrist_rot, angles, object_pos],
                )
                if k == n_samples - 1:
                    break
                advance(2 * k)
                wp.launch(
                    control, dim=(n, nj), inputs=[targets, k, kp, v_max, arm_qpos, data.qpos], outputs=[data.ctrl]
                )
                advance(2 * k + 1)
            # copied back once: every sample of every world
            pos, rot, q = wrist_pos.numpy(), rot_host(wrist_rot), angles.numpy()
            obj = object_pos.numpy() if self._object >= 0 else None
            overflow = data.overflow.numpy()
        capacity = int(mjw.OverflowType.NEFC | mjw.OverflowType.BROADPHASE | mjw.OverflowType.NARROWPHASE)
        rollouts = []
        for w in range(n):
            roll = Rollout(
                times,
                pos[w].astype(float),
                rot[w].astype(float),
                q[w].astype(float),
                obj[w].astype(float) if obj is not None else None,
                samples_run=n_samples,
            )
            if overflow[w] & capacity:
                roll.stable = False
                roll.message = "mujoco-warp ran out of room for contacts or constraints (its results are not valid)"
            rollouts.append((roll, counts[w].reshape(-1, 2).sum(axis=1)))
        return rollouts

    # --- one rollout: a batch of one ---------------------------------------------------------------------------
    def rollout(
        self,
        params: dict[str, float],
        n_samples: int,
        rate: float = 1.0 / CONTROL_PERIOD,
        monitor: Monitor | None = None,
        after_step: Callable[[], None] | None = None,
    ) -> Rollout:
        """A batch of one; with ``after_step`` or another rate, the shared step-by-step protocol instead."""
        if after_step is not None or rate != 1.0 / CONTROL_PERIOD:
            return super().rollout(params, n_samples, rate, monitor, after_step)
        ((_, result),) = self.rollout_batch([params], n_samples, [monitor])
        if isinstance(result, Exception):
            raise result
        return result

    # --- the one-world interface (probes that step one physics step at a time) -----------------------------------
    def defaults(self) -> dict[str, float]:
        return self.host.defaults()

    @property
    def timestep(self) -> float:
        return self._single_timestep

    @property
    def model(self):
        """The MuJoCo model with the parameters of the last reset: the MJCF export writes it."""
        return self.host.model

    def reset(self, params: dict[str, float]) -> None:
        model, data, dts = self._batch_model([params])
        model.opt.timestep.assign(dts)
        self._single, self._single_timestep = (model, data), float(dts[0])

    def _world(self):
        if self._single is None:
            raise RuntimeError("reset() the engine before stepping it")
        return self._single

    def set_joint_velocities(self, velocities: np.ndarray) -> None:
        _, data = self._world()
        data.ctrl.assign(np.asarray(velocities, dtype=np.float32).reshape(1, -1))

    def step(self, n: int) -> None:
        model, data = self._world()
        with wp.ScopedDevice(self._device):
            for _ in range(n):
                mjw.step(model, data)

    def joint_angles(self) -> np.ndarray:
        return self._world()[1].qpos.numpy()[0, self._arm_qpos].astype(float)

    def wrist_pose(self) -> tuple[np.ndarray, np.ndarray]:
        data = self._world()[1]
        return data.xpos.numpy()[0, self._wrist].astype(float), data.xmat.numpy()[0, self._wrist].astype(float)

    def object_position(self) -> np.ndarray | None:
        return None if self._object < 0 else self._world()[1].xpos.numpy()[0, self._object].astype(float)

    def arm_object_contact(self) -> bool:
        if self._object < 0:
            return False
        data = self._world()[1]
        n = min(int(data.nacon.numpy()[0]), data.contact.geom.shape[0])
        if not n:
            return False
        geoms = data.contact.geom.numpy()[:n]
        bodies = self.host.model.geom_bodyid[geoms]
        b1, b2 = bodies[:, 0], bodies[:, 1]
        obj = self._object
        return bool(np.any(((b1 == obj) & self._arm_body[b2]) | ((b2 == obj) & self._arm_body[b1])))

    def diverged(self) -> str:
        if self._single is not None and int(self._single[1].overflow.numpy()[0]) & int(
            mjw.OverflowType.NEFC | mjw.OverflowType.BROADPHASE | mjw.OverflowType.NARROWPHASE
        ):
            return "mujoco-warp ran out of room for contacts or constraints"
        return ""

    def close(self) -> None:
        self._single = None


def rot_host(rot) -> np.ndarray:
    """Device rotation samples as (world, sample, 3, 3)."""
    return rot.numpy().reshape(*rot.shape, 3, 3)


def _replay(roll: Rollout, period_steps: np.ndarray, monitor: Monitor | None, limit: float) -> Rollout:
    """``roll``, simulated to the end, as :meth:`Engine.rollout` would have ended it: the same state
    checks at the same samples, the monitor shown the same samples, the last good sample held after a stop."""
    n = len(roll.times)
    k = 0
    stopped_at, checked, stable, message, pruned = n, 0, roll.stable, roll.message, False
    obj_start = roll.object_pos[0] if roll.object_pos is not None else None
    for k in range(n):
        if k == n - 1 or k - checked >= CHECK_EVERY - 1:
            bad, why = _first_bad(
                roll.wrist_pos[checked : k + 1],
                roll.wrist_rot[checked : k + 1],
                roll.joint_angles[checked : k + 1],
                roll.object_pos[checked : k + 1] if roll.object_pos is not None else None,
                obj_start,
                limit,
            )
            if bad is not None:
                stopped_at = checked + bad
                stable, message = False, f"unstable at t={roll.times[stopped_at]:.2f} s: {why}"
                break
            checked = k + 1
        if k == n - 1:
            break
        if monitor is not None and monitor(k, roll.wrist_pos[k], roll.wrist_rot[k]):
            stopped_at, pruned = k + 1, True
            break
    roll.steps = int(period_steps[:k].sum())  # the periods before the one the loop ended in
    roll.stable, roll.message, roll.pruned, roll.samples_run = stable, message, pruned, min(stopped_at, n)
    if 0 < roll.samples_run < n:
        for samples in (roll.wrist_pos, roll.wrist_rot, roll.joint_angles, roll.object_pos):
            if samples is not None:
                samples[roll.samples_run :] = samples[roll.samples_run - 1]
    return roll


__all__ = ["MujocoWarpEngine", "step_counts", "time_step_groups", "warp_device"]
