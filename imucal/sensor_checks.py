"""What one sensor's readings are checked for when a recording is built or used, before
any estimate: units (a gyroscope in deg/s declared rad/s, an accelerometer in g),
corrupt packets and non-physical values, stuck channels, and gaps (runs of NaN or Inf),
which are interpolated when short. :mod:`imucal.recording` applies them."""

from __future__ import annotations

import difflib
from collections.abc import Mapping
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from .errors import InputError

if TYPE_CHECKING:
    from .recording import SensorData

GYR_UNITS = {"rad/s": 1.0, "deg/s": np.pi / 180.0}
ACC_UNITS = {"m/s^2": 1.0, "g": 9.80665}

#: A human limb segment does not turn faster than this (rad/s, about 2000 deg/s); a
#: gyroscope peaking above it is most likely in deg/s.
MAX_LIMB_RATE = 35.0
#: A median accelerometer norm in this range (m/s^2 after conversion) is ~1 g expressed
#: in g: the data are most likely in g, not m/s^2.
ACC_LOOKS_LIKE_G = (0.5, 2.0)
#: A median accelerometer norm below the first or above the second (m/s^2 after
#: conversion) is far from the 1 g that gait and rest give: a unit 1000 or ~100 times off
#: (m/s^2 or g declared as mg; m/s^2 or mg declared as g), or gravity removed.
ACC_PLAUSIBLE = (0.5, 50.0)
#: A gyroscope declared in deg/s that never turns faster than this (rad/s; 5.7 deg/s)
#: beside an accelerometer whose specific force spans at least ``ACC_MOVING_SPAN``
#: (m/s^2, 1st to 99th percentile of its norm) looks like rad/s read as deg/s: circling
#: read so was "the sensors barely rotate (1.6 and 2.2 deg/s)", with no word of units (a
#: new-user trial).
SLOW_DEG_S_PEAK = 0.1
ACC_MOVING_SPAN = 2.0

#: Longest run of non-finite samples (NaN or Inf: a dropped packet) inside a recording that
#: is filled by linear interpolation, s. Human limb motion has almost no energy above
#: 6 Hz; over 0.05 s (under a third of such a period) a straight line stays close to it.
#: A longer gap in the data an estimate uses stops it.
MAX_INTERPOLATED_GAP_S = 0.05
#: Largest share of one signal's samples in the window used that may be interpolated;
#: beyond it the signal is more repair than measurement and the estimate stops.
MAX_INTERPOLATED_FRACTION = 0.05
#: Readings beyond these, in SI units, are no measurement but a corrupt packet (a value
#: of 1e30): they are treated as missing, like NaN. Far above any body-worn sensor's range
#: (4000 deg/s = 70 rad/s; 400 g = 3900 m/s^2) and above what a unit mistake gives
#: (deg/s or mrad/s read as rad/s: some ten thousands; mG read as m/s^2 or as g: some
#: ten thousands, up to 1e5 for 10 g read as g), which the unit checks name instead.
NONPHYSICAL = {"gyr": 1e5, "acc": 1e6}
#: No body-worn sensor reads beyond these (SI units: 4000 deg/s, 400 g). A reading beyond
#: them far above the readings around it is no measurement but a corrupt packet: one
#: such gyroscope reading of 1e3 rad/s made a good knee axis "not identifiable", blamed
#: on disagreeing stretches of the data, with a warning that the file was in deg/s. A
#: unit mistake (deg/s read as rad/s) is no such spike: the readings around it are about
#: as large, and the unit checks name it.
SENSOR_RANGE = {"gyr": 70.0, "acc": 3924.0}
#: Longest run of readings beyond :data:`SENSOR_RANGE` still taken for a corrupt packet.
MAX_SPIKE_SAMPLES = 5
#: A corrupt packet stands this many times above the readings on either side. A fast
#: moment of a signal in another unit does not: on the shared recording read in deg/s or
#: mg, every sensor's readings beyond the range stand at most 3.4 (deg/s) and 3.9 (mg)
#: times above their neighbours (quiet stretches' 80 "rad/s", heel strikes of 4-7 g),
#: and were taken for spikes by a rule without it.
SPIKE_RATIO = 10.0

#: Common spellings of the accepted units, used only to suggest the right name.
_UNIT_ALIASES = {
    "dps": "deg/s", "deg/sec": "deg/s", "degrees/s": "deg/s", "°/s": "deg/s",
    "rad/sec": "rad/s", "rps": "rad/s", "radians/s": "rad/s",
    "m/s2": "m/s^2", "m/s²": "m/s^2", "m/s**2": "m/s^2", "mps2": "m/s^2", "m s^-2": "m/s^2",
    "G": "g", "gn": "g", "g0": "g",
}



