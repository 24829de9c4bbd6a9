"""Time offset between two sensors' clocks, found from the kinematic constraint itself.

Wireless sensors timestamp with their own clocks; even "synchronised" exports can be
tens of milliseconds apart. Eq. (1) and eq. (3) compare the two sensors at the same
instant, so an offset breaks them: 20 ms wrecks a joint centre and moves a knee axis by
degrees. Both constraints hold only at the right relative shift ``delta``::

    |g1(t) x j1| = |g2(t + delta) x j2|          (hinge)
    |a1(t) - Gamma_1(o1)| = |(a2 - Gamma_2(o2))(t + delta)|   (joint centre)

``delta`` > 0 means the second sensor's clock is late: its samples show the motion
``delta`` seconds after the first sensor's do, so its signal is read at ``t + delta``.
The cost over ``delta`` is smooth near its minimum: a grid of one-sample steps over
+-``search`` finds the basin and a parabola through the lowest grid point and its
neighbours gives the minimum to a fraction of a sample (realism-and-angles-notes.md).
The uncertainty is the delete-one-block jackknife over contiguous time blocks, as for the
estimates themselves (:func:`imucal.quality.block_masks`).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from scipy.interpolate import make_interp_spline

from .quality import block_masks, jackknife_sigma

# the search range and the offset check live with the settings; imported here for the
# callers of their old home
from .settings import OFFSET_SEARCH_S as SEARCH_S  # noqa: F401
from .settings import check_time_offset  # noqa: F401

#: The profile refits use about this many of the samples and this many plain
#: Gauss-Newton steps from the first estimate (an offset of tens of milliseconds moves
#: the estimate a little: the refits start next to their minimum); both estimators.
OFFSET_SAMPLES = 1500
OFFSET_STEPS = 2
#: A shift also lowers the residual a little where the model is wrong rather than the
#: clocks (soft tissue lags the bone; a knee is no perfect hinge): on the shared real
#: recording the knees' best shifts are -31 ms (0-55 s) and -115 ms (55-100 s), which no
#: clock does, at cost ratios of only 1.06-1.41, while a real 20 ms offset on simulated
#: circling or walking gives 2.1-16. An offset is applied only above this ratio.
MIN_COST_RATIO = 1.5
#: A best shift this large, clear of its 1-sigma but not applied, is reported as a warning.
SUSPICIOUS_S = 0.01
#: Grid step of the first pass over the search range, samples.
COARSE_STEP = 4
#: An estimated offset is applied when it exceeds both this fraction of a sample and
#: twice its own 1-sigma: a smaller one changes nothing the estimates could resolve.
MIN_APPLIED_SAMPLES = 0.25


@dataclass(frozen=True)
class Offset:
    """A time offset estimate.

    Attributes
    ----------
    delta_s : the second sensor's clock lateness, s (0 when not estimated).
    sigma_s : its 1-sigma (delete-one-block jackknife), s.
    at_edge : the cost kept falling to the end of the search range: the offset may be
        larger than the search, so ``delta_s`` is not trusted (and not applied).
    search_s : the search range +-, s.
    cost_ratio : cost at zero offset over the cost at ``delta_s`` (1 = no gain).
    """

    delta_s: float
    sigma_s: float
    at_edge: bool
    search_s: float
    cost_ratio: float

    def significant(self, rate: float) -> bool:
        """Worth applying: inside the search, larger than ``MIN_APPLIED_SAMPLES`` of a
        sample and than twice its 1-sigma, and aligning lowers the mean squared residual
        by at least ``MIN_COST_RATIO``."""
        size = abs(self.delta_s)
        return (not self.at_edge and size > MIN_APPLIED_SAMPLES / rate
                and size > 2 * self.sigma_s and self.cost_ratio >= MIN_COST_RATIO)

    def suspicious(self, rate: float) -> bool:
        """Found but not applied, yet large and clear enough to mention."""
        size = abs(self.delta_s)
        return (not self.significant(rate) and not self.at_edge
                and size >= SUSPICIOUS_S and size > 2 * self.sigma_s)


def shifted(x: np.ndarray, rate: float, delta: float) -> np.ndarray:
    """``x`` (N, ...) sampled at ``rate`` Hz, read at t + ``delta`` s by a cubic spline
    (times beyond the ends are held at the ends)."""
    if delta == 0:
        return x
    n = x.shape[0]
    t = np.arange(n) / rate
    spline = make_interp_spline(t, x, k=3, axis=0)
    return spline(np.clip(t + delta, 0.0, t[-1]))


def estimate_offset(residuals: Callable[[np.ndarray], np.ndarray], rate: float,
                    search: float = SEARCH_S) -> Offset:
    """Minimise the profile cost: for candidate offsets on a grid of one-sample steps
    over +-``search`` s, ``residuals(deltas)`` (D,) refits the estimate with the second
    sensor read at t + delta, for every delta at once, and returns the (D, M) residuals
    (the same M samples, in time order, for every delta).

    Refitting matters: at a fixed estimate the cost barely sees the offset, because the
    first fit, made with the wrong alignment, has already absorbed most of it (simulated
    circling, shank 20 ms late: the axis moves 3.9 deg and a fixed-axis search finds
    1.3 ms).
    """
    steps = max(1, int(np.floor(search * rate)))
    # coarse grid first, then one-sample steps around its lowest point: the profile is
    # smooth, and each point costs a refit
    half = np.unique(np.concatenate([np.arange(0, steps + 1, COARSE_STEP), [steps]]))
    coarse = np.unique(np.concatenate([-half, half]))  # symmetric, with 0 and both ends
    costs = dict(zip(coarse.tolist(), np.square(residuals(coarse / rate)), strict=True))
    low = min(costs, key=lambda k: costs[k].mean())
    at_edge = low in (-steps, steps)
    fine = np.arange(max(-steps, low - COARSE_STEP), min(steps, low + COARSE_STEP) + 1)
    todo = np.array([k for k in fine.tolist() if k not in costs])
    if todo.size:
        costs.update(zip(todo.tolist(), np.square(residuals(todo / rate)), strict=True))
    table = np.stack([costs[int(k)] for k in fine])  # (D, M) on the one-sample grid
    deltas = fine / rate
    if not np.isfinite(table).all() or table.shape[1] < 20:
        return Offset(0.0, float("inf"), False, float(search), 1.0)
    masks = block_masks(table.shape[1])
    # mean square per delta over all samples, then with each block left out
    whole = table.mean(axis=1)
    parts = (table @ masks.T) / masks.sum(axis=1)
    best = _parabola_minimum(whole, deltas)[0]
    left_out = np.array([_parabola_minimum(parts[:, k], deltas)[0]
                         for k in range(masks.shape[0])])
    sigma = jackknife_sigma(left_out - best)
    zero = costs[0].mean()  # 0 is on the coarse grid
    ratio = float(zero / max(whole.min(), 1e-300))
    return Offset(float(best), sigma, bool(at_edge), float(search), ratio)


def reader(x: np.ndarray, rate: float) -> Callable[[np.ndarray], np.ndarray]:
    """``times -> x(times)``: ``x`` (N, ...) sampled at ``rate`` Hz as a cubic spline of
    time in s (times beyond the ends held at the ends)."""
    t = np.arange(x.shape[0]) / rate
    spline = make_interp_spline(t, x, k=3, axis=0)
    return lambda times: spline(np.clip(times, 0.0, t[-1]))


def fit_with_offset(fit, profile, rate: float, search: float):
    """The "auto" clock offset around any estimator.

    ``fit(seconds)`` runs the estimator with the second sensor read at
    t + seconds; ``profile(first)`` returns the ``residuals(deltas)`` function of
    :func:`estimate_offset` around the first, synchronised fit. Fits again with the
    offset where it is significant (:meth:`Offset.significant`) and records it in the
    result's ``time_offset``, ``settings`` and ``warnings``.
    """
    first = fit(0.0)
    found = estimate_offset(profile(first), rate, search)
    result = fit(found.delta_s) if found.significant(rate) else first
    result.time_offset = offset_report(found, rate)
    result.settings["time_offset"] = "auto"
    result.warnings.extend(offset_warnings(found, rate))
    return result


def offset_report(found: Offset, rate: float) -> dict:
    """The ``time_offset`` block of a result estimated with "auto"."""
    applied = found.significant(rate)
    return {"mode": "auto", "time_offset_s": found.delta_s if applied else 0.0,
            "estimated_s": found.delta_s, "sigma_s": found.sigma_s, "applied": applied,
            "cost_ratio": found.cost_ratio, "search_s": found.search_s,
            "at_edge": found.at_edge}


def offset_warnings(found: Offset, rate: float) -> list[str]:
    """What to say about an automatic offset that was not applied."""
    if found.at_edge:
        return [offset_edge_warning(found)]
    if found.suspicious(rate):
        return [f"the residual is lowest with the second sensor read {1000 * found.delta_s:+.0f} "
                f"ms later (+-{1000 * found.sigma_s:.0f} ms), but that lowers it only by a "
                f"factor {found.cost_ratio:.2f}: a clock offset or a model error (soft "
                "tissue, not a hinge); not applied. Check the synchronisation, or pass the "
                "offset with --time-offset"]
    return []


def offset_edge_warning(found: Offset) -> str:
    """The warning for an offset that may lie beyond the search range."""
    return (f"the clock offset between the sensors may exceed the +-{found.search_s:g} s "
            "searched (the constraint's cost kept falling to the edge): none was applied; "
            "align the recordings first or widen the search")


def _parabola_minimum(cost: np.ndarray, deltas: np.ndarray) -> tuple[float, bool]:
    """Sub-sample minimum of ``cost`` over the grid ``deltas``; True when the lowest point
    is at an end of the grid (the minimum may lie beyond it)."""
    k = int(np.argmin(cost))
    if k == 0 or k == cost.size - 1:
        return float(deltas[k]), True
    c0, c1, c2 = cost[k - 1], cost[k], cost[k + 1]
    curvature = c0 - 2 * c1 + c2
    step = deltas[1] - deltas[0]
    shift = 0.5 * (c0 - c2) / curvature if curvature > 0 else 0.0
    return float(deltas[k] + np.clip(shift, -0.5, 0.5) * step), False
