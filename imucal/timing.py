"""Sample rates and time stamps: the plausible rates of body-worn sensors, the rate a
time column gives, and the checks of a time column (regular sampling within a jitter
tolerance, no resampling, drift against a given rate)."""

from __future__ import annotations

import math

import numpy as np

from .errors import InputError
from .settings import as_real, is_bool

#: Plausible sample rates of body-worn IMUs, Hz.
MIN_RATE_HZ = 1.0
MAX_RATE_HZ = 10_000.0
#: Largest relative deviation of one sampling interval from the median interval that is
#: still treated as regular sampling (timestamps of wireless sensors jitter a little).
#: Beyond it loading stops: imucal never resamples, because a resampled gap would be
#: invented data that the estimate then fits.
TIME_JITTER_TOLERANCE = 0.1
#: A given rate that differs from the time stamps' by more than this share gets a
#: warning (a clock's ordinary drift stays below it); within it, a time column is rebuilt
#: from the rate silently. Vendor exports' header rates use it too (:mod:`imucal.clock`).
RATE_WARN = 0.01


def check_plausible_rate(rate: float, source: str = "", origin: str = "",
                         fix: str = "check the rate's units") -> None:
    """Check that ``rate`` (Hz) lies within MIN/MAX_RATE_HZ (1 to 10 000 Hz): body-worn
    IMUs sample at a few Hz to a few kHz, and outside that the number is a unit mistake
    (ms for s, kHz for Hz), not a sample rate. The one check of every rate imucal meets
    (given, stored, from a file's time steps or a device's stamps); ``source`` and
    ``origin`` say whose and where from, ``fix`` what to check.

    Raises
    ------
    InputError
        ``rate`` lies outside the range (NaN too), naming ``source``, ``origin`` and
        ``fix``.
    """
    if MIN_RATE_HZ <= rate <= MAX_RATE_HZ:
        return
    # "below"/"above" and enough digits: 0.99999 Hz printed as 1 Hz would seem to lie
    # inside the range
    side = f"below {MIN_RATE_HZ:g}" if rate < MIN_RATE_HZ else f"above {MAX_RATE_HZ:g}"
    prefix = f"{source}: " if source else ""
    raise InputError(
        f"{prefix}sample rate {rate:.6g} Hz{origin} is {side} Hz, outside the "
        f"{MIN_RATE_HZ:g} to {MAX_RATE_HZ:g} Hz of body-worn IMUs; {fix}"
    )


def reported_rate(rate: float) -> float:
    """A sample rate as documents report it, Hz: to 8 significant digits (0.1 ppm at 100
    Hz; a device's crystal is off by 10-50 ppm). Rates measured from time stamps read
    100.00000000000213 or 99.99999991 Hz in every JSON document (a new-user trial), a
    precision no clock has; the computations keep the measured rate (rounded, a 4 h
    recording at 1024 Hz written with its stamps was rebuilt 0.58 samples off on
    reading, a review).

    Returns
    -------
    float
        ``rate`` rounded to 8 significant digits (inf or NaN as they come).

    Examples
    --------
    >>> from imucal.timing import reported_rate
    >>> reported_rate(1 / 0.009999999999999787), reported_rate(59.99980000001)
    (100.0, 59.9998)
    """
    rate = float(rate)
    return float(f"{rate:.8g}") if math.isfinite(rate) else rate


def check_rate(rate) -> float:
    """A sample rate in Hz as a float, checked (:func:`check_plausible_rate`).

    Returns
    -------
    float
        ``rate`` in Hz, within 1 to 10 000 Hz.

    Raises
    ------
    InputError
        ``rate`` is not a positive real number, or outside the range of body-worn IMUs.
    """
    number = as_real(rate)
    if number is None or number <= 0:
        shown = number if number is not None else repr(rate)
        raise InputError(f"sample rate must be a positive number of Hz, got {shown}")
    check_plausible_rate(number, fix="check its units")
    return number