@dataclass(frozen=True)
class Gap:
    """One run of non-finite samples (NaN or Inf in any axis) in one signal.

    ``start`` and ``length`` count samples; ``time`` is the first bad sample's time, s on
    the recording's time axis.
    """

    sensor: str
    kind: str
    start: int
    length: int
    time: float


def corrupt_readings(arr: np.ndarray, kind: str) -> np.ndarray:
    """The readings of ``arr`` ((N, 3), SI units: rad/s for ``kind`` "gyr", m/s^2 for
    "acc") that are no measurement: beyond :data:`NONPHYSICAL`, or spikes beyond
    :data:`SENSOR_RANGE`: runs of at most :data:`MAX_SPIKE_SAMPLES` at least
    :data:`SPIKE_RATIO` times the readings on either side (a missing reading or the
    signal's end counts as 0). A reading's size is its largest absolute axis.

    Returns
    -------
    numpy.ndarray
        (N,) bool, True for such a reading; non-finite readings are False.

    Examples
    --------
    >>> import numpy as np
    >>> from imucal.sensor_checks import corrupt_readings
    >>> gyr = np.full((5, 3), 1.0)
    >>> gyr[2] = 1e3                          # rad/s: a one-sample spike
    >>> corrupt_readings(gyr, "gyr")
    array([False, False,  True, False, False])
    """
    with np.errstate(invalid="ignore"):
        size = np.abs(arr).max(axis=1)
        finite = np.isfinite(size)
        bad = finite & (size > NONPHYSICAL[kind])
        over = finite & (size > SENSOR_RANGE[kind])
    if not over.any():
        return bad
    around = np.concatenate([[0.0], np.where(finite, size, 0.0), [0.0]])
    edges = np.diff(np.concatenate([[0], over.view(np.int8), [0]]))
    for start, stop in zip(np.flatnonzero(edges == 1), np.flatnonzero(edges == -1),
                           strict=True):  # (runs beyond the range: few, if any)
        sides = max(around[start], around[stop + 1])
        if stop - start <= MAX_SPIKE_SAMPLES and size[start:stop].min() >= SPIKE_RATIO * sides:
            bad[start:stop] = True
    return bad


def nonphysical(arr: np.ndarray, name: str, kind: str) -> list[tuple]:
    """Readings of ``arr`` ((N, 3), SI units) that are no measurement
    (:func:`corrupt_readings`) set to NaN in place, so they become gaps. Before, one 1e30
    sample stopped every estimate with "no restart produced a finite result", naming
    neither the sample nor the cause (a new-user review).

    Returns
    -------
    list[tuple]
        ``[(name, kind, count, first index, its largest absolute axis value)]`` (the
        value in rad/s or m/s^2), or ``[]`` when every reading is a measurement.
    """
    bad = corrupt_readings(arr, kind)
    if not bad.any():
        return []
    i = int(np.flatnonzero(bad)[0])
    value = float(np.abs(arr[i]).max())
    arr[bad] = np.nan
    return [(name, kind, int(bad.sum()), i, value)]


def nonphysical_notes(corrupt: list[tuple], time: np.ndarray) -> list[str]:
    """One warning per signal that :func:`nonphysical` found readings beyond the sensor
    range in, with the first one's time (s, on ``time``).

    Returns
    -------
    list[str]
        One line per entry of ``corrupt``: count, :data:`SENSOR_RANGE` (rad/s or m/s^2),
        the first value, its time (s) and sample index.
    """
    return [f"sensor '{name}' {kind}: {count} reading(s) beyond any body-worn sensor's "
            f"range ({SENSOR_RANGE[kind]:g} {'rad/s' if kind == 'gyr' else 'm/s^2'}), the "
            f"first {value:.6g} at t="
            f"{time[i]:g} s (sample {i}): not a physical reading (a corrupt packet?), "
            "treated as missing"
            for name, kind, count, i, value in corrupt]


