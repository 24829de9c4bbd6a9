"""What both estimators do around the solver: seeds, data subsets, and the best restart.

Sec. IV of the paper runs 100 restarts, each from random initial values and on a
different subset of the data, and shows that they all land on the same estimate. imucal
does the same, refines every restart on all samples, reports the refined result with the
lowest cost, and counts how many restarts reached it.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from .errors import InputError


def resolve_seed(seed: int | None) -> int:
    """``seed`` itself, or a fresh one (recorded in results so the run can be repeated).

    Returns
    -------
    seed : int
        ``seed`` as an int, or a random one in [0, 2^32) when ``seed`` is None.

    Raises
    ------
    InputError
        ``seed`` is negative.
    """
    if seed is None:
        return int(np.random.SeedSequence().generate_state(1, dtype=np.uint32)[0])
    seed = int(seed)
    if seed < 0:
        raise InputError(f"seed must be non-negative, got {seed}")
    return seed


#: Random numbers drawn at once for the subsets (doubles: 32 MiB).
MASK_DRAW_VALUES = 1 << 22


def subset_mask(
    n: int, restarts: int, fraction: float, rng: np.random.Generator
) -> np.ndarray | None:
    """Each restart's random subset of the ``n`` samples, drawn with ``rng``: each sample
    in with probability ``fraction`` (independently: an exact count would need a sort per
    row and buys nothing).

    Returns
    -------
    mask : (restarts, n) float32 or None
        0/1 weights, row r marking restart r's subset; a row that came out empty gets one
        random sample. None when every restart sees all samples (``fraction`` 1).

    Raises
    ------
    InputError
        ``fraction`` is not in (0, 1].

    References
    ----------
    Seel, Schauer, Raisch (2012), "Joint axis and position estimation from inertial
    measurement data by exploiting kinematic constraints", IEEE CCA, Sec. IV (restarts on
    different subsets of the data).
    """
    if not 0 < fraction <= 1:
        raise InputError(f"subset fraction must be in (0, 1], got {fraction}")
    if fraction == 1:
        return None
    # single precision, the restarts' own (no copy for them: 10 000 restarts of 10 000
    # samples held 0.8 GB of float64 weights and their 0.4 GB copy); drawn in blocks of
    # rows, the same numbers as one draw, without its (R, n) doubles at once
    mask = np.empty((restarts, n), dtype=np.float32)
    rows = max(1, MASK_DRAW_VALUES // max(n, 1))
    for start in range(0, restarts, rows):
        stop = min(start + rows, restarts)
        mask[start:stop] = rng.random((stop - start, n)) < fraction
    # a restart needs samples; with tiny n a row could come out empty
    empty = mask.sum(axis=1) == 0
    mask[empty, rng.integers(0, n, size=int(empty.sum()))] = 1.0
    return mask


def best_restart(
    finals: np.ndarray,
    costs: np.ndarray,
    distance: Callable[[np.ndarray, np.ndarray], np.ndarray],
    tolerance: float,
) -> tuple[int, np.ndarray]:
    """The lowest-cost restart and which restarts ended within ``tolerance`` of it.

    ``finals`` (R, s) and ``costs`` (R,) must come from the same data (all samples), so
    the costs are comparable: the lowest one is the least-squares answer, however few
    restarts found it. Non-finite restarts never win and never agree.

    Returns
    -------
    best : int
        Row of the finite restart with the lowest cost.
    reached : (R,) bool
        Finite restarts whose ``distance`` to ``finals[best]`` is <= ``tolerance`` (best
        included).

    Raises
    ------
    InputError
        no restart produced a finite result.
    """
    finite = np.isfinite(costs) & np.isfinite(finals).all(axis=1)
    if not finite.any():
        raise InputError("no restart produced a finite result")
    best = int(np.flatnonzero(finite)[np.argmin(costs[finite])])
    return best, finite & agreeing(finals, best, distance, tolerance)


def agreeing(
    finals: np.ndarray,
    best: int,
    distance: Callable[[np.ndarray, np.ndarray], np.ndarray],
    tolerance: float,
) -> np.ndarray:
    """Which finite restarts ended within ``tolerance`` of restart ``best``.

    Returns
    -------
    reached : (R,) bool
        True where the row of ``finals`` (R, s) is finite and ``distance`` to
        ``finals[best]`` (units of ``tolerance``) is <= ``tolerance``.
    """
    finite = np.isfinite(finals).all(axis=1)
    return finite & (distance(finals, finals[best]) <= tolerance)


#: A restart whose refined RMS residual is within this factor of the best one fits almost
#: as well: if it ended elsewhere, the data do not single out one answer. Restarts in
#: clearly worse local minima (on short simulated circling: 15 x the best RMS) are
#: rejected by their cost and are no reason to doubt the estimate.
COMPETING_RMS_FACTOR = 1.25


def competing_agreement(costs: np.ndarray, reached: np.ndarray) -> float:
    """How many of the competing restarts reached the estimate.

    Returns
    -------
    fraction : float
        In [0, 1]: of the restarts whose RMS residual (sqrt of ``costs`` (R,), mean
        squares on all samples) is within ``COMPETING_RMS_FACTOR`` of the lowest, the
        share marked in ``reached`` (R,).
    """
    rms = _rms(costs)
    competing = rms <= COMPETING_RMS_FACTOR * rms.min()
    return float(np.sum(reached & competing) / max(np.sum(competing), 1))


def settled(subset_costs: np.ndarray, reached: np.ndarray) -> np.ndarray:
    """(R,) restarts that reached the estimate and whose subset fit was not stuck.

    A restart can sit in a local minimum of its subset's cost (on simulated circling:
    40 deg off, at 300 x the typical mean square) and still reach the estimate once
    refined on all samples. Its subset result says nothing about how much the answer
    depends on the data, so the spread leaves it out: kept are the restarts whose subset
    RMS residual is within ``COMPETING_RMS_FACTOR`` of the median of those that reached.

    Returns
    -------
    settled : (R,) bool
        ``reached`` and sqrt(``subset_costs``) <= ``COMPETING_RMS_FACTOR`` x the median of
        the reached ones' (``reached`` itself when none reached).
    """
    rms = _rms(subset_costs)
    if not reached.any():
        return reached
    return reached & (rms <= COMPETING_RMS_FACTOR * np.median(rms[reached]))


def _rms(costs: np.ndarray) -> np.ndarray:
    """RMS residuals from mean-square costs; non-finite costs become infinite."""
    return np.sqrt(np.where(np.isfinite(costs), costs, np.inf))


#: Two minima whose RMS residuals differ by less than this factor fit equally well: the
#: real hip (pelvis - thigh, 55-100 s of the shared recording) has two minima 30 cm apart
#: at 1.01 x, each reached by about half the restarts.
EQUAL_RMS_FACTOR = 1.05


def equal_minima(
    finals: np.ndarray,
    costs: np.ndarray,
    best: int,
    reached: np.ndarray,
    distance: Callable[[np.ndarray, np.ndarray], np.ndarray],
) -> tuple[int, float, float]:
    """Restarts that ended away from the estimate at an equally low cost: not in
    ``reached``, finite, RMS residual (sqrt of ``costs``) within ``EQUAL_RMS_FACTOR`` of
    restart ``best``'s.

    Returns
    -------
    count : int
        How many such restarts there are.
    distance : float
        The largest distance of one of them from ``finals[best]``, units of
        ``distance`` (deg or m); 0 when none.
    rms_ratio : float
        The largest RMS residual ratio to the best among them; 1 when none.
    """
    rms = _rms(costs)
    equal = ~reached & np.isfinite(finals).all(axis=1) & (rms <= EQUAL_RMS_FACTOR * rms[best])
    if not equal.any():
        return 0, 0.0, 1.0
    far = distance(finals[equal], finals[best])
    with np.errstate(invalid="ignore", divide="ignore"):  # a zero residual (no signal)
        ratio = float((rms[equal] / rms[best]).max())
    return int(equal.sum()), float(far.max()), ratio


#: Fewer of the competing restarts than this fraction reaching the estimate is not
#: confident (both estimators).
MIN_AGREEING_FRACTION = 0.8


def disagreement_warning(agreement: float, why: str = "") -> list[str]:
    """The "restarts disagree" warning when fewer than ``MIN_AGREEING_FRACTION`` of the
    competing restarts (:func:`competing_agreement`) reached the estimate; ``why`` adds
    the estimator's likely reason.

    Returns
    -------
    warnings : list of str
        The one warning (``why`` appended), or [] when ``agreement`` reaches
        ``MIN_AGREEING_FRACTION``.
    """
    if agreement >= MIN_AGREEING_FRACTION:
        return []
    return [f"restarts disagree: of the restarts that fit almost as well as the best, only "
            f"{agreement:.0%} reached the estimate: the answer depends on the starting point"
            + why]


def equal_minima_blocking(minima: tuple[int, float, float], sigma: float, floor: float,
                          unit: str, answers: str, answer: str) -> list[str]:
    """The blocking reason for an equally good answer (:func:`equal_minima`) farther from
    the estimate than both the reported 1-sigma ``sigma`` and ``floor`` (``unit``): the
    sigma cannot cover it. ``answers`` / ``answer`` name them ("different axes", "axis").

    Returns
    -------
    blocking : list of str
        The one blocking reason, or [] when there is no equal minimum or it lies within
        max(``sigma``, ``floor``).
    """
    count, far, ratio = minima
    if not count or far <= max(sigma, floor):
        return []
    return [f"two {answers} fit equally well ({count} restarts ended {far:.0f} {unit} from "
            f"the estimate at {ratio:.2f} x its RMS residual): the data do not single out "
            f"one {answer}"]
