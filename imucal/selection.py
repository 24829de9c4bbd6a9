"""Informative-sample selection for long recordings (after Olsson et al. 2020, Sec. 3.4).

Most of a lab recording is standing still or repeating the same stride. Still stretches
add nothing to either constraint (with no rotation, eq. 1 reads 0 = 0 and eq. 3 compares
two readings of gravity), and a hundred identical strides add little over ten: they only
make the fit slower. imucal therefore

1. drops every sample whose windowed angular-rate energy (both sensors, a centred
   ``WINDOW_S`` window) stays below ``MIN_RATE_DEG_S``: the joint did not move there;
2. if more than ``max_samples`` remain, keeps every k-th of them, evenly spread over the
   moving stretches, so all kinds of motion in the recording stay represented.

The selection runs inside the user's window (``--start``/``--end`` win), and when fewer
than ``min_samples`` moving samples exist it keeps the whole window: the estimators'
excitation checks then say that the joint did not move, instead of fitting noise.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.ndimage import uniform_filter1d

#: Length of the centred moving window of the angular-rate energy, s (Olsson et al. use
#: 21 samples at 100 Hz).
WINDOW_S = 0.2
#: A window whose RMS angular rate (over both sensors) is below this did not move, deg/s.
#: Standing sway and gyroscope noise stay below a few deg/s; voluntary leg motion is
#: far faster (tens to hundreds of deg/s).
MIN_RATE_DEG_S = 10.0
#: Default cap on the samples that enter a fit: 3000 well-spread moving samples pin the
#: axis to a small fraction of a degree, and more only cost time (docs/performance.md).
MAX_SAMPLES = 3000
#: Used stretches closer than this are reported as one time range, s.
MERGE_GAP_S = 0.5


@dataclass
class Selection:
    """Which samples a fit uses.

    Attributes
    ----------
    index : (M,) sorted sample indices into the signals passed to :func:`select`.
    moving : (K,) every informative sample before the thinning to ``max_samples`` (the
        same as ``index`` when nothing was thinned): consecutive samples, for what needs
        the residual as a time series (:func:`imucal.quality.smooth_residual_rms`).
    ranges : (K, 2) start and end of each used stretch, s from the first sample passed
        (``start`` inclusive, ``end`` exclusive).
    """

    index: np.ndarray
    ranges: np.ndarray
    moving: np.ndarray


def select(
    gyr1: np.ndarray,
    gyr2: np.ndarray,
    rate: float,
    *,
    max_samples: int | None = MAX_SAMPLES,
    min_samples: int = 0,
    enabled: bool = True,
) -> Selection:
    """Choose informative samples of two sensors' angular rates (N, 3), rad/s, at ``rate`` Hz.

    ``rate`` is the rate of the given samples (after any subsampling). ``max_samples``
    None: no cap. ``enabled`` False keeps every sample (still reported as one range).

    Returns
    -------
    Selection
        ``index`` (M,) sorted sample indices into ``gyr1`` / ``gyr2``: the samples whose
        centred ``WINDOW_S`` RMS rate (both sensors) reaches ``MIN_RATE_DEG_S``, every
        k-th of them when more than ``max_samples`` (k = ceil(count / max_samples), so M
        <= ``max_samples``); ``moving`` (K,) all of them before the thinning; ``ranges``
        (S, 2) [start, end) of their stretches, s from the first sample (stretches less
        than ``MERGE_GAP_S`` apart merged). Every sample (one range) when
        ``enabled`` is False, N is 0, or fewer than max(``min_samples``, 1) samples move.

    References
    ----------
    Olsson, Kok, Seel, Halvorsen (2020), "Robust plug-and-play joint axis estimation
    using inertial sensors", Sensors 20:3534, Sec. 3.4 (informative samples by
    windowed angular-rate energy).

    Examples
    --------
    >>> import numpy as np
    >>> from imucal.selection import select
    >>> g = np.zeros((1000, 3))
    >>> g[300:700, 0] = 1.0  # 10 s at 100 Hz: still, 4 s at 1 rad/s, still
    >>> s = select(g, g, rate=100.0, max_samples=100)
    >>> s.index.size, s.moving.size, s.ranges
    (84, 419, array([[2.91, 7.1 ]]))
    """
    n = gyr1.shape[0]
    everything = np.arange(n)
    if not enabled or n == 0:
        return Selection(everything, _ranges(np.ones(n, bool), rate), everything)
    energy = 0.5 * (np.sum(gyr1 * gyr1, axis=1) + np.sum(gyr2 * gyr2, axis=1))
    width = max(1, int(round(WINDOW_S * rate)))
    windowed = uniform_filter1d(energy, size=width, mode="nearest")
    moving = windowed >= np.radians(MIN_RATE_DEG_S) ** 2
    if int(moving.sum()) < max(min_samples, 1):
        return Selection(everything, _ranges(np.ones(n, bool), rate), everything)
    informative = np.flatnonzero(moving)
    index = informative
    if max_samples is not None and index.size > max_samples:
        index = index[::int(np.ceil(index.size / max_samples))]
    return Selection(index, _ranges(moving, rate), informative)


def _ranges(mask: np.ndarray, rate: float) -> np.ndarray:
    """(K, 2) [start, end) in s of the runs of True in ``mask``."""
    padded = np.concatenate([[False], mask, [False]])
    edges = np.flatnonzero(np.diff(padded.astype(np.int8))).reshape(-1, 2) / rate
    if edges.shape[0] < 2:
        return edges
    gaps = edges[1:, 0] - edges[:-1, 1]
    keep = np.concatenate([[True], gaps >= MERGE_GAP_S])
    starts = edges[keep, 0]
    ends = edges[np.concatenate([keep[1:], [True]]), 1]
    return np.stack([starts, ends], axis=1)