def check_units(kind: str, unit, what: str) -> None:
    """Check that ``unit`` is known for ``kind`` (``"gyr"``: rad/s, deg/s; ``"acc"``:
    m/s^2, g).

    Raises
    ------
    InputError
        Naming ``what``, for any other unit (not a str, or misspelt); the message suggests
        the accepted spelling of a common alias (``dps`` -> ``deg/s``) or a close match.
    """
    table = GYR_UNITS if kind == "gyr" else ACC_UNITS
    if isinstance(unit, str) and unit in table:
        return
    text = str(unit)
    guess = _UNIT_ALIASES.get(text.strip()) or _UNIT_ALIASES.get(text.strip().lower())
    if guess not in table:
        close = difflib.get_close_matches(text.strip(), list(table), n=1, cutoff=0.6)
        guess = close[0] if close else None
    hint = f" (did you mean '{guess}'?)" if guess else ""
    prefix = _SCALE_PREFIXES.get(text.strip()[:1])
    if guess and prefix and text.strip()[1:].lower() == guess.lower():
        # 'mg' is no misspelt 'g': taken for it the data would be 1000 times too large
        hint = f" ({prefix}{guess}: convert the values to {guess} first)"
    raise InputError(f"{what}: unknown units {text[:40]!r}{hint}; use one of {', '.join(table)}")


#: SI prefixes a unit may carry (mg, mdeg/s): a scale, not a spelling.
_SCALE_PREFIXES = {"m": "milli-", "u": "micro-", "µ": "micro-", "k": "kilo-"}


def max_gap_samples(rate: float) -> int:
    """Longest gap, in samples at ``rate`` Hz, that is filled by interpolation.

    Returns
    -------
    int
        ``floor(MAX_INTERPOLATED_GAP_S * rate)`` (0.05 s worth of samples).

    Examples
    --------
    >>> from imucal.sensor_checks import max_gap_samples
    >>> max_gap_samples(100.0), max_gap_samples(60.0)
    (5, 3)
    """
    return int(np.floor(MAX_INTERPOLATED_GAP_S * rate + 1e-9))


def find_gaps(raw, time: np.ndarray) -> tuple[Gap, ...]:
    """Every run of non-finite samples (NaN or Inf in any axis) in ``raw``
    ({sensor: {kind: (N, 3)}}).

    Returns
    -------
    tuple[Gap, ...]
        One :class:`Gap` per run, by sensor and kind in ``raw``'s order, then by start;
        ``time`` the run's first sample's time (s, on ``time``).
    """
    gaps = []
    for name, arrays in raw.items():
        for kind, arr in arrays.items():
            starts, lengths = _runs(~np.isfinite(arr).all(axis=1))
            gaps += [Gap(name, kind, int(i), int(k), float(time[i]))
                     for i, k in zip(starts, lengths, strict=True)]
    return tuple(gaps)


def finite_rows(sd: SensorData) -> np.ndarray:
    """Where both of the sensor's signals are finite in every axis.

    Returns
    -------
    numpy.ndarray
        (N,) bool.
    """
    return np.isfinite(sd.gyr).all(axis=1) & np.isfinite(sd.acc).all(axis=1)


def gap_warnings(gaps, raw, rate: float, n: int) -> list[str]:
    """One line per signal with gaps: where they are and what an estimate using it will do.

    Returns
    -------
    list[str]
        Per signal with gaps, in ``raw``'s order: the count, the first gap's time and the
        longest gap (samples, s, its time), and whether estimates will interpolate or stop;
        or that it has no finite sample at all.
    """
    notes = []
    max_gap = max_gap_samples(rate)
    for name, arrays in raw.items():
        for kind in arrays:
            runs = [g for g in gaps if (g.sensor, g.kind) == (name, kind)]
            if not runs:
                continue
            count = sum(g.length for g in runs)
            if count == n:
                notes.append(f"sensor '{name}' {kind} has no finite sample (all NaN, Inf or "
                             "beyond any body-worn sensor's range): "
                             "estimates that use it cannot run")
                continue
            longest = max(runs, key=lambda g: g.length)
            long = sum(g.length > max_gap for g in runs)
            fate = (f"{long} longer than {MAX_INTERPOLATED_GAP_S:g} s stop estimates whose "
                    "window they touch, shorter ones are interpolated" if long else
                    "estimates that use them interpolate them")
            notes.append(
                f"sensor '{name}' {kind}: {count} non-finite sample(s) (NaN or Inf) in "
                f"{len(runs)} gap(s), the first at t={runs[0].time:g} s, the longest "
                f"{longest.length} sample(s) ({longest.length / rate:g} s) at "
                f"t={longest.time:g} s; {fate}"
            )
    return notes


def interpolate_gap(arr: np.ndarray, start: int, length: int) -> None:
    """Fill ``arr[start:start + length]`` in place on the line between its finite neighbours."""
    before, after = arr[start - 1], arr[start + length]
    weight = (np.arange(1, length + 1) / (length + 1))[:, None]
    arr[start:start + length] = before + weight * (after - before)


