"""Device clocks: put sensors that started at different times, run at slightly different
rates or dropped packets on one common time grid over the span they share.

For every device (:class:`imucal.formats.RawSensor`):

1. **Sample index.** Each sample gets its index ``k`` in the device's own sample
   sequence. With time stamps (all formats but old Xsens exports) ``k`` is found from the
   stamps: the local interval ``dt`` is rounded to whole sample periods (a dropped packet
   is a step of two or more periods), then refined against a straight-line fit of the
   stamps or taken from the stamps' phase (:func:`_from_phase`) where that fits the line
   better, so jitter and quantised stamps (Shimmer's repeating milliseconds) do not count
   as drops as long as they stay below about 0.4 of a sample period (docs/formats.md).
   Without usable stamps ``k``
   is the unwrapped packet counter. Missing ``k`` are the dropped samples.
2. **Device time.** The stamps are fitted by a straight line ``t = a + T k`` (least
   squares): ``T`` is the device's true sample period on the shared clock (its rate is
   ``1/T``, checked against what the header claims), and the jitter of individual stamps
   is removed. A stamp further than one period from the line (a clock reset) stops
   loading. With a counter only, ``T`` is one over the header's rate (or ``--rate``).
3. **Common grid.** The fastest device is the reference (the first of those within
   :data:`RATE_TIE` of the fastest rate, in the order the sensors were read): the grid is
   its sample times, over the span every device covers (from the latest first sample to
   the earliest last sample). Other devices are **linearly interpolated** onto the grid
   between their two neighbouring samples. When a device runs at the same rate and
   phase as the reference (the usual case of synchronised devices), every grid point
   falls on one of its samples and its data are copied exactly, not interpolated.
4. **Dropped packets** leave NaN on the grid wherever a grid point's neighbours include a
   missing sample. :meth:`imucal.recording.Recording.select` then bridges the short gaps
   by linear interpolation and refuses the long ones (the existing gap rules,
   ``MAX_INTERPOLATED_GAP_S`` and ``MAX_INTERPOLATED_FRACTION``): a dropped packet is
   treated exactly like a NaN sample in imucal's own files.

The recording's time axis starts at 0 s at the first grid point; ``Aligned.origin`` keeps
the shared clock's value there.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from .errors import InputError
from .formats import RawSensor
from .timing import RATE_WARN, check_plausible_rate, reported_rate

#: A header's claimed rate that differs from the time stamps' by more than this share
#: is refused (one of them is wrong); more than :data:`imucal.timing.RATE_WARN` gives
#: a warning.
RATE_REFUSE = 0.10
#: s: a sensor losing more than this outside the span all sensors share gets a warning
#: (devices started one after another lose less; a sensor started late costs more).
CUT_WARN_S = 1.0
#: Repeated stamps (:func:`_repeated_stamps`) are glitches to put in place only in files
#: of at least REPEAT_MIN_ROWS rows where one, or at most REPEAT_MAX_SHARE of the
#: intervals, are 0.
REPEAT_MIN_ROWS = 8
#: Devices whose rates differ by less than this share run at one nominal rate: the grid
#: is the first such device's of the fastest (its clock's own drift, some ppm, must not
#: pick it). The first device alone, i.e. the file whose name sorts first, put a 60 Hz
#: foot's grid under 120 Hz thigh and shank: every second sample of theirs dropped
#: without a word, and the ankle centre 5 mm from the same export with the foot renamed
#: (a new-user trial).
RATE_TIE = 0.01
REPEAT_MAX_SHARE = 0.01
#: Grid points this close to a device sample (in sample periods) are taken as that
#: sample: float rounding of the time stamps must not turn a copy into an interpolation.
SNAP = 1e-6
#: A device whose samples all lie this close to the grid's (in sample periods: 0.1 ms at
#: 100 Hz, far below the clock offsets the estimators resolve) is copied, not
#: interpolated: devices with clocks of their own (x-IMU3) started a few microseconds
#: apart, and the interpolation's warning made every such recording "use with care".
PHASE_SNAP = 0.01
#: A device whose stamps or counter leave more than this share of its span without
#: samples is refused: one corrupt stamp (1e18 us in a 10 s file) read as dropped packets
#: asked for petabytes of gaps (exit 3), and a recording that mostly is gaps is no
#: recording.
MAX_DROPPED_SHARE = 0.9


@dataclass
class Aligned:
    """Devices on one grid: ``time`` (N,) s from 0, ``data[name] = (gyr, acc)`` (N, 3)
    each in the file's units with NaN where samples were dropped, ``info[name]`` what
    ``Recording.sensor_info`` holds, ``notes`` for the warnings, ``origin`` the shared
    clock's time (s) at the first grid point, ``grid_sensor`` the device whose samples
    form the grid."""

    time: np.ndarray
    rate: float
    data: dict
    info: dict
    notes: list
    origin: float
    grid_sensor: str = ""


@dataclass
class _Clock:
    k: np.ndarray        # sample index of each row (int)
    a: float             # device time of k = 0, s
    period: float        # s per sample
    dropped: int
    source_of_time: str  # "time stamps", "packet counter", "sample rate"
    stamp_rate: float | None = None  # Hz, from the stamps when --rate replaced it
    missing_stamp_row: int | None = None  # data row (1-based) of a stamp the counter replaced
    repeated_rows: tuple = ()  # data rows (1-based) of stamps put between their neighbours


def unwrap(values: np.ndarray, wrap: float | None) -> np.ndarray:
    """Undo the wrap-around of a counter or time stamp that restarts at 0 after ``wrap``.

    A step down by more than ``wrap / 2`` is taken as one wrap.

    Returns
    -------
    (N,) float64
        ``values`` with ``wrap`` added once per wrap before each sample, in their own
        unit (s, samples); unchanged when ``wrap`` is None or there are fewer than 2.

    Examples
    --------
    >>> from imucal.clock import unwrap
    >>> unwrap([65534, 65535, 0, 1], 65536).tolist()
    [65534.0, 65535.0, 65536.0, 65537.0]
    """
    values = np.asarray(values, dtype=np.float64)
    if wrap is None or values.size < 2:
        return values
    steps = np.diff(values)
    jumps = np.concatenate([[0.0], np.cumsum(np.where(steps < -wrap / 2, wrap, 0.0))])
    return values + jumps


#: Farthest a device's time stamps (s) or packet counter (samples) may lie from its first
#: one: 115 days of recording, or of samples at 1 kHz. Beyond it a value is corrupt, and
#: casting it to sample numbers overflowed (numpy's warnings, then a wrong message).
MAX_CLOCK_SPAN = 1e7


def _check_values(values: np.ndarray, what_values: str, unit: str, what: str) -> None:
    """InputError naming the first data row (1-based) whose stamp or counter is missing,
    not a number or :data:`MAX_CLOCK_SPAN` from the first."""
    bad = ~np.isfinite(values)
    if bad.any():
        i = int(np.flatnonzero(bad)[0])
        raise InputError(f"{what}: {what_values} missing or not a number at data row {i + 1}; "
                         "fix or delete that row")
    far = np.abs(values - values[0]) > MAX_CLOCK_SPAN
    if far.any():
        i = int(np.flatnonzero(far)[0])
        raise InputError(f"{what}: {what_values} {values[i]:.6g}{unit and ' ' + unit} at data row "
                         f"{i + 1} lies {abs(values[i] - values[0]):.3g}{unit and ' ' + unit} "
                         "from the first: a corrupt value; fix or delete that row")


def _check_repeated_rows(s: RawSensor, t: np.ndarray, what: str) -> None:
    """Refuse a row that repeats the one before it: the same time stamp and the same
    values, a packet logged twice. The stamps' clock fit read it as one more sample
    (a DOT export with one row repeated: a 60.075 Hz clock, the sensor stretched and
    interpolated onto the others' grid, up to 0.59 rad/s off near the repeat, with no
    word of the repeat; a new-user trial), where imucal's own CSV and a packet counter
    refuse it."""
    same = ((t[1:] == t[:-1]) & (s.gyr[1:] == s.gyr[:-1]).all(axis=1)
            & (s.acc[1:] == s.acc[:-1]).all(axis=1))
    if same.any():
        i = int(np.flatnonzero(same)[0])
        raise InputError(
            f"{what}: data row {i + 2} repeats row {i + 1} (the same time stamp and values: "
            "a packet logged twice?); remove the duplicated rows"
        )


def _repeated_stamps(t: np.ndarray) -> tuple[np.ndarray, tuple]:
    """Stamps that repeat their neighbour's while the values are their own (a glitched
    stamp, not a packet logged twice: :func:`_check_repeated_rows`), put between their
    neighbours where the intervals around the pair say which one is off: two periods
    after the pair and one before, the second is early; two before and one after, the
    first is late. A repeat next to a dropped packet on both sides, or three equal stamps,
    is left as it is (read as a drop). Before, every such stamp read as a dropped packet
    beside it and the line through the stamps gave the sensor a false rate (+270 ppm per
    repeat in 2000 samples) and interpolated it whole (a new-user trial).

    Returns
    -------
    t : (N,) float64
        The stamps, s, with those put between their neighbours.
    rows : tuple of int
        Their data rows (1-based).
    """
    dt = np.diff(t)
    zero = int(np.sum(dt == 0))
    # equal stamps that are common are the stamps' rounding (ms stamps at 2 kHz) or one
    # stamp per packet of samples, not glitches: left to the jitter rules (moving them
    # put false drops at a file's ends, a review)
    if t.size < REPEAT_MIN_ROWS or zero == 0 or zero > max(1, REPEAT_MAX_SHARE * dt.size):
        return t, ()
    m = min(32, t.size - 1)
    period = float(np.median((t[m:] - t[:-m]) / m))  # (as _from_stamps: spans of samples)
    if not period > 0:
        return t, ()
    t, moved = t.copy(), []
    for _ in range(3):  # a repeat fixed can settle its neighbour's (two, two rows apart)
        rows = _one_pass(t, period)
        if not rows.size:
            break
        moved.extend(rows.tolist())
    return t, tuple(int(r) + 1 for r in sorted(moved))


def _one_pass(t: np.ndarray, period: float) -> np.ndarray:
    """One pass of :func:`_repeated_stamps` over ``t`` (changed in place): the rows moved."""
    dt = np.diff(t)
    steps = np.rint(dt / period)
    i = np.flatnonzero(dt == 0)  # rows i and i + 1 share a stamp
    first, last = i == 0, i + 1 == dt.size  # (the file's first or last two rows)

    def interval(k):  # steps of interval k, NaN beyond the file
        return np.where((k >= 0) & (k < dt.size), steps[np.clip(k, 0, dt.size - 1)], np.nan)

    before, after = interval(i - 1), interval(i + 1)
    alone = ~np.isin(i - 1, i) & ~np.isin(i + 1, i)  # (three equal stamps: left)
    # the second a period early: two periods after it, one (or the file's start) before;
    # the first a period late: two before it, one (or the file's end) after; at the ends
    # two one-period intervals on the inner side say which
    early = alone & (((after == 2) & ((before == 1) | first))
                     | (last & (before == 1) & (interval(i - 2) == 1)))
    late = alone & ~early & (((before == 2) & ((after == 1) | last))
                             | (first & (after == 1) & (interval(i + 2) == 1)))
    for rows in (i[early] + 1, i[late]):
        inner = (rows > 0) & (rows < t.size - 1)
        mid = rows[inner]
        t[mid] = 0.5 * (t[mid - 1] + t[mid + 1])
        end = rows[~inner]  # the first or last row: a period beyond its neighbour
        t[end] = np.where(end == 0, t[1] - period, t[-2] + period)
    return np.concatenate([i[early] + 1, i[late]])


def _from_counter(counter: np.ndarray, what: str) -> np.ndarray:
    k = counter - counter[0]
    steps = np.diff(k)
    if (steps <= 0).any():
        i = int(np.flatnonzero(steps <= 0)[0])
        raise InputError(
            f"{what}: packet counter goes from {counter[i]:.0f} to {counter[i + 1]:.0f} at data "
            f"row {i + 2} (repeated or out of order); remove the duplicated rows"
        )
    return np.rint(k).astype(np.int64)


def _from_stamps(t: np.ndarray, what: str) -> np.ndarray:
    """Sample indices from time stamps that may jitter, repeat, or skip dropped samples."""
    n = t.size
    m = min(32, n - 1)
    # Period from spans of m samples: quantised stamps average out over the span; spans
    # holding a dropped sample are longer by a whole period and left out of the mean.
    spans = (t[m:] - t[:-m]) / m
    middle = float(np.median(spans))
    if not middle > 0:
        raise InputError(f"{what}: time stamps do not increase")
    period = float(np.mean(spans[spans < middle * (1 + 0.5 / m)]))
    dt = np.diff(t)
    if (dt < -0.5 * period).any():
        i = int(np.flatnonzero(dt < -0.5 * period)[0])
        raise InputError(
            f"{what}: time stamps go backwards at data row {i + 2} ({t[i]:.6f} -> "
            f"{t[i + 1]:.6f} s after the first); rows out of order or a clock reset"
        )
    steps = np.maximum(1, np.rint(dt / period)).astype(np.int64)
    # A long interval next to a short one is jitter, not a drop: two intervals together
    # cover as many periods as their joint span says. Long then short is a late stamp,
    # short then long an early one (which read as a drop: uniform jitter of +-0.3 of a
    # period, within the documented half, gave 185 of 200 files false drops, a review);
    # a short interval pairs with one long neighbour only.
    pair = np.rint((dt[:-1] + dt[1:]) / period).astype(np.int64)
    excess = steps[:-1] + steps[1:] - np.maximum(pair, 2)
    late = (steps[:-1] >= 2) & (excess > 0)
    early = (steps[1:] >= 2) & (excess > 0) & ~late & ~np.r_[False, late[:-1]]
    steps[:-1][late] = np.maximum(1, steps[:-1][late] - excess[late])
    steps[1:][early] = np.maximum(1, steps[1:][early] - excess[early])
    k = np.concatenate([[0], np.cumsum(steps)])
    worst = np.inf
    for _ in range(3):  # refine against the straight line through all stamps
        slope, intercept = np.polyfit(k, t, 1)
        now = float(np.max(np.abs(t - intercept - slope * k)))
        if now >= worst:
            break
        best, worst = k, now
        est = np.rint((t - intercept) / slope).astype(np.int64)
        k = np.maximum.accumulate(est - np.arange(n)) + np.arange(n)  # strictly increasing
    # Neighbours' intervals misread stamps jittered by a third of a period or more
    # (uniform +-0.3: 52 of 200 files with false drops; with 1 % real drops, 131); the
    # stamps' phase against the period does not, where it fits the line better. The
    # period from the spans, or from the line through the indices above (the better where
    # spans hold many drops), each refined once by the line through its own indices.
    # Stamps all within a quarter period of the line are read: another index would put
    # its stamp three quarters of a period off.
    for start in (period, np.polyfit(best, t, 1)[0]) if worst > 0.25 * period else ():
        slope = start
        for _ in range(2):
            if not slope > 0:
                break
            k = _from_phase(t, slope)
            slope, intercept = np.polyfit(k, t, 1)
            now = float(np.max(np.abs(t - intercept - slope * k)))
            if now < worst:
                best, worst = k, now
    return best - best[0]


#: Samples per window over which :func:`_from_phase` averages the stamps' phase.
PHASE_WINDOW = 128


def _from_phase(t: np.ndarray, period: float) -> np.ndarray:
    """Sample indices as the stamps' whole periods after their local phase is taken off.

    Each stamp is a whole number of periods plus one phase (the clock's start) plus its
    jitter. The phase is the circular mean of the stamps' fractional periods over windows
    of :data:`PHASE_WINDOW` samples (dropped samples change no stamp's phase), followed
    between windows (a rate a little off ``period`` turns it slowly); a stamp jittered by
    less than half a period minus the phase's error then rounds to its own index.

    Returns
    -------
    (N,) int64
        Strictly increasing indices (two stamps within one period get consecutive ones).
    """
    n = t.size
    u = (t - t[0]) / period
    z = np.concatenate([[0], np.cumsum(np.exp(2j * np.pi * u))])
    edges = np.linspace(0, n, max(1, n // PHASE_WINDOW) + 1).astype(np.int64)
    phase = np.unwrap(np.angle(z[edges[1:]] - z[edges[:-1]])) / (2 * np.pi)
    centres = 0.5 * (edges[1:] + edges[:-1] - 1)
    est = np.rint(u - np.interp(np.arange(n), centres, phase)).astype(np.int64)
    return np.maximum.accumulate(est - np.arange(n)) + np.arange(n)


def _clock(s: RawSensor, what: str, rate: float | None) -> _Clock:
    n = s.gyr.shape[0]
    t = None if s.time is None else unwrap(s.time, s.time_wrap)
    missing = None
    if t is not None and not np.isfinite(t).all() and s.counter is not None:
        # the packet counter instead (:func:`_device_clocks` refuses that next to devices
        # whose clocks are their stamps: the counter's zero is not theirs)
        missing = int(np.flatnonzero(~np.isfinite(t))[0]) + 1
        t = None
    repeated = ()
    if t is not None:
        _check_values(t, "time stamp", "s", what)
        _check_repeated_rows(s, t, what)
        t, repeated = _repeated_stamps(t)
    if t is not None and n >= 3:
        # Relative to the first stamp: a large clock value would cost the fit precision.
        t0, t = t[0], t - t[0]
        k = _from_stamps(t, what)
        period, a = np.polyfit(k, t, 1)
        residual = np.abs(t - (a + period * k))
        worst = float(np.max(residual))
        if worst > period:
            i = int(np.argmax(residual))
            raise InputError(
                f"{what}: time stamp at data row {i + 1} lies {worst:g} s off the "
                "device's regular clock (a clock reset or a pause in logging); cut the file there"
            )
        a += t0
        stamps = None
        if rate is not None:
            stamps = 1.0 / period
            if abs(stamps - rate) > RATE_REFUSE * rate:
                raise InputError(
                    f"{what}: --rate {rate:g} Hz but its time stamps say {stamps:.4g} Hz; "
                    "drop --rate (the stamps give the rate) or fix the file"
                )
            # Within the tolerance the user may know better than the stamps (a device
            # clock that runs a little fast): the given rate spaces the samples.
            period = 1.0 / rate
        origin = "time stamps"
    else:
        stamps = None
        if s.counter is not None:
            c = unwrap(s.counter, s.counter_wrap)
            _check_values(c, "packet counter", "", what)
            k = _from_counter(c, what)
            origin = "packet counter"
        else:
            c = np.zeros(1)
            k = np.arange(n, dtype=np.int64)
            origin = "sample rate"
        use = rate or s.claimed_rate
        if use is None:
            raise InputError(
                f"{what}: no time stamps and no sample rate in the file; give --rate "
                "(the rate the device recorded at, Hz)"
            )
        if not (math.isfinite(use) and use > 0):  # (a given --rate is checked on loading)
            raise InputError(f"{what}: the file's header gives the sample rate {use:g} Hz, "
                             "which is no rate; give --rate (the rate the device recorded "
                             "at, Hz)")
        period = 1.0 / float(use)
        a = float(c[0]) * period  # the counters of one export are shared: align on them
    _check_dropped(k, period, what, origin)
    return _Clock(k=k, a=float(a), period=float(period), dropped=int(k[-1] + 1 - n),
                  source_of_time=origin, stamp_rate=stamps, missing_stamp_row=missing,
                  repeated_rows=repeated)


def _check_dropped(k: np.ndarray, period: float, what: str, origin: str) -> None:
    """InputError naming the largest jump where the sample indices ``k`` leave more
    than :data:`MAX_DROPPED_SHARE` of the device's span without samples."""
    span = int(k[-1]) + 1
    if span - k.size <= MAX_DROPPED_SHARE * span:
        return
    i = int(np.argmax(np.diff(k)))
    jump = int(k[i + 1] - k[i])
    raise InputError(
        f"{what}: a jump of {jump * period:.6g} s ({jump - 1} samples) in its {origin} at "
        f"data row {i + 2} leaves {(span - k.size) / span:.1%} of its time without "
        "samples: a corrupt value or a long pause in logging; cut the file there"
    )


def align(sensors: list[RawSensor], source: str, rate: float | None = None) -> Aligned:
    """Put ``sensors`` on the fastest one's sample grid over the span they share (the
    first of those within :data:`RATE_TIE` of the fastest rate).

    ``rate`` (Hz, optional) replaces the devices' own rate (for files without time
    stamps or header rate); with time stamps it must agree with theirs within
    :data:`RATE_REFUSE`. ``source`` names the recording in messages.

    Returns
    -------
    Aligned
        ``time`` (N,) s from 0 at the first shared grid point, ``rate`` the first
        reference sensor's rate from its clock (Hz), ``data[name] = (gyr, acc)`` (N, 3) each in the
        file's units (NaN at dropped samples), ``info`` per sensor, ``notes`` (dropped,
        cut or interpolated samples, rate disagreements) and ``origin`` (s on the
        devices' shared clock at the first grid point).

    Raises
    ------
    InputError
        Unusable clocks: a sensor with fewer than 3 samples, stamps or counters that are
        missing, go backwards, repeat, lie off the device's straight-line clock by more
        than a period or leave more than :data:`MAX_DROPPED_SHARE` of the span empty; no
        rate at all, or a rate outside the plausible range or more than
        :data:`RATE_REFUSE` from the header's or ``rate``; sensors that do not record 3
        samples' worth of time together.
    """
    sensors = _one_wrap_cycle(sensors)
    clocks, notes = _device_clocks(sensors, source, rate)
    fastest = min(c.period for c in clocks.values())
    ref_name = next(s.name for s in sensors
                    if clocks[s.name].period <= fastest * (1 + RATE_TIE))
    ref = clocks[ref_name]
    grid, firsts, lasts = _shared_grid(clocks, ref, source)
    # who cut the span: named in the warning of each sensor that lost data to it
    cutters = (max(firsts, key=firsts.get), min(lasts, key=lasts.get))
    data, info = {}, {}
    for s in sensors:
        data[s.name], info[s.name], more = _onto_grid(s, clocks[s.name], grid, firsts[s.name],
                                                      ref, ref_name, cutters)
        notes += more
    return Aligned(time=grid - grid[0], rate=1.0 / ref.period, data=data, info=info,
                   notes=notes, origin=round(float(grid[0]), 9), grid_sensor=ref_name)


def _one_wrap_cycle(sensors: list[RawSensor]) -> list[RawSensor]:
    """``sensors`` with the stamps of devices that started after their clock wrapped (a
    DOT's microseconds wrap every 71.6 min) moved on by a whole wrap, next to those that
    started before it. Each device's own wraps are undone on its own (:func:`unwrap`); a
    device whose first stamp lay past the wrap read as starting 71 min before the others
    ("do not record at the same time"). Only when the devices do not record at the same
    time as they are and do once moved: devices 40 min apart within one cycle stay."""
    stamped = [i for i, s in enumerate(sensors) if s.time is not None and s.time_wrap
               and s.time.size and np.isfinite(s.time[[0, -1]]).all()]
    if len(stamped) < 2:
        return sensors
    spans = {i: unwrap(sensors[i].time, sensors[i].time_wrap)[[0, -1]] for i in stamped}
    latest = max(float(a) for a, _ in spans.values())
    # (first stamps lie within one wrap, so one wrap is the most a device is behind)
    shift = {i: sensors[i].time_wrap if a < latest - sensors[i].time_wrap / 2 else 0.0
             for i, (a, _) in spans.items()}

    def overlap(moves):
        return (min(float(b) + moves[i] for i, (_, b) in spans.items())
                > max(float(a) + moves[i] for i, (a, _) in spans.items()))

    if not any(shift.values()) or overlap(dict.fromkeys(spans, 0.0)) or not overlap(shift):
        return sensors
    return [replace(s, time=s.time + shift[i]) if shift.get(i) else s
            for i, s in enumerate(sensors)]


def _device_clocks(sensors: list[RawSensor], source: str,
                   rate: float | None) -> tuple[dict, list[str]]:
    """Each device's clock (:func:`_clock`), its rate checked against the plausible range
    and against its header's claim, and notes where they differ."""
    clocks, notes = {}, []
    for s in sensors:
        what = f"{source}: sensor '{s.name}'"
        if s.gyr.shape[0] < 3:  # (two stamps neither give a clock nor span a grid)
            raise InputError(f"{what} has {s.gyr.shape[0]} sample(s); a recording needs at "
                             "least 3")
        clk = _clock(s, what, rate)
        dev_rate = 1.0 / clk.period
        check_plausible_rate(dev_rate, what, f" from its {clk.source_of_time}",
                             "check the time stamps' units")
        if s.claimed_rate and clk.source_of_time == "time stamps" and rate is None:
            off = abs(dev_rate - s.claimed_rate) / s.claimed_rate
            if off > RATE_REFUSE:
                raise InputError(
                    f"{what}: the header says {s.claimed_rate:g} Hz but the time stamps say "
                    f"{dev_rate:.4g} Hz; one of them is wrong (if the stamps are right, give "
                    f"--rate {dev_rate:.4g})"
                )
            if off > RATE_WARN:
                notes.append(f"sensor '{s.name}': the header says {s.claimed_rate:g} Hz, the "
                             f"time stamps {dev_rate:.4g} Hz; the time stamps are used")
        if clk.stamp_rate and abs(clk.stamp_rate - rate) > RATE_WARN * rate:
            notes.append(f"sensor '{s.name}': --rate {rate:g} Hz is used; its time stamps "
                         f"say {clk.stamp_rate:.4g} Hz")
        clocks[s.name] = clk
    stamped = [n for n, c in clocks.items() if c.source_of_time == "time stamps"]
    for name, c in clocks.items():
        if stamped and c.missing_stamp_row is not None:
            # its counter's zero is not the stamps': it read as starting 637 s apart
            raise InputError(
                f"{source}: sensor '{name}': time stamp missing or not a number at data row "
                f"{c.missing_stamp_row}, so its clock would be its packet counter, which "
                f"does not share the time stamps of '{stamped[0]}'; fix or delete that row")
    return clocks, notes


def _shared_grid(clocks: dict, ref, source: str) -> tuple[np.ndarray, dict, dict]:
    """The reference device's sample times (``ref``) over the span every device recorded, s on
    the devices' shared clock, and each device's first and last sample times."""
    firsts = {n: c.a for n, c in clocks.items()}
    lasts = {n: c.a + c.period * c.k[-1] for n, c in clocks.items()}
    start, end = max(firsts.values()), min(lasts.values())
    if end - start < (2 - SNAP) * ref.period:  # (three samples span two periods)
        late = max(firsts, key=firsts.get)
        early = min(lasts, key=lasts.get)
        if end > start:
            raise InputError(
                f"{source}: the sensors record together for only {end - start:g} s ('{late}' "
                f"starts last, '{early}' stops first): fewer than the 3 samples a recording "
                "needs")
        raise InputError(
            f"{source}: the sensors do not record at the same time: '{late}' starts at "
            f"{firsts[late] - min(firsts.values()):g} s, after '{early}' stopped at "
            f"{lasts[early] - min(firsts.values()):g} s (on the devices' shared clock)"
        )
    j0 = int(np.ceil((start - ref.a) / ref.period - SNAP))
    j1 = int(np.floor((end - ref.a) / ref.period + SNAP))
    return ref.a + ref.period * np.arange(j0, j1 + 1), firsts, lasts


def _onto_grid(s: RawSensor, clk, grid: np.ndarray, first: float, ref,
               ref_name: str, cutters: tuple[str, str]) -> tuple[tuple, dict, list[str]]:
    """One device's (gyr, acc) on the grid (its samples where they fall on it, the
    straight line between them elsewhere, dropped samples NaN), its provenance entry,
    and notes on what was dropped, cut or interpolated (``cutters``: the sensors that
    start last and stop first)."""
    full = int(clk.k[-1]) + 1
    pos = (grid - clk.a) / clk.period
    near = np.rint(pos)
    # a device within PHASE_SNAP of the grid everywhere is copied; a drifting one keeps
    # its interpolation wherever it is further from a sample than float rounding
    snap = PHASE_SNAP if np.all(np.abs(pos - near) < PHASE_SNAP) else SNAP
    pos = np.clip(np.where(np.abs(pos - near) < snap, near, pos), 0, full - 1)
    interpolated = bool(np.any(pos != np.floor(pos)))
    i = np.minimum(np.floor(pos).astype(np.int64), full - 1)
    nxt = np.minimum(i + 1, full - 1)
    frac = (pos - i)[:, None]
    arrays = []
    for arr in (s.gyr, s.acc):
        filled = np.full((full, 3), np.nan)
        filled[clk.k] = arr
        # A grid point on a sample is that sample (0 * NaN of a dropped neighbour
        # would otherwise spoil it); between samples, the straight line.
        with np.errstate(invalid="ignore"):
            out = np.where(frac == 0, filled[i], (1 - frac) * filled[i] + frac * filled[nxt])
        arrays.append(out)
    times = clk.a + clk.period * clk.k
    cut0 = int(np.sum(times < grid[0] - snap * clk.period))  # (a copied one is used)
    cut1 = int(np.sum(times > grid[-1] + snap * clk.period))
    info = {
        "label": s.name,
        "serial": s.serial,
        "rate_hz": reported_rate(1.0 / clk.period),
        "claimed_rate_hz": s.claimed_rate,
        "time_from": clk.source_of_time,
        "start_s": first - grid[0],
        "duration_s": clk.period * full,
        "samples": int(s.gyr.shape[0]),
        "units_read": {"gyr": s.gyr_units, "acc": s.acc_units},
        "dropped": clk.dropped,
        "cut": [cut0, cut1],
        "interpolated": interpolated,
        "files": list(s.files),
    }
    notes = []
    if clk.repeated_rows:
        rows, count = clk.repeated_rows, len(clk.repeated_rows)
        listed = ", ".join(map(str, rows[:5])) + (f" and {count - 5} more" if count > 5 else "")
        notes.append(
            f"sensor '{s.name}': {count} time stamp(s) repeat a neighbour's while the values "
            f"are their own (data row {listed}): read at their place in the sequence")
    if clk.dropped:
        notes.append(
            f"sensor '{s.name}': {clk.dropped} sample(s) missing from its "
            f"{clk.source_of_time} (dropped packets), left as gaps"
        )
    # Samples outside the span every sensor shares (devices started one after another)
    # are no problem of the data used: ``info["cut"]`` records them, and ``imucal info``
    # shows each sensor's start. As a warning they cost nearly every real multi-device
    # export its "good" (its converted .h5 kept it); past CUT_WARN_S, though, a sensor
    # that started late takes the others' data with it (15 of 20 s, silently: a review)
    if (cut0 + cut1) * clk.period > CUT_WARN_S:
        # (a side cut by a few samples only is no cause: "'Foot' stopped first" beside
        # "0.0 s after" read as a contradiction)
        why = " and ".join(
            f"'{name}' {what}" for name, what, cut in
            ((cutters[0], "started last", cut0), (cutters[1], "stopped first", cut1))
            if cut * clk.period >= 0.05 and name != s.name
        ) or "a sensor started late or stopped early"
        notes.append(
            f"sensor '{s.name}': {cut0 * clk.period:.1f} s before and {cut1 * clk.period:.1f}"
            f" s after the span all sensors share are not used ({why}; load the others "
            "without it, e.g. from their own files)"
        )
    if interpolated:
        notes.append(
            f"sensor '{s.name}' ({1 / clk.period:.6g} Hz) does not sample at the grid's "
            f"times ({1 / ref.period:.6g} Hz, '{ref_name}'): linearly interpolated "
            "onto it"
        )
    return tuple(arrays), info, notes
