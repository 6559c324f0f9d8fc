"""The design's criterion and its search: which excursions, in which number, fill the recording best.

The information an excursion's recording gives the parameters (unit coordinates: each parameter over its range) is
``F = J^T J / s^2``: ``J`` the rows of the noise-weighted Jacobian of the rollout residuals
(:func:`simtune.uncertainty.jacobian`) that fall within the excursion, ``s^2`` one residual's noise variance.
Excursions start and end at rest at the same pose, so a chain's information is the sum of its excursions' (to the
small settling error left at each return).  The criterion is

    log det(sum_k F_k + LAMBDA I)

with ``LAMBDA = (2 x 1.96)^2``: the information of a prior as wide as the ranges (a 95 % interval one range wide), so
that a direction no excursion informs counts as known to its range and not as minus infinity (D-optimality,
regularised).  It is taken at a few points of the ranges (the generic point and two points a tenth of each range
to either side of it) and the design maximises the smallest of them (maximin: robust over the prior).

The search is Fedorov's exchange algorithm on the library: greedy (each time the excursion that raises the criterion
most per second of recording, until none fits the duration; an excursion may be chosen again), then exchanges (an
excursion of the chain for one of the library, the first that raises the criterion, until none does).  It is
deterministic: no random number, every tie broken by the library's order.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence

import numpy as np

from simtune.uncertainty import Z95

#: The prior's information per unit coordinate: a 95 % interval as wide as the range.
LAMBDA = (2.0 * Z95) ** 2
#: Rounds of exchanges at the most (each a pass over the chain).
EXCHANGE_ROUNDS = 4
#: An exchange is taken where it raises the criterion by more than this (a tie is no change).
GAIN_TOL = 1e-9


def sample_rows(span: tuple[float, float], n_samples: int, rate: float, signals: Sequence[int]) -> np.ndarray:
    """The residual rows of the samples within ``span`` [s) of one task: ``signals`` is each signal's width per
    sample, in the residual vector's order (3 for the wrist marker, the logged joints' count), each signal's block
    sample-major (:func:`simtune.fitness.residuals`)."""
    first = max(int(np.ceil(span[0] * rate - 1e-9)), 0)
    last = min(int(np.ceil(span[1] * rate - 1e-9)), n_samples)
    rows, offset = [], 0
    for width in signals:
        rows.append(offset + np.arange(first * width, last * width))
        offset += n_samples * width
    return np.concatenate(rows) if rows else np.zeros(0, dtype=int)


def information(unit: np.ndarray, rows: np.ndarray, variance: float) -> np.ndarray:
    """``J_rows^T J_rows / variance``: the information of those residual rows (unit coordinates)."""
    part = unit[rows]
    return part.T @ part / variance


def logdet(matrix: np.ndarray) -> float:
    """log det(``matrix`` + :data:`LAMBDA` I)."""
    sign, value = np.linalg.slogdet(matrix + LAMBDA * np.eye(len(matrix)))
    return float(value) if sign > 0 else -np.inf


def criterion(infos: Sequence[np.ndarray], chain: Sequence[int], base: Sequence[np.ndarray] | None = None) -> float:
    """The smallest over the points of log det(information of ``chain`` + prior): ``infos[p][k]`` is excursion k's
    information at point p (a stacked (K, D, D) array per point); ``base[p]``: information held by every chain."""
    values = []
    for p, stack in enumerate(infos):
        total = np.zeros(stack.shape[1:]) if base is None else base[p].copy()
        for k in chain:
            total += stack[k]
        values.append(logdet(total))
    return min(values)


def choose(
    infos: Sequence[np.ndarray],
    lengths: Sequence[float],
    budget: float,
    on_step: Callable[[], None] | None = None,
) -> tuple[list[int], float]:
    """The chain of excursions (indices into the library, repeats allowed) within ``budget`` seconds that maximises
    :func:`criterion`: greedy per second, then exchanges (see the module's notes).

    Args:
        infos: per point, the excursions' information (K, D, D).
        lengths: each excursion's length [s].
        budget: the seconds the chain may take.
        on_step: called after each greedy pick and each exchange round (a progress bar).
    Returns:
        The chain (in the order chosen) and its criterion.
    """
    k_count = len(lengths)
    chain: list[int] = []
    totals = [np.zeros(stack.shape[1:]) for stack in infos]
    current = min(logdet(t) for t in totals)
    used = 0.0
    while True:
        best, best_rate, best_value = None, 0.0, current
        for k in range(k_count):
            if used + lengths[k] > budget + 1e-9:
                continue
            value = min(logdet(t + stack[k]) for t, stack in zip(totals, infos))
            rate = (value - current) / lengths[k]
            if rate > best_rate + GAIN_TOL:
                best, best_rate, best_value = k, rate, value
        if best is None:
            break
        chain.append(best)
        for t, stack in zip(totals, infos):
            t += stack[best]
        used += lengths[best]
        current = best_value
        if on_step:
            on_step()
    for _ in range(EXCHANGE_ROUNDS):
        improved = False
        for position in range(len(chain)):
            out = chain[position]
            for k in range(k_count):
                if k == out or used - lengths[out] + lengths[k] > budget + 1e-9:
                    continue
                value = min(logdet(t - stack[out] + stack[k]) for t, stack in zip(totals, infos))
                if value > current + GAIN_TOL:
                    for t, stack in zip(totals, infos):
                        t += stack[k] - stack[out]
                    used += lengths[k] - lengths[out]
                    chain[position], current, out = k, value, k
                    improved = True
        if on_step:
            on_step()
        if not improved:
            break
    return chain, current