def _runs(mask: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Start indices and lengths of the runs of True in a 1-D boolean ``mask``."""
    edges = np.diff(np.concatenate([[0], mask.astype(np.int8), [0]]))
    starts = np.flatnonzero(edges == 1)
    return starts, np.flatnonzero(edges == -1) - starts


def unit_warnings(sensors: Mapping[str, SensorData], units) -> list[str]:
    """Plain-language doubts about the declared units, with the evidence.

    ``sensors`` hold data converted to SI units; ``units`` the units declared per sensor.

    Returns
    -------
    list[str]
        Per sensor: a gyroscope peak norm above :data:`MAX_LIMB_RATE` (35 rad/s: deg/s?)
        or, declared deg/s, below :data:`SLOW_DEG_S_PEAK` while the accelerometer moves
        (rad/s?),
        a median accelerometer norm within :data:`ACC_LOOKS_LIKE_G` (about 1 in m/s^2:
        g?) or outside :data:`ACC_PLAUSIBLE` (:func:`acc_scale_doubt`). Empty sensors are
        skipped.
    """
    notes = []
    for name, sd in sensors.items():
        if sd.gyr.shape[0] == 0:
            continue
        with np.errstate(over="ignore"):  # absurd values overflow to Inf, still evidence
            peak = float(np.linalg.norm(sd.gyr, axis=1).max())
            acc_norm = np.linalg.norm(sd.acc, axis=1)
            median = float(np.median(acc_norm))
        if peak > MAX_LIMB_RATE:
            notes.append(
                f"sensor '{name}' gyr peaks at {peak:.0f} rad/s ({units[name]['gyr']}), faster "
                f"than a limb turns (< {MAX_LIMB_RATE:g} rad/s): is it in deg/s? "
                "(--gyr-units deg/s or a 'units' attribute)"
            )
        if ACC_LOOKS_LIKE_G[0] <= median <= ACC_LOOKS_LIKE_G[1]:
            notes.append(
                f"sensor '{name}' acc has a median norm of {median:.2f} m/s^2, about 1 g in g "
                "units: is it in g? (--acc-units g or a 'units' attribute)"
            )
        elif not ACC_PLAUSIBLE[0] <= median <= ACC_PLAUSIBLE[1]:
            notes.append(f"sensor '{name}' acc "
                         f"{acc_scale_doubt(median)} (--acc-units or a 'units' attribute)")
        if units.get(name, {}).get("gyr") == "deg/s" and peak < SLOW_DEG_S_PEAK:
            p1, p99 = np.percentile(acc_norm, [1, 99])
            if p99 - p1 >= ACC_MOVING_SPAN:
                notes.append(
                    f"sensor '{name}' gyr peaks at {np.degrees(peak):.1f} deg/s (declared "
                    f"deg/s) while its acc spans {p99 - p1:.1f} m/s^2: the sensor moved; is "
                    "the gyroscope in rad/s? (--gyr-units rad/s or a 'units' attribute)")
    return notes


def acc_scale_doubt(median: float) -> str:
    """Why a median specific force (m/s^2) outside :data:`ACC_PLAUSIBLE` points to wrong
    accelerometer units, naming the likely mistake.

    Returns
    -------
    str
        A phrase starting "has a median norm of ...", to follow "sensor '<name>' acc".
    """
    if median < ACC_PLAUSIBLE[0]:
        return (f"has a median norm of {median:.3g} m/s^2, far below 1 g = 9.81 m/s^2: the "
                "declared units look wrong (m/s^2 or g data declared as mg?), or gravity "
                "was removed (free acceleration)")
    return (f"has a median norm of {median:.4g} m/s^2 = {median / ACC_UNITS['g']:.3g} g, far above "
            "1 g: the declared units look wrong (m/s^2 data declared as g, or mg data as g "
            "or m/s^2?)")


def stuck_warnings(sensors: Mapping[str, SensorData]) -> list[str]:
    """Signals that never change: real sensors always show some noise, so such a signal
    comes from a dead, disconnected or saturated sensor (or a filler value).

    Returns
    -------
    list[str]
        One line per signal (sensor, gyr/acc) whose samples all equal its first, with
        that value (rad/s or m/s^2); empty signals are skipped.
    """
    notes = []
    for name, sd in sensors.items():
        for kind, unit in (("gyr", "rad/s"), ("acc", "m/s^2")):
            arr = getattr(sd, kind)
            if arr.shape[0] and (arr == arr[0]).all():
                value = ", ".join(f"{v:g}" for v in arr[0])
                notes.append(
                    f"sensor '{name}' {kind} never changes (all {arr.shape[0]} samples are "
                    f"[{value}] {unit}): a dead or disconnected sensor? estimates that use "
                    "it have nothing to go on"
                )
    return notes
