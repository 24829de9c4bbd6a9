"""Signal preparation shared by both estimators: low-pass, derivative, window, subsample.

The defaults follow Sec. III-B and IV of Seel, Schauer, Raisch (2012): a non-causal
(zero-phase) low-pass filter, a difference quotient for the angular acceleration
``gdot``, and using only every k-th sample because neighbouring samples of slow human
motion carry almost the same information. docs/method.md explains the choices.
"""

from __future__ import annotations

import numpy as np
from scipy import signal

from .errors import InputError

#: Default low-pass cut-off in Hz. Voluntary leg motion (circling, gait) has almost all
#: its energy below 6 Hz; 10 Hz keeps it and removes sensor noise and soft-tissue ringing.
DEFAULT_CUTOFF_HZ = 10.0
#: The cut-off never exceeds this fraction of the sample rate (0.8 of Nyquist).
MAX_CUTOFF_FRACTION = 0.4
#: Butterworth order of one pass; filtfilt runs it twice (zero phase, double the order).
FILTER_ORDER = 2
#: Automatic subsampling keeps about this many samples per cut-off period: filtered
#: samples closer than 1 / (2.5 * cutoff) are strongly correlated and add little.
SAMPLES_PER_CUTOFF_PERIOD = 2.5


def default_cutoff(rate: float) -> float:
    """Default low-pass cut-off in Hz for a sample rate ``rate`` in Hz."""
    return min(DEFAULT_CUTOFF_HZ, MAX_CUTOFF_FRACTION * rate)


def default_subsample(rate: float, cutoff: float | None) -> int:
    """Default step k (use every k-th sample) for ``rate`` Hz after a ``cutoff`` Hz low-pass."""
    if cutoff is None or cutoff <= 0:
        return 1
    return max(1, int(rate // (SAMPLES_PER_CUTOFF_PERIOD * cutoff)))


def lowpass(x: np.ndarray, rate: float, cutoff: float | None) -> np.ndarray:
    """Zero-phase Butterworth low-pass of ``x`` (N, ...) along time; ``cutoff`` None: no filter.

    Short signals are padded less, so any N >= 2 works.
    """
    if cutoff is None or cutoff <= 0:
        return np.asarray(x, dtype=np.float64)
    if cutoff >= rate / 2:
        raise InputError(f"cut-off {cutoff:g} Hz must be below half the sample rate ({rate:g} Hz)")
    sos = signal.butter(FILTER_ORDER, cutoff, fs=rate, output="sos")
    padlen = min(x.shape[0] - 1, 3 * (2 * len(sos) + 1) * 4)
    return signal.sosfiltfilt(sos, x, axis=0, padlen=padlen)


def derivative(x: np.ndarray, rate: float) -> np.ndarray:
    """Time derivative of ``x`` (N, ...) by central differences (one-sided at the ends)."""
    return np.gradient(x, 1.0 / rate, axis=0)


def window_slice(n: int, rate: float, start: float | None, end: float | None) -> slice:
    """Sample slice for the window [start, end) in seconds from the first sample."""
    duration = n / rate
    s = 0.0 if start is None else float(start)
    e = duration if end is None else float(end)
    if not (np.isfinite(s) and np.isfinite(e)):
        raise InputError(f"window start/end must be finite numbers of seconds, got {s}, {e}")
    if s < 0 or s >= duration:
        raise InputError(f"window start {s:g} s lies outside the recording (0 to {duration:g} s)")
    if e <= s:
        raise InputError(f"window end {e:g} s must be after its start {s:g} s")
    i0 = int(round(s * rate))
    i1 = min(n, int(round(e * rate)))
    return slice(i0, i1)
