"""The checks of a value a user gives that every entry point makes (the Python API's arguments and a run's
settings, whether typed, passed or read from a store), and how a refused value is shown: one set, so that a
count or a number is refused alike, in the same words, wherever it comes in."""

from __future__ import annotations

import math

from simtune.errors import ConfigError


def shown(value: object) -> str:
    """``value`` as an error message shows it: its repr, but an integer past any float by its length (10**5000's
    digits are more than a line, and more than Python prints).

    Args:
        value: the refused value.

    Returns:
        At most 80 characters.
    """
    if is_integer(value) and value.bit_length() > 64:  # type: ignore[attr-defined]
        return f"an integer of about {int(value.bit_length() * math.log10(2)) + 1} digits"  # type: ignore[attr-defined]
    text = repr(value)
    return text if len(text) <= 80 else text[:77] + "..."


def is_integer(value: object) -> bool:
    """Whether ``value`` is an integer; a bool is not (True is no count the user meant).

    Args:
        value: any value.

    Returns:
        True for an ``int`` that is not a ``bool``.
    """
    return isinstance(value, int) and not isinstance(value, bool)


def is_finite(value: object) -> bool:
    """Whether ``value`` is a real number that a float holds (not a bool, NaN, an infinity or 10**400).

    Args:
        value: any value.

    Returns:
        True for a finite ``int`` or ``float`` that is not a ``bool``.
    """
    if isinstance(value, bool) or not isinstance(value, int | float):
        return False
    try:
        return math.isfinite(value)
    except OverflowError:  # an integer past any float
        return False


def count(name: str, value: object, low: int = 1, high: int | None = None) -> int:
    """``value`` if it is an integer from ``low`` to ``high``; a bool, a float, a string or None is refused (a
    count the user typed wrongly is not guessed).

    Args:
        name: what the message calls the value (an argument's or a setting's name, with any place before it).
        value: the value given.
        low: the least allowed.
        high: the most allowed; None: no upper limit.

    Returns:
        ``value``.

    Raises:
        ConfigError: ``NAME must be an integer from LOW to HIGH, got VALUE``.
    """
    if not is_integer(value) or value < low or (high is not None and value > high):  # type: ignore[operator]
        span = f"from {low} to {high}" if high is not None else f"of at least {low}"
        raise ConfigError(f"{name} must be an integer {span}, got {shown(value)}")
    return value  # type: ignore[return-value]


def number(name: str, value: object) -> float:
    """``value`` as a float if it is a finite number (whose range the caller checks).

    Args:
        name: what the message calls the value.
        value: the value given.

    Returns:
        ``float(value)``.

    Raises:
        ConfigError: ``NAME must be a finite number, got VALUE``.
    """
    if not is_finite(value):
        raise ConfigError(f"{name} must be a finite number, got {shown(value)}")
    return float(value)  # type: ignore[arg-type]


def positive(name: str, value: object, of: str = "") -> float:
    """``value`` as a float if it is a finite number above 0.

    Args:
        name: what the message calls the value.
        value: the value given.
        of: what it counts, for the message (``" of seconds"``).

    Returns:
        ``float(value)``.

    Raises:
        ConfigError: ``NAME must be a finite number OF above 0, got VALUE``.
    """
    if not is_finite(value) or not value > 0:  # type: ignore[operator]
        raise ConfigError(f"{name} must be a finite number{of} above 0, got {shown(value)}")
    return float(value)  # type: ignore[arg-type]


def seconds(name: str, value: object) -> float:
    """A time budget: :func:`positive` in seconds.

    Args:
        name: what the message calls the value.
        value: the value given.

    Returns:
        ``float(value)`` [s].

    Raises:
        ConfigError: ``NAME must be a finite number of seconds above 0, got VALUE``.
    """
    return positive(name, value, " of seconds")
