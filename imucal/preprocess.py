"""Signal preparation shared by both estimators: low-pass, derivative, window, subsample,
and the ``prepare`` stage that applies them (:func:`prepare`).

The defaults follow Sec. III-B and IV of Seel, Schauer, Raisch (2012): a non-causal
(zero-phase) low-pass filter, a difference quotient for the angular acceleration
``gdot``, and using only every k-th sample because neighbouring samples of slow human
motion carry almost the same information. docs/method.md explains the choices.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from functools import lru_cache

import numpy as np
from scipy import signal

from .errors import InputError
from .quality import STILL_REASON, is_still, smooth_residual_rms
from .recording import window_slice
from .selection import Selection
from .selection import select as select_samples
from .sensor_checks import (
    ACC_LOOKS_LIKE_G,
    ACC_PLAUSIBLE,
    MAX_LIMB_RATE,
    SENSOR_RANGE,
    acc_scale_doubt,
    corrupt_readings,
)
from .settings import as_real
from .time_offset import shifted

#: Default low-pass cut-off in Hz. Voluntary leg motion (circling, gait) has almost all
#: its energy below 6 Hz; 10 Hz keeps it and removes sensor noise and soft-tissue ringing.
DEFAULT_CUTOFF_HZ = 10.0
#: The cut-off never exceeds this fraction of the sample rate (0.8 of Nyquist).
MAX_CUTOFF_FRACTION = 0.4
#: Butterworth order of one pass; filtfilt runs it twice (zero phase, double the order).
FILTER_ORDER = 2
#: The joint-centre fit's filter: eq. (3) is quadratic in the rates, so a filter that
#: attenuates the motion's own band by a few percent biases the centre (second order at
#: 10 Hz: 5-22 mm on simulated walking and protocol, from 1-6 % lost at 3-6 Hz). A fourth
#: order one pass (eighth after filtfilt) at 12 Hz keeps 0-6 Hz within 0.1 %: 0.2-1.8 mm.
JOINT_FILTER_ORDER = 4
JOINT_CUTOFF_HZ = 12.0
#: Automatic subsampling keeps about this many samples per cut-off period: filtered
#: samples closer than 1 / (2.5 * cutoff) are strongly correlated and add little.
SAMPLES_PER_CUTOFF_PERIOD = 2.5
#: A sensor whose RMS angular rate stays below this is called still: voluntary limb
#: motion is far faster, gyroscope noise and drift far slower.
STILL_RATE_DEG_S = 5.0


def rms_rate_deg_s(gyr: np.ndarray) -> float:
    """RMS of the angular-rate norm of ``gyr`` (N, 3) rad/s, in deg/s.

    Returns
    -------
    float
        sqrt(mean |g|^2) over the N samples, deg/s (NaN for N = 0).

    Examples
    --------
    >>> import numpy as np
    >>> from imucal.preprocess import rms_rate_deg_s
    >>> rms_rate_deg_s(np.tile([0.0, 0.0, np.pi], (10, 1)))  # pi rad/s about z
    180.0
    """
    return float(np.degrees(np.sqrt(np.mean(np.sum(gyr * gyr, axis=1)))))


class UnitDoubt(str):
    """A warning of :func:`unit_doubts` (a str like the others): kept where a recording
    without motion drops the fit's other warnings (:func:`only_the_stillness`), since a
    unit mistake can be why it looks still."""


def only_the_stillness(result):
    """``result`` with no warnings beside its refusal when that is a recording without
    motion (:data:`STILL_REASON`): a poor fit, an uncertain estimate, a clock offset or
    an axis that is no line mean nothing without motion, and a reader met them before
    the reason (a standing-still recording warned to check the synchronisation first: a
    new-user trial). Doubts about the units (:class:`UnitDoubt`) stay: a mis-scaled
    sensor can be why. ``result.blocking`` keeps the reason.

    Returns
    -------
    AxisResult or PositionResult
        ``result`` itself, its ``warnings`` reduced to its unit doubts where the first
        blocking reason is :data:`imucal.quality.STILL_REASON`'s, and a second copy of
        that reason (a knee centre's axis's) dropped from ``blocking``.
    """
    if is_still(result.blocking):
        result.warnings = [w for w in result.warnings if isinstance(w, UnitDoubt)]
        # a knee centre carries its axis's reasons ("axis: ..."): the same one, judged on
        # the axis's samples, came second with other rates (an independent review)
        result.blocking = result.blocking[:1] + [b for b in result.blocking[1:]
                                                 if not is_still([b])]
    return result


def stillness_warning(gyr1: np.ndarray, gyr2: np.ndarray) -> list[str]:
    """A warning when either sensor barely rotates (nothing to estimate from), else [].

    Returns
    -------
    list of str
        One warning giving both RMS rates (deg/s) when either is below
        ``STILL_RATE_DEG_S``, else [].
    """
    rates = (rms_rate_deg_s(gyr1), rms_rate_deg_s(gyr2))
    if min(rates) >= STILL_RATE_DEG_S:
        return []
    # which one: "RMS rate 123.9 and 0.0 deg/s, below 5" left a dead foot to be guessed
    if max(rates) < STILL_RATE_DEG_S:
        which = f"both: RMS rates {rates[0]:.1f} and {rates[1]:.1f} deg/s"
    else:
        still, moving = ("first", "second") if rates[0] < rates[1] else ("second", "first")
        which = (f"the {still} sensor: RMS rate {min(rates):.1f} deg/s, the {moving} "
                 f"{max(rates):.1f}")
    return [
        f"{STILL_REASON} ({which}; below {STILL_RATE_DEG_S:g} deg/s): the "
        "recording holds no motion to estimate from"
    ]


def default_cutoff(rate: float) -> float:
    """Default low-pass cut-off in Hz for a sample rate ``rate`` in Hz.

    Returns
    -------
    float
        ``DEFAULT_CUTOFF_HZ`` (10 Hz), at most ``MAX_CUTOFF_FRACTION`` (0.4) x ``rate``, Hz.

    Examples
    --------
    >>> from imucal.preprocess import default_cutoff
    >>> default_cutoff(100.0), default_cutoff(20.0)
    (10.0, 8.0)
    """
    return min(DEFAULT_CUTOFF_HZ, MAX_CUTOFF_FRACTION * rate)


def default_joint_cutoff(rate: float) -> float:
    """Highest cut-off of the joint-centre fit's filter, Hz (:data:`JOINT_CUTOFF_HZ`).

    Returns
    -------
    float
        ``JOINT_CUTOFF_HZ`` (12 Hz), at most ``MAX_CUTOFF_FRACTION`` (0.4) x ``rate``, Hz.
    """
    return min(JOINT_CUTOFF_HZ, MAX_CUTOFF_FRACTION * rate)


#: The spectral cut-off sits at this multiple of the frequency below which
#: ``MOTION_POWER`` of the angular rates' power lies: a flat filter there keeps the motion
#: and drops the noise above it (circling: about 4-6 Hz, walking: 12 Hz). At twice the
#: frequency the filter's edge still took 2 % off walking's 6th harmonic (3-7 mm).
CUTOFF_PER_MOTION_FREQUENCY = 3.0
MOTION_POWER = 0.99
#: The spectral cut-off never goes below this, Hz.
MIN_JOINT_CUTOFF_HZ = 4.0


def spectral_cutoff(gyr: tuple, rate: float) -> float:
    """Cut-off for the joint-centre filter from the recording's spectrum, Hz.

    ``gyr``: the sensors' (N, 3) rates, rad/s (N may differ); ``rate`` in Hz. Welch power
    spectra of all components (mean removed) are summed.

    Returns
    -------
    float
        The frequency below which :data:`MOTION_POWER` of the power lies, times
        :data:`CUTOFF_PER_MOTION_FREQUENCY`, clipped to [:data:`MIN_JOINT_CUTOFF_HZ`,
        :func:`default_joint_cutoff`], Hz; :func:`default_joint_cutoff` itself when the
        shortest signal has fewer than 64 samples or no power.
    """
    top = default_joint_cutoff(rate)
    n = min(g.shape[0] for g in gyr)
    if n < 64:
        return top
    # sensors of one length in one call: its cost is mostly per segment, not per channel
    total = 0.0
    for length in sorted({g.shape[0] for g in gyr}):
        centred = np.concatenate([g - g.mean(axis=0) for g in gyr if g.shape[0] == length],
                                 axis=1)
        freqs, power = signal.welch(centred, fs=rate, nperseg=min(n, 4 * int(rate)), axis=0)
        total = total + power.sum(axis=1)
    cumulative = np.cumsum(total)
    if cumulative[-1] <= 0:
        return top
    f_motion = freqs[np.searchsorted(cumulative, MOTION_POWER * cumulative[-1])]
    return float(np.clip(CUTOFF_PER_MOTION_FREQUENCY * f_motion, min(MIN_JOINT_CUTOFF_HZ, top),
                         top))


def default_subsample(rate: float, cutoff: float | None) -> int:
    """Default step k (use every k-th sample) for ``rate`` Hz after a ``cutoff`` Hz low-pass.

    Returns
    -------
    int
        floor(``rate`` / (``SAMPLES_PER_CUTOFF_PERIOD`` x ``cutoff``)), at least 1; 1 when
        ``cutoff`` is None or <= 0 (no filter).

    References
    ----------
    Seel, Schauer, Raisch (2012), "Joint axis and position estimation from inertial
    measurement data by exploiting kinematic constraints", IEEE CCA, Sec. III-B (every third
    to tenth sample suffices).

    Examples
    --------
    >>> from imucal.preprocess import default_subsample
    >>> default_subsample(100.0, 10.0), default_subsample(100.0, None)
    (4, 1)
    """
    if cutoff is None or cutoff <= 0:
        return 1
    return max(1, int(rate // (SAMPLES_PER_CUTOFF_PERIOD * cutoff)))


def resolve_subsample(rate: float, cutoff: float | None, subsample: int | None) -> int:
    """``subsample`` checked, or :func:`default_subsample` when it is None.

    Returns
    -------
    int
        The step k >= 1 (use every k-th sample).

    Raises
    ------
    InputError
        ``subsample`` is no whole number of at least 1 (2.5 was taken as 2: a review).
    """
    if subsample is None:
        return default_subsample(rate, cutoff)
    number = as_real(subsample)
    if number is None or number < 1 or number != int(number):
        raise InputError(f"subsample must be a positive integer, got {subsample!r}")
    return int(number)


def _pandas_missing(arr: np.ndarray) -> np.ndarray:
    """Where an object array holds pandas' missing value (``pd.NA``, of type ``NAType``),
    without importing pandas for it."""
    return np.vectorize(lambda v: type(v).__name__ == "NAType", otypes=[bool])(arr)


def check_pair(a, b, kind: str = "gyr") -> tuple[np.ndarray, np.ndarray]:
    """Two sensors' (N, 3) arrays of ``kind`` ("gyr", rad/s, or "acc", m/s^2) as finite
    float64 of equal length, else InputError.

    Readings that are no measurement (:func:`imucal.sensor_checks.corrupt_readings`) are
    refused with their sample: passed straight to an estimator (a recording treats them
    as missing), one corrupt 1e20 reading overflowed the single-precision restarts into
    "no restart produced a finite result", and one of 1e3 rad/s made a good axis "not
    identifiable".

    Returns
    -------
    a, b : (N, 3) float64
        The two arrays, converted (new arrays).

    Raises
    ------
    InputError
        An array is ragged, not real numbers (complex, text, booleans, objects), not
        (N, 3), holds NaN or Inf or a reading beyond any body-worn sensor's range
        (:data:`imucal.sensor_checks.SENSOR_RANGE`; the first one and its sample named),
        or the two differ in length.
    """
    arrays = []
    for name, arr in (("first", a), ("second", b)):
        try:
            arr = np.asarray(arr)
        except (ValueError, TypeError):  # ragged lists
            raise InputError(f"{name} sensor's data is not an (N, 3) array of numbers") from None
        if arr.dtype.kind == "O":  # numbers as objects (pandas' nullable Float64)
            try:  # (its missing value, pd.NA, is NaN here: "not numbers" misnamed it)
                arr = np.where(_pandas_missing(arr), np.nan, arr).astype(np.float64)
            except (ValueError, TypeError):
                pass
        if arr.dtype.kind not in "iuf":
            got = {"c": "complex numbers", "U": "text", "S": "text", "b": "booleans"}.get(
                arr.dtype.kind, "values that are not numbers")
            raise InputError(f"{name} sensor's data must be real numbers, got {got}")
        arr = arr.astype(np.float64)
        if arr.ndim != 2 or arr.shape[1] != 3:
            raise InputError(f"{name} sensor's data has shape {arr.shape}, expected (N, 3)")
        if not np.isfinite(arr).all():
            raise InputError(f"{name} sensor's data contains NaN or Inf")
        big = np.flatnonzero(corrupt_readings(arr, kind))
        if big.size:
            unit = "rad/s" if kind == "gyr" else "m/s^2"
            raise InputError(
                f"{name} sensor's {kind}: {big.size} reading(s) beyond any body-worn sensor's "
                f"range ({SENSOR_RANGE[kind]:g} {unit}), the first "
                f"{np.abs(arr[big[0]]).max():.6g} at sample {big[0]}: not a physical reading "
                "(a corrupt packet?); repair or drop it (a recording from "
                "imucal.make_recording treats such readings as missing)")
        arrays.append(arr)
    a, b = arrays
    if a.shape != b.shape:
        raise InputError(f"sensors have different lengths ({a.shape[0]} and {b.shape[0]})")
    return a, b


#: Lowest cut-off as a fraction of the rate: far below it the filter's poles sit on 1 to
#: machine precision and its initial state cannot be solved for (1e-9 Hz at 100 Hz raised
#: numpy's LinAlgError); 1e-8 still worked.
MIN_CUTOFF_FRACTION = 1e-6


def lowpass(x: np.ndarray, rate: float, cutoff: float | None,
            order: int = FILTER_ORDER) -> np.ndarray:
    """Zero-phase Butterworth low-pass of ``x`` (N, ...) along time (axis 0), sampled at
    ``rate`` Hz; ``cutoff`` in Hz, None or 0: none. ``order`` is that of one pass
    (filtfilt doubles it).

    Short signals are padded less, so any N >= 2 works.

    Returns
    -------
    ndarray, float64, the shape of ``x``
        The filtered signal (scipy's ``sosfiltfilt``), in the units of ``x``; ``x`` as
        float64 when there is no filter.

    Raises
    ------
    InputError
        ``cutoff`` is negative or NaN, not below half of ``rate``, or too low to filter at
        ``rate``.

    References
    ----------
    Seel, Schauer, Raisch (2012), "Joint axis and position estimation from inertial
    measurement data by exploiting kinematic constraints", IEEE CCA, Sec. III-B (a
    non-causal low-pass before the derivative).
    """
    if cutoff is None or cutoff == 0:
        return np.asarray(x, dtype=np.float64)
    if not cutoff > 0:
        raise InputError(f"cut-off must be a positive number of Hz (or 0: no filter), got {cutoff}")
    if cutoff >= rate / 2:
        raise InputError(
            f"cut-off {cutoff:g} Hz must be below half the sample rate ({rate / 2:g} Hz)"
        )
    if cutoff < MIN_CUTOFF_FRACTION * rate:
        raise InputError(f"cut-off {cutoff:g} Hz is too low to filter at {rate:g} Hz (at "
                         f"least {MIN_CUTOFF_FRACTION * rate:g} Hz; 0: no filter)")
    # a copy: scipy's filter wants a writable array, and the cached one must not change
    sos = _butterworth(int(order), float(cutoff), float(rate)).copy()
    padlen = min(x.shape[0] - 1, 3 * (2 * len(sos) + 1) * 4)
    return signal.sosfiltfilt(sos, x, axis=0, padlen=padlen)


#: Central-difference weights of 8th order for the first derivative (x[t-4] ... x[t+4]).
#: The 2-point central difference np.gradient uses loses 10 % of a 5 Hz component at
#: 40 Hz (sin(wT)/(wT)), which biased the simulated ankle centre by 3-4 mm; this stencil
#: loses 0.02 %.
DERIVATIVE_STENCIL = np.array([1 / 280, -4 / 105, 1 / 5, -4 / 5, 0.0, 4 / 5, -1 / 5, 4 / 105,
                               -1 / 280])


@lru_cache(maxsize=64)
def _butterworth(order: int, cutoff: float, rate: float) -> np.ndarray:
    """Second-order sections of a Butterworth low-pass. Cached: designing one costs about
    as much as filtering 10 s of three channels, and every estimate filters at the same
    few cut-offs (fit, sign tests, sensitivity refits)."""
    return signal.butter(order, cutoff, fs=rate, output="sos")


def derivative(x: np.ndarray, rate: float) -> np.ndarray:
    """Time derivative of ``x`` (N, ...) sampled at ``rate`` Hz, by an 8th-order central
    difference (:data:`DERIVATIVE_STENCIL`; np.gradient's differences within 4 samples of
    the ends).

    Returns
    -------
    ndarray, float64, the shape of ``x``
        d``x``/dt in the units of ``x`` per second (rad/s -> rad/s^2).

    Examples
    --------
    >>> import numpy as np
    >>> from imucal.preprocess import derivative
    >>> derivative(0.5 * np.arange(20.0), rate=100.0)[:3]  # 0.5 per sample at 100 Hz
    array([50., 50., 50.])
    """
    out = np.gradient(x, 1.0 / rate, axis=0)
    n = x.shape[0]
    if n > 8:
        inner = np.zeros_like(out[4:n - 4])
        for k, c in enumerate(DERIVATIVE_STENCIL):
            if c:
                inner += c * x[k:n - 8 + k]
        out[4:n - 4] = inner * rate
    return out


def unit_doubts(gyr: tuple, acc: tuple = ()) -> list[str]:
    """Reasons to believe the rates are not rad/s or the specific forces not m/s^2.

    A limb does not turn at more than :data:`imucal.sensor_checks.MAX_LIMB_RATE` rad/s for 1 %
    of the time (deg/s read as rad/s: 57 times faster), and at rest or in gait the median
    specific force is about 1 g = 9.81 m/s^2, not 1 (g read as m/s^2), nor below 0.5 or
    above 50 m/s^2 (:data:`imucal.sensor_checks.ACC_PLAUSIBLE`: a unit 100-1000 x off). The
    rates' scale does not change a hinge axis, but both scales enter the joint position.

    Returns
    -------
    list of str
        One plain-language doubt per sensor and signal that looks mis-scaled, naming the
        sensor ("the first sensor", "the second sensor") and the number; [] when all look
        right.
    """
    doubts = []
    which = ("the first sensor", "the second sensor")  # as --sensors names them
    for k, g in zip(which, gyr, strict=False):
        fast = float(np.percentile(np.sqrt(np.sum(g * g, axis=1)), 99))
        if fast > MAX_LIMB_RATE:
            doubts.append(UnitDoubt(
                f"{k}'s angular rate exceeds {fast:.0f} rad/s 1 % of the time, faster than a "
                f"limb turns (< {MAX_LIMB_RATE:g} rad/s): the gyroscope data look like deg/s "
                "read as rad/s"))
    for k, a in zip(which, acc, strict=False):
        median = float(np.median(np.sqrt(np.sum(a * a, axis=1))))
        if ACC_LOOKS_LIKE_G[0] <= median <= ACC_LOOKS_LIKE_G[1]:
            doubts.append(UnitDoubt(
                f"{k}'s specific force has a median norm of {median:.2f} m/s^2, about 1 g in "
                "g units: the accelerometer data look like g read as m/s^2"))
        elif not ACC_PLAUSIBLE[0] <= median <= ACC_PLAUSIBLE[1]:
            doubts.append(UnitDoubt(f"{k}'s specific force {acc_scale_doubt(median)}"))
    return doubts


@dataclass
class Prepared:
    """The ``prepare`` stage's output: the samples a fit uses and where they came from.

    Attributes
    ----------
    first, second : each sensor's full-length signals as given (the second's read at
        t + the time offset), e.g. (gyr, acc), for what needs more than the fit's samples
        (sign tests, cut-off refits).
    data : the per-sample arrays entering the fit, the first sensor's then the second's,
        (M, 3) each: filtered, windowed, subsampled and selected.
    rate : sample rate of the recording, Hz.
    cutoff : low-pass cut-off used, Hz (0: none).
    step : subsampling step k.
    window : the recording's window as a slice of samples.
    selection : the informative samples chosen, indices into the subsampled window.
    windowed : the arrays of ``data`` at every sample of the window (filtered and
        subsampled, before the selection), for :attr:`moving`.
    """

    first: tuple
    second: tuple
    data: tuple
    rate: float
    cutoff: float
    step: int
    window: slice
    selection: Selection
    windowed: tuple

    @property
    def samples(self) -> int:
        """M, the number of samples entering the fit."""
        return self.data[0].shape[0]

    @property
    def moving(self) -> tuple:
        """The arrays of ``data`` at every informative sample before the thinning to
        ``max_samples`` (``selection.moving``; ``data`` itself when nothing was thinned),
        for what needs the residual as a time series at ``rate / step``. Gathered on
        demand: only :meth:`smooth_residual` reads it."""
        if self.selection.moving.size == self.selection.index.size:
            return self.data
        return tuple(x[self.selection.moving] for x in self.windowed)

    def smooth_residual(self, e: np.ndarray, residual: Callable[..., np.ndarray]) -> float:
        """The residual's smooth part over every moving sample
        (:func:`imucal.quality.smooth_residual_rms` at ``rate / step``): ``e``, the
        residual at ``data``, where nothing was thinned, else ``residual(*moving)``. Not on
        the fit's thinned samples: tenths of a second apart (a long recording), gait and
        soft tissue alias into each other (180 s of simulated gait: a model term of 0
        deg, "good" 18 sigma off).

        Returns
        -------
        float
            RMS of the smooth part, in the unit of ``e``.
        """
        moving = self.moving
        return smooth_residual_rms(e if moving is self.data else residual(*moving),
                                   self.rate / self.step)

    @property
    def sample_index(self) -> np.ndarray:
        """(M,) index of each sample used in the recording passed in."""
        return self.window.start + self.selection.index * self.step

    @property
    def span_s(self) -> tuple[float, float]:
        """(start, end) of the window, s from the first sample."""
        return self.window.start / self.rate, self.window.stop / self.rate

    @property
    def time_ranges(self) -> np.ndarray:
        """(K, 2) stretches the selection used, s from the first sample."""
        return self.window.start / self.rate + self.selection.ranges * 1.0


def prepare(first: tuple, second: tuple, rate: float, settings, *,
            cutoff: float | Callable[[np.ndarray, np.ndarray], float],
            fit_signals: Callable[[tuple, float], list[tuple]], min_samples: int,
            what: str) -> Prepared:
    """The ``prepare`` stage of every estimator: the second sensor's clock offset
    applied, the window cut, the signals filtered by ``fit_signals((first, second),
    cutoff)`` (one tuple of arrays per sensor; on the whole recording first, so the window
    has no filter transients), subsampled and the informative samples selected
    (:mod:`imucal.selection`, on the gyroscopes: the first array of each sensor's tuple).

    ``first``, ``second``: each sensor's full-length (N, 3) signals; ``rate``: Hz;
    ``settings``: an :class:`imucal.settings.AxisSettings` or
    :class:`imucal.settings.PositionSettings` with a number for ``time_offset`` (s);
    ``cutoff``: the cut-off to use, Hz, or a rule giving it from both gyroscopes' windows
    (after the offset); ``min_samples``: the fewest samples the estimate needs; ``what``
    names the estimate in messages.

    Returns
    -------
    Prepared
        The fit's samples ``data`` (the first sensor's arrays, then the second's, (M, 3)
        each), the full-length signals ``first``, ``second`` (the second's read at t +
        the offset), ``cutoff`` (Hz), ``step``, the ``window`` slice and the
        ``selection``.

    Raises
    ------
    InputError
        Fewer than ``min_samples`` samples given, or left after window, offset edges,
        subsampling and selection; also (from the helpers) a window outside the recording
        or an invalid ``subsample``.
    """
    if settings.time_offset:  # the second sensor read at t + offset, over the whole recording
        second = tuple(None if x is None else shifted(x, rate, settings.time_offset)
                       for x in second)
    n_all = first[0].shape[0]
    if n_all < min_samples:  # (before the filters: their derivative needs a few samples)
        raise InputError(f"only {n_all} sample{'' if n_all == 1 else 's'} given; the {what} "
                         f"needs at least {min_samples} (about {min_samples / rate:.1f} s of "
                         "motion)")
    win = window_slice(n_all, rate, settings.start, settings.end)
    if settings.time_offset:
        # within the offset of either end the second sensor read at t + offset is no
        # recorded motion (the reading holds the end values): those samples stay out
        edge = int(np.ceil(abs(settings.time_offset) * rate)) + 1
        first_in = max(win.start, edge)
        win = slice(first_in, max(first_in, min(win.stop, n_all - edge)))
    if callable(cutoff):
        cutoff = cutoff(first[0][win], second[0][win])
    step = resolve_subsample(rate, cutoff, settings.subsample)
    parts = [tuple(x[win][::step] for x in sensor)
             for sensor in fit_signals((first, second), cutoff)]
    sel = select_samples(parts[0][0], parts[1][0], rate / step,
                         max_samples=settings.max_samples, min_samples=min_samples,
                         enabled=settings.select)
    windowed = (*parts[0], *parts[1])
    data = tuple(x[sel.index] for x in windowed)
    n = data[0].shape[0]
    if n < min_samples:
        every = f" (one sample in {step}, from the cut-off or --subsample)" if step > 1 else ""
        offset = (f" and the time offset ({settings.time_offset:g} s: {edge / rate:g} s left "
                  "out at each end)" if settings.time_offset else "")
        raise InputError(
            f"only {n} sample{'' if n == 1 else 's'} left after window{offset} and "
            f"subsampling{every}; the {what} needs at least {min_samples} (about "
            f"{min_samples * step / rate:.1f} s of motion)"
        )
    return Prepared(first, second, data, rate, cutoff, step, win, sel, windowed)
