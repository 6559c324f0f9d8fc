"""Errors and warnings that reach the user as one readable line.

Anything raised as a :class:`SimtuneError` is caught by the CLI and printed as
``error: <message>`` with a non-zero exit code, never as a traceback.  Messages
name the file, line, body, field or option that is wrong.
"""


class SimtuneError(Exception):
    """A problem with the user's input or request, explained in one line."""


class RecordingError(SimtuneError):
    """A recording file or folder cannot be used (corrupt, truncated, wrong units ...)."""


class RecordingWarning(UserWarning):
    """Recording data that is still usable but was changed or partly left out."""


class ConfigError(SimtuneError):
    """An unknown engine, task, space or parameter, or an invalid value for one."""


class ProjectError(ConfigError):
    """A project or task file that cannot be used: the message names the file and the key."""


class EngineUnavailable(SimtuneError):
    """A physics engine that is not installed on this machine."""


class RunInterrupted(KeyboardInterrupt):
    """Ctrl-C while a run was tuning: its finished evaluations are stored; ``run_dir`` is where to resume."""

    def __init__(self, run_dir) -> None:
        super().__init__(str(run_dir))
        self.run_dir = run_dir


class RobotWarning(UserWarning):
    """A robot description that loads, but where simtune chose or changed something the user should know."""


class TaskWarning(UserWarning):
    """A task that runs, but against an assumption simtune tunes it under (an arm that touches the floor in a task
    without an object)."""


class EngineVersionWarning(UserWarning):
    """A result measured or stored under another version of an engine than the installed one: used where it was
    checked to replay (a shipped probe, a stored run), measured again where it does not."""


class RobotError(SimtuneError):
    """A robot description (URDF, meshes) that cannot be loaded, or a link or joint it does not have."""


def check_choice(value: object, choices: tuple[str, ...], where: str, meaning: str) -> str:
    """``value`` if it is one of ``choices``; else a one-line ConfigError naming ``where``, the choices and what
    they mean (``meaning``, in parentheses)."""
    if not isinstance(value, str) or value not in choices:
        listed = f"{', '.join(choices[:-1])} or {choices[-1]}" if len(choices) > 1 else choices[0]
        raise ConfigError(f"{where}: expected {listed} ({meaning}), got {value!r}")
    return value
