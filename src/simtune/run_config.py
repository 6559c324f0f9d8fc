"""A run's settings: :class:`RunConfig`, the one list of them, as a run store keeps it.

It stands apart from :mod:`simtune.run_plan` (what a configuration resolves to) so that the command line can
derive its options from it without importing the engines, the optimisers and the objective: its checks import
what they need when they run.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass, fields

from simtune.common import checks
from simtune.common.limits import MAX_SEED, MAX_WORKERS
from simtune.data import check_repeats
from simtune.data.clock import check_reference, default_reference
from simtune.errors import ConfigError, check_choice
from simtune.tasks import check_loading, check_targets

#: ``simtune tune``'s space where none is given: ``calibrated`` fits both real tasks better and sooner than
#: ``extended`` (docs/tuning.md "The default space", measured 2026-11-26); a paper-exact run takes ``shared``, the
#: paper's 31 parameters (--paper-exact runs only the paper's spaces, shared and individual)
DEFAULT_SPACE = "calibrated"
#: What least squares fits (RunConfig.residuals): each signal divided by its noise, or the fitness's parts as they are
RESIDUALS = ("noise", "plain")


#: the settings every run store has held since the first: a store without one is damaged, not old
STORED_ALWAYS = ("engine", "tasks", "space", "data")


#: the run settings a comparison of optimisers takes where it is given none: the extended space (RunConfig's
#: defaults for the rest); the optimiser, seed and evaluation budget are the comparison's own, set per run
COMPARE_DEFAULTS = {"space": "extended"}
#: the run settings each run of a comparison sets itself
COMPARE_SETS = ("optimizer", "seed", "max_evaluations", "max_seconds", "target_fitness", "refine")
#: the run settings a transfer study takes where it is given none: the extended space searched by the paper's DE,
#: as the transfer results of docs/tuning.md were measured (RunConfig's defaults for the rest)
TRANSFER_DEFAULTS = {"space": "extended", "optimizer": "de"}


def default_space(paper_exact: bool) -> str:
    """The space a tune runs in when none is named: :data:`DEFAULT_SPACE`, or ``shared`` for a paper-exact run."""
    return "shared" if paper_exact else DEFAULT_SPACE


#: evaluations one run may be given: far above any search that ends (a day of MuJoCo rollouts is about 10^6), low
#: enough that a mistyped count is refused rather than taken as "never stop"
MAX_EVALUATIONS = 10**9


@dataclass
class RunConfig:
    """A run's settings: the one list of them.  Its defaults are a new run's, wherever it is made (``simtune
    tune``'s options, :func:`simtune.api.run_config`, the studies); an empty string resolves in
    ``__post_init__`` (the defaults --paper-exact changes).  What a key missing from an older store meant is
    :meth:`from_stored`'s."""

    engine: str = "mujoco"
    tasks: str = "cube"  # as given: "cube" or "single,cube"
    #: the parameter space; left empty: calibrated, or shared with paper_exact (:func:`default_space`)
    space: str = ""
    data: str | None = None  # folder with one sub-folder of recordings per task; None: each task's own (its project's)
    seed: int = 0
    workers: int = 1
    max_seconds: float | None = None
    max_generations: int = 1000
    only: list[str] | None = None  # tune just these parameters of the space
    eval_timeout: float | None = 600.0  # seconds before a worker's evaluation is abandoned; None: never
    prune: bool = True  # stop trials that can no longer beat their parent (same search, less simulation)
    target_fitness: float | None = None  # stop once the best fitness reaches this
    #: a key of simtune.optimize.OPTIMIZERS; left empty: auto, or de with paper_exact
    optimizer: str = ""
    refine: bool = False  # polish the best point with least squares on the residuals afterwards
    max_evaluations: int | None = None  # stop once this many evaluations were used (checked per batch)
    #: the seed paper's exact search: SciPy's DE with immediate updating and polish, one worker, no
    #: pruning, and the paper's whole parameter list (parameters the engine lacks kept, without effect)
    paper_exact: bool = False
    #: weights of the fitness's parts (simtune.fitness.FitnessWeights keys); None: the defaults
    weights: dict[str, float] | None = None
    #: the JointState topic of ROS 2 joint logs; None: each log's only one
    joint_topic: str | None = None
    #: the project file the tasks are read from (absolute); None: the bundled MICO project
    project: str | None = None
    #: keep parameters that change no rollout of the tasks in the search (the paper's full D); implied by
    #: paper_exact.  Runs stored before this setting existed kept them all.
    keep_inactive: bool = False
    #: with several tasks, one command delay per task (``command_delay_<task>``) instead of one shared
    #: delay; runs stored before this setting existed shared one
    task_delays: bool = True
    #: evaluate each batch in the coordinating process on --workers threads (the engine's batch path; the same
    #: results as worker processes, without their crash isolation and time-outs)
    threads: bool = False
    #: what the simulation is scored against: ``aligned`` (the repeats on one clock, then averaged) or ``mean``
    #: (the paper's plain mean); left empty: aligned, or mean with paper_exact.  Runs stored before this setting
    #: existed scored against the mean
    reference: str = ""
    #: which of each task's repeats build the reference (held-out scoring): ``all``, ``even`` (the 1st, 3rd ...
    #: in sorted order) or ``odd`` (the 2nd, 4th ...); runs stored before this setting existed used all
    repeats: str = "all"
    #: which targets the tasks' phases carry (simtune.tasks.TARGETS): ``task``, the task files' (what the robot
    #: ran), or ``published``, a phase's published targets where its file corrects them (the bundled `cube`'s
    #: phase 2); left empty: task, or published with paper_exact.  Runs stored before the correction ran the
    #: published ones.
    targets: str = ""
    #: what least squares, the intervals and the identifiability check fit (:data:`RESIDUALS`): ``noise``, every
    #: recorded signal divided by its own noise (simtune.fitness.signal_noise), or ``plain``, the fitness's parts
    #: as they are; left empty: noise, or plain with paper_exact.  Runs stored before this setting fitted plain ones.
    residuals: str = ""
    #: keep a repeat far from the others (the repeat check, simtune.data.screen, leaves it out with a warning);
    #: runs stored before the check kept every repeat, and their fingerprints say which it now leaves out
    keep_repeats: bool = False
    #: the prior's strength (a maximum a posteriori fit: simtune.objective.Prior): each tuned parameter's distance
    #: from its generic value, over its kind's width (simtune.params.kinds.PRIOR_WIDTHS), costs this many noise
    #: floors per width squared; None or 0: plain least squares.  Runs stored before this setting had none
    prior: float | None = None
    #: how the engines load the robot (simtune.tasks.LOADINGS): ``description``, as its description says
    #: (PyBullet: the file's inertias, no link damping of Bullet's own), or ``paper``, as the seed paper loaded it
    #: (PyBullet: inertias from the collision shapes, link damping 0.04); left empty: description, or paper with
    #: paper_exact.  Runs stored before this setting loaded as the paper did.
    loading: str = ""
    #: tasks held out of the search and scored with its best parameters afterwards (:func:`simtune.tasks.held_out`):
    #: ``N``, the last N of the tasks named (episodes of a dataset: the last N episodes), or a comma-separated list
    #: of task names or episode numbers; empty: none.  Runs stored before this setting held none out
    validate: str = ""

    def __post_init__(self) -> None:
        if self.space == "":
            self.space = default_space(self.paper_exact is True)
        if self.optimizer == "":
            self.optimizer = "de" if self.paper_exact is True else "auto"
        if self.reference == "":
            self.reference = default_reference(self.paper_exact is True)
        if self.targets == "":
            self.targets = "published" if self.paper_exact is True else "task"
        if self.residuals == "":
            self.residuals = "plain" if self.paper_exact is True else "noise"
        if self.loading == "":
            self.loading = "paper" if self.paper_exact is True else "description"

    @property
    def worker_processes(self) -> bool:
        """Whether the run's evaluations go to worker processes (more than one worker, not on threads): what needs
        a script's ``__main__`` guard and what the fork server is started for."""
        return self.workers > 1 and not self.threads

    def record(self) -> dict:
        """The configuration as a run store keeps it: ``project`` left out for the bundled MICO project (None),
        ``weights``, ``joint_topic`` and ``prior`` at their defaults (None), ``threads`` when off, ``repeats`` when
        ``all``, ``targets`` when ``published`` and ``loading`` when ``paper``, so that the stores of runs made
        before projects, joint logs, the batch path, the choice of repeats, the corrected targets and the loading
        and of new MICO runs compare equal (``validate`` left out when empty)."""
        values = asdict(self)
        for key in ("project", "weights", "joint_topic", "prior"):
            if values[key] is None:
                del values[key]
        for key in ("threads", "keep_repeats"):
            if not values[key]:
                del values[key]
        if values["repeats"] == "all":
            del values["repeats"]
        if values["targets"] == "published":
            del values["targets"]
        if values["residuals"] == "plain":
            del values["residuals"]
        if values["loading"] == "paper":
            del values["loading"]
        if values["validate"] == "":
            del values["validate"]
        return values

    @classmethod
    def from_stored(cls, values, where: str) -> RunConfig:
        """The configuration a run store holds; one line naming ``where`` and the key for anything unknown or bad."""
        if not isinstance(values, dict):
            raise ConfigError(f"{where}: the stored configuration is not a JSON object")
        known = {f.name for f in fields(cls)}
        for key in values:
            if key not in known:
                raise ConfigError(
                    f"{where}: unknown key {key!r} in the stored configuration (written by another simtune version?)"
                )
        # a run from before these settings ran DE without a time-out, searched every parameter, with one shared
        # command delay, and scored against the plain mean of the repeats, on the targets as published (before the
        # task files corrected them), with PyBullet loading the robot as the paper did
        values = {
            "optimizer": "de",
            "eval_timeout": None,
            "keep_inactive": True,
            "task_delays": False,
            "reference": "mean",
            "targets": "published",
            "residuals": "plain",
            "loading": "paper",
            **values,
        }
        for key in STORED_ALWAYS:
            if key not in values:
                raise ConfigError(f"{where}: the stored configuration has no {key!r}")
        config = cls(**values)
        config.check(where)
        return config

    def check(self, where: str = "") -> None:
        """One-line ConfigError for settings no optimiser can run with (each value's type and range)."""
        # imported here: the command line reads this module for its options, without the optimisers' imports
        from simtune.fitness import FitnessWeights
        from simtune.optimize import get_optimizer

        at = f"{where}: " if where else ""

        def bad(key: str, what: str) -> ConfigError:
            return ConfigError(f"{at}{key} must be {what}, got {checks.shown(getattr(self, key))}")

        for key in ("engine", "tasks", "space", "optimizer", "validate"):
            if not isinstance(getattr(self, key), str):
                raise bad(key, "a string")
        for key in ("data", "project"):
            if getattr(self, key) is not None and not isinstance(getattr(self, key), str):
                raise bad(key, "a string or null")
        checks.count(f"{at}seed", self.seed, 0, MAX_SEED)
        checks.count(f"{at}workers", self.workers, 1, MAX_WORKERS)
        checks.count(f"{at}max_generations", self.max_generations)
        if self.max_evaluations is not None:
            checks.count(f"{at}max_evaluations", self.max_evaluations)
            if self.max_evaluations > MAX_EVALUATIONS:
                raise bad("max_evaluations", f"at most {MAX_EVALUATIONS} (a budget, not 'never stop')")
        for key in ("max_seconds", "eval_timeout"):
            if getattr(self, key) is not None:
                checks.seconds(f"{at}{key}", getattr(self, key))
        if self.target_fitness is not None and (not checks.is_finite(self.target_fitness) or self.target_fitness < 0):
            raise bad("target_fitness", "a finite number of at least 0")
        number = isinstance(self.prior, int | float) and not isinstance(self.prior, bool)
        if self.prior is not None and (not number or not 0 <= self.prior < float("inf")):
            raise bad("prior", "a finite number of at least 0 (0: no prior)")
        for key in ("prune", "refine", "paper_exact", "keep_inactive", "task_delays", "threads", "keep_repeats"):
            if not isinstance(getattr(self, key), bool):
                raise bad(key, "true or false")
        if self.only is not None and (
            not isinstance(self.only, list) or not all(isinstance(n, str) for n in self.only)
        ):
            raise bad("only", "a list of parameter names")
        if self.weights is not None:
            if not isinstance(self.weights, dict):
                raise bad("weights", "a mapping of weight names to numbers")
            FitnessWeights.from_mapping(self.weights, f"{at}weights")
        if self.joint_topic is not None and not isinstance(self.joint_topic, str):
            raise bad("joint_topic", "a topic name")
        get_optimizer(self.optimizer)
        from simtune.params.space import SPACES

        if self.space not in SPACES:
            raise ConfigError(f"{at}unknown parameter space {self.space!r} (known: {', '.join(SPACES)})")
        check_reference(self.reference, f"{at}reference")
        check_repeats(self.repeats, f"{at}repeats")
        check_targets(self.targets, f"{at}targets")
        check_choice(self.residuals, RESIDUALS, f"{at}residuals", "weighed by each signal's noise, or plain")
        check_loading(self.loading, f"{at}loading")
        if self.paper_exact:
            if self.reference != "mean":
                raise ConfigError(
                    f"{at}--paper-exact scores against the plain mean of the repeats (the paper's fitness): "
                    f"drop --reference {self.reference}"
                )
            if self.optimizer != "de":
                raise ConfigError(f"{at}--paper-exact runs differential evolution, not --optimizer {self.optimizer}")
            if self.space not in ("shared", "individual"):
                raise ConfigError(
                    f"{at}--paper-exact needs one of the paper's spaces (shared, individual), not {self.space!r}"
                )
            if self.only:
                raise ConfigError(f"{at}--paper-exact tunes the paper's whole parameter list: drop --only")
            if self.workers != 1:
                raise ConfigError(
                    f"{at}--paper-exact evaluates one trial at a time (SciPy's immediate updating): drop --workers"
                )
            if self.refine:
                raise ConfigError(f"{at}--paper-exact ends with SciPy's own polish: drop --refine")
            if self.targets != "published":
                raise ConfigError(f"{at}--paper-exact runs the published targets: drop --targets {self.targets}")
            if self.residuals != "plain":
                raise ConfigError(f"{at}--paper-exact fits the plain residuals: drop residuals={self.residuals!r}")
            if self.prior:
                raise ConfigError(f"{at}--paper-exact minimises the paper's fitness alone: drop --prior {self.prior:g}")
            if self.loading != "paper":
                raise ConfigError(f"{at}--paper-exact loads the robot as the paper did: drop --loading {self.loading}")


#: every run setting's default, by name: a new run's (an empty string: resolved in ``__post_init__``)
DEFAULTS: dict[str, object] = {f.name: f.default for f in fields(RunConfig)}