def check_timing(rate, time, n: int, source: str) -> tuple[float, np.ndarray, list[str]]:
    """The rate (Hz) and time axis (s) of a recording of ``n`` samples from a given rate,
    a time column, or both, and notes on how they were reconciled.

    Raises
    ------
    InputError
        a rate that is no plausible number of Hz (:func:`check_plausible_rate`); a time
        column that is not real numbers, not ``n`` long, not finite, not strictly
        increasing, not regular within :data:`TIME_JITTER_TOLERANCE` of its median step,
        or whose steps give no plausible rate; a rate and a time column that disagree by
        more than :data:`TIME_JITTER_TOLERANCE`; or neither given. The message names
        ``source``.

    Returns
    -------
    rate : float
        Hz: the rate given, else ``1 / median step`` of ``time``.
    time : numpy.ndarray
        (n,) float64, s: ``time`` as given (a copy), ``arange(n) / rate`` without one, or,
        where a given rate and ``time``'s span disagree by over half a sample, rebuilt as
        ``time[0] + arange(n) / rate``.
    notes : list[str]
        Warnings: the rebuilt time axis when the rates differ by over :data:`RATE_WARN`
        (1 %), or ``time``'s steps drifting from their median by as much.

    Examples
    --------
    >>> import numpy as np
    >>> from imucal.timing import check_timing
    >>> rate, time, notes = check_timing(None, np.arange(5) * 0.01, 5, "x.csv")
    >>> round(rate, 6), time.shape, notes
    (100.0, (5,), [])
    """
    if rate is not None:
        number = None
        if not is_bool(rate):  # (True read as 1 Hz)
            try:
                number = float(rate)
            except (TypeError, ValueError, OverflowError):
                pass
        if number is None:
            raise InputError(f"{source}: sample rate {str(rate)[:40]!r} is not a number of Hz")
        rate = number
        if not np.isfinite(rate) or rate <= 0:
            raise InputError(
                f"{source}: sample rate must be a positive number of Hz, got {rate:g}; fix "
                "the 'sample_rate' attribute or give --rate"
            )
        check_plausible_rate(rate, source)
    if time is None:
        if rate is None:
            raise InputError(
                f"{source}: no sample rate and no time stamps; "
                "give a 'sample_rate' attribute, a 'time' column/dataset, or --rate"
            )
        with np.errstate(over="ignore"):
            time_out = np.arange(n) / rate
        if not np.isfinite(time_out).all():
            raise InputError(f"{source}: sample rate {rate:g} Hz is too small to be real")
        return rate, time_out, []

    if np.iscomplexobj(time):
        raise InputError(f"{source}: 'time' holds complex numbers; expected seconds")
    if getattr(time, "dtype", None) == np.bool_:
        raise InputError(f"{source}: 'time' holds True/False values; expected seconds")
    try:
        # a copy: the recording must not change when the caller's array does later
        time = np.array(time, dtype=np.float64).reshape(-1)
    except (TypeError, ValueError, OverflowError):
        raise InputError(f"{source}: 'time' is not numeric") from None
    if time.shape[0] != n:
        raise InputError(f"{source}: 'time' has {time.shape[0]} entries but sensors have {n}")
    if not np.isfinite(time).all():
        i = int(np.flatnonzero(~np.isfinite(time))[0])
        raise InputError(f"{source}: 'time' contains NaN or Inf (first at index {i})")
    with np.errstate(over="ignore", invalid="ignore"):
        dt = np.diff(time)
    if not (dt > 0).all():
        i = int(np.flatnonzero(~(dt > 0))[0])
        what = "repeats a value" if dt[i] == 0 else "goes backwards"
        raise InputError(
            f"{source}: 'time' is not strictly increasing: it {what} at index {i + 1} "
            f"(t[{i}]={float(time[i])!r} s, t[{i + 1}]={float(time[i + 1])!r} s); remove "
            "duplicated or out-of-order rows"
        )
    step = float(np.median(dt))
    with np.errstate(over="ignore", invalid="ignore", divide="ignore"):
        jitter = np.abs(dt - step) / step
        time_rate = 1.0 / step
    if not (jitter <= TIME_JITTER_TOLERANCE).all():
        i = int(np.argmax(np.where(np.isnan(jitter), np.inf, jitter)))
        raise InputError(
            f"{source}: irregular sampling: the interval of {dt[i]:g} s after t={time[i]:g} s "
            f"differs from the median {step:g} s by more than {TIME_JITTER_TOLERANCE:.0%}; "
            "imucal does not resample (that would invent data), so resample the recording "
            "to a constant rate or cut it at the gap first"
        )
    if not (np.isfinite(time_rate) and time_rate > 0):
        raise InputError(f"{source}: 'time' steps of {step:g} s give no usable sample rate")
    check_plausible_rate(time_rate, source, " from the 'time' steps (are they in seconds?)")
    if rate is not None and abs(time_rate - rate) > TIME_JITTER_TOLERANCE * rate:
        raise InputError(
            f"{source}: the rate given ('sample_rate' or --rate) says {rate:g} Hz but 'time' "
            f"says {time_rate:g} Hz; "
            "fix one of them (or drop --rate)"
        )
    if rate is None:
        return time_rate, time, _drift_notes(time, time_rate)
    # The estimators space the samples by the rate; a time axis that drifts from it by
    # over half a sample would put --start/--end and the reported span somewhere else.
    if abs((time[-1] - time[0]) - (n - 1) / rate) <= 0.5 / rate:
        return rate, time, []
    rebuilt = time[0] + np.arange(n) / rate
    # a clock a little off (a crystal's 100 ppm) is no problem worth a warning, and a
    # warning costs the result its "good"; past 1 % one of the two is wrong
    if abs(time_rate - rate) <= RATE_WARN * rate:
        return rate, rebuilt, []
    note = (f"the sample rate {rate:g} Hz ('sample_rate' or --rate) and the 'time' steps "
            f"({time_rate:.6g} Hz) differ by {abs(time_rate - rate) / rate:.2%}; the rate "
            f"is used, and the time axis is rebuilt from it (from t={time[0]:g} s)")
    return rate, rebuilt, [note]


def _drift_notes(time: np.ndarray, rate: float) -> list[str]:
    """A warning when a time column's span says another rate than its median step.

    Every step may be within the jitter tolerance while the steps drift (or a run of them
    is longer): the estimators space the samples by the median step, so past
    :data:`RATE_WARN` the span's rate is not what they assume.
    """
    n, span = time.shape[0], float(time[-1] - time[0])
    span_rate = (n - 1) / span
    if abs(span_rate - rate) <= RATE_WARN * rate:
        return []
    return [f"the 'time' steps drift: their median gives {rate:.6g} Hz, their span "
            f"({span:g} s for {n} samples) {span_rate:.6g} Hz, {abs(span_rate - rate) / rate:.2%}"
            f" apart; the estimators use {rate:.6g} Hz. If the samples are evenly spaced "
            "and only their stamps rounded (a 64 Hz sensor stamped in whole ms), pass the "
            "true rate with --rate; otherwise resample the recording to a constant rate"]
