"""The validated recording object every estimator receives.

Loaders (``imucal.loaders``) parse files; :func:`make_recording` is the one place where
their output is checked and converted to SI units. Everything downstream may assume:
finite ``float64`` arrays of shape (N, 3), gyroscope in rad/s, accelerometer (specific
force) in m/s^2, one common sample rate in Hz.
"""

from __future__ import annotations

import difflib
from collections.abc import Mapping
from dataclasses import dataclass, field

import numpy as np

from .errors import InputError

GYR_UNITS = {"rad/s": 1.0, "deg/s": np.pi / 180.0}
ACC_UNITS = {"m/s^2": 1.0, "g": 9.80665}

#: A human limb segment does not turn faster than this (rad/s, about 2000 deg/s); a
#: gyroscope peaking above it is most likely in deg/s.
MAX_LIMB_RATE = 35.0
#: A median accelerometer norm in this range (m/s^2 after conversion) is ~1 g expressed
#: in g: the data are most likely in g, not m/s^2.
ACC_LOOKS_LIKE_G = (0.5, 2.0)

#: Largest relative deviation of one sampling interval from the median interval that is
#: still treated as regular sampling (timestamps of wireless sensors jitter a little).
#: Beyond it loading stops: imucal never resamples, because a resampled gap would be
#: invented data that the estimate then fits.
#: Plausible sample rates of body-worn IMUs, Hz.
MIN_RATE_HZ = 1.0
MAX_RATE_HZ = 10_000.0
TIME_JITTER_TOLERANCE = 0.1

#: Longest run of non-finite samples (NaN or Inf: a dropped packet) inside a recording that
#: is filled by linear interpolation, s. Human limb motion has almost no energy above
#: 6 Hz; over 0.05 s (under a third of such a period) a straight line stays close to it.
#: A longer gap stops loading.
MAX_INTERPOLATED_GAP_S = 0.05
#: Largest share of one signal's samples that may be interpolated; beyond it the signal
#: is more repair than measurement and loading stops.
MAX_INTERPOLATED_FRACTION = 0.05

#: Common spellings of the accepted units, used only to suggest the right name.
_UNIT_ALIASES = {
    "dps": "deg/s", "deg/sec": "deg/s", "degrees/s": "deg/s", "°/s": "deg/s",
    "rad/sec": "rad/s", "rps": "rad/s", "radians/s": "rad/s",
    "m/s2": "m/s^2", "m/s²": "m/s^2", "m/s**2": "m/s^2", "mps2": "m/s^2", "m s^-2": "m/s^2",
    "G": "g", "gn": "g", "g0": "g",
}


@dataclass(frozen=True)
class SensorData:
    """One inertial sensor: ``gyr`` in rad/s and ``acc`` in m/s^2, each (N, 3), own frame."""

    gyr: np.ndarray
    acc: np.ndarray


@dataclass(frozen=True)
class Recording:
    """A validated multi-sensor recording.

    Attributes
    ----------
    rate : float
        Sample rate in Hz.
    sensors : Mapping[str, SensorData]
        Sensor name -> data, in file order.
    time : numpy.ndarray
        (N,) sample times in seconds (from the file, else ``arange(N) / rate``).
    source : str
        Path the recording came from (``"<stdin>"`` for ``-``), used in messages.
    units : Mapping[str, Mapping[str, str]]
        Units the file declared per sensor (``{"thigh": {"gyr": "deg/s", "acc": "g"}}``),
        before conversion to SI.
    warnings : list[str]
        Notes from loading that did not stop it (plain-language, one line each).
    """

    rate: float
    sensors: Mapping[str, SensorData]
    time: np.ndarray
    source: str = "<memory>"
    units: Mapping[str, Mapping[str, str]] = field(default_factory=dict)
    warnings: list[str] = field(default_factory=list)

    @property
    def n_samples(self) -> int:
        return int(self.time.shape[0])

    @property
    def duration(self) -> float:
        """Duration in seconds (N / rate)."""
        return self.n_samples / self.rate

    def sensor(self, name: str) -> SensorData:
        """The sensor called ``name``; an :class:`InputError` lists the ones that exist."""
        try:
            return self.sensors[name]
        except KeyError:
            close = difflib.get_close_matches(name, list(self.sensors), n=1)
            hint = f" (did you mean '{close[0]}'?)" if close else ""
            raise InputError(
                f"{self.source}: no sensor '{name}'{hint}; "
                f"sensors in this file: {', '.join(self.sensors) or 'none'}"
            ) from None


def make_recording(
    sensors: Mapping[str, Mapping[str, np.ndarray]],
    *,
    rate: float | None = None,
    time: np.ndarray | None = None,
    units: Mapping[str, Mapping[str, str]] | None = None,
    source: str = "<memory>",
) -> Recording:
    """Check raw arrays and build a :class:`Recording` in SI units.

    Parameters
    ----------
    sensors
        ``{name: {"gyr": (N, 3) array, "acc": (N, 3) array}}`` in the declared units.
    rate
        Sample rate in Hz. Optional when ``time`` is given; when both are given they must
        agree within :data:`TIME_JITTER_TOLERANCE`.
    time
        (N,) sample times in seconds, strictly increasing, every interval within
        :data:`TIME_JITTER_TOLERANCE` of the median one.
    units
        ``{name: {"gyr": "rad/s" | "deg/s", "acc": "m/s^2" | "g"}}``; missing entries
        default to rad/s and m/s^2.
    source
        Name of the file, used in every message.

    Non-finite samples (NaN or Inf, e.g. dropped packets): runs at the start or end of
    the recording are dropped from every sensor and from ``time``; runs inside it of at
    most :data:`MAX_INTERPOLATED_GAP_S` seconds are filled by linear interpolation, as
    long as they make up at most :data:`MAX_INTERPOLATED_FRACTION` of the signal. Both
    repairs are listed in ``Recording.warnings``; anything more stops loading.

    Raises
    ------
    InputError
        With one line naming ``source`` and the problem.
    """
    units = {_sensor_name(k): dict(v) for k, v in (units or {}).items()}
    if not sensors:
        raise InputError(f"{source}: no sensors found")

    raw: dict[str, dict[str, np.ndarray]] = {}
    lengths = {}
    for name, data in sensors.items():
        name = _sensor_name(name)
        arrays = {}
        for kind, table in (("gyr", GYR_UNITS), ("acc", ACC_UNITS)):
            if kind not in data or data[kind] is None:
                other = "acc" if kind == "gyr" else "gyr"
                raise InputError(
                    f"{source}: sensor '{name}' has no '{kind}' data (only '{other}'); "
                    "every sensor needs both gyr and acc"
                )
            unit = units.setdefault(name, {}).setdefault(kind, next(iter(table)))
            check_units(kind, unit, f"{source}: sensor '{name}' {kind}")
            arr = _as_n_by_3(data[kind], f"{source}: sensor '{name}' {kind}")
            with np.errstate(over="ignore"):  # overflow to Inf is reported as non-finite
                arrays[kind] = arr * table[unit]
        if arrays["gyr"].shape[0] != arrays["acc"].shape[0]:
            raise InputError(
                f"{source}: sensor '{name}' has {arrays['gyr'].shape[0]} gyr samples but "
                f"{arrays['acc'].shape[0]} acc samples; both must cover the same samples"
            )
        lengths[name] = arrays["gyr"].shape[0]
        raw[name] = arrays

    if len(set(lengths.values())) > 1:
        desc = ", ".join(f"{k}: {v}" for k, v in lengths.items())
        raise InputError(
            f"{source}: sensors have different lengths ({desc} samples); all sensors must be "
            "sampled together, so cut them to the same samples"
        )
    n = next(iter(lengths.values()))
    if n < 2:
        raise InputError(
            f"{source}: only {n} sample(s); a recording needs at least 2, and an estimate "
            "a few seconds of motion"
        )

    rate_out, time_out = _check_timing(rate, time, n, source)
    kept, notes = _repair_non_finite(raw, rate_out, time_out, source)
    converted = {name: SensorData(gyr=a["gyr"][kept], acc=a["acc"][kept]) for name, a in
                 raw.items()}
    return Recording(
        rate=rate_out, sensors=converted, time=time_out[kept], source=source, units=units,
        warnings=notes + _unit_warnings(converted, units) + _stuck_warnings(converted),
    )


def _sensor_name(name) -> str:
    """Sensor names are text: h5py gives bytes for a group name that is not UTF-8, most
    likely Latin-1 from an old Windows tool, and Latin-1 decodes any bytes."""
    return name.decode("latin-1") if isinstance(name, bytes) else str(name)


def check_units(kind: str, unit, what: str) -> None:
    """Raise an :class:`InputError` naming ``what`` unless ``unit`` is known for ``kind``.

    ``kind`` is ``"gyr"`` or ``"acc"``; the message suggests the accepted spelling of a
    common alias (``dps`` -> ``deg/s``).
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
    raise InputError(f"{what}: unknown units {text[:40]!r}{hint}; use one of {', '.join(table)}")


def _repair_non_finite(raw, rate: float, time: np.ndarray, source: str):
    """Drop non-finite samples at the ends, interpolate short gaps inside; see make_recording.

    Returns the slice of samples kept and the warnings describing what was done. The
    arrays in ``raw`` are interpolated in place.
    """
    bad = {(name, kind): ~np.isfinite(arr).all(axis=1)
           for name, arrays in raw.items() for kind, arr in arrays.items()}
    any_bad = np.logical_or.reduce(list(bad.values()))
    if not any_bad.any():
        return slice(None), []
    n = any_bad.shape[0]
    for (name, kind), rows in bad.items():
        if rows.all():
            raise InputError(
                f"{source}: sensor '{name}' {kind} has no finite sample (all NaN or Inf)"
            )
    good = np.flatnonzero(~any_bad)
    if good.size < 2:
        raise InputError(
            f"{source}: fewer than 2 samples are finite (not NaN or Inf) in every sensor at once"
        )
    first, last = int(good[0]), int(good[-1])
    max_gap = int(np.floor(MAX_INTERPOLATED_GAP_S * rate + 1e-9))
    notes = []
    for (name, kind), rows in bad.items():
        inner = rows[first:last + 1]
        if not inner.any():
            continue
        starts, lengths = _runs(inner)
        what = f"{source}: sensor '{name}' {kind}"
        longest = int(np.argmax(lengths))
        if lengths[longest] > max_gap:
            i = first + int(starts[longest])
            raise InputError(
                f"{what} has a gap of {lengths[longest]} non-finite samples (NaN or Inf, "
                f"{lengths[longest] / rate:g} s) from t={time[i]:g} s; imucal interpolates "
                f"gaps of at most {MAX_INTERPOLATED_GAP_S:g} s ({max_gap} samples); repair "
                "the data, or cut the file before or after the gap"
            )
        count = int(inner.sum())
        if count > MAX_INTERPOLATED_FRACTION * n:
            raise InputError(
                f"{what} has {count} non-finite samples (NaN or Inf), {count / n:.1%} of "
                f"{n}; imucal interpolates at most {MAX_INTERPOLATED_FRACTION:.0%}"
            )
        arr = raw[name][kind]
        index = np.arange(first, last + 1)
        fine = ~inner
        for c in range(3):
            column = arr[first:last + 1, c]
            column[inner] = np.interp(index[inner], index[fine], column[fine])
        notes.append(
            f"sensor '{name}' {kind}: {count} non-finite sample(s) (NaN or Inf) in "
            f"{len(lengths)} gap(s), the longest {lengths[longest]} sample(s) "
            f"({lengths[longest] / rate:g} s), filled by linear interpolation"
        )
    if first > 0 or last < n - 1:
        notes.insert(0, (
            f"dropped {first} sample(s) at the start and {n - 1 - last} at the end where some "
            f"sensor has non-finite values (NaN or Inf); the recording now runs from "
            f"t={time[first]:g} to {time[last]:g} s"
        ))
    return slice(first, last + 1), notes


def _runs(mask: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Start indices and lengths of the runs of True in a 1-D boolean ``mask``."""
    edges = np.diff(np.concatenate([[0], mask.astype(np.int8), [0]]))
    starts = np.flatnonzero(edges == 1)
    return starts, np.flatnonzero(edges == -1) - starts


def _unit_warnings(sensors: Mapping[str, SensorData], units) -> list[str]:
    """Plain-language doubts about the declared units, with the evidence."""
    notes = []
    for name, sd in sensors.items():
        with np.errstate(over="ignore"):  # absurd values overflow to Inf, still evidence
            peak = float(np.linalg.norm(sd.gyr, axis=1).max())
            median = float(np.median(np.linalg.norm(sd.acc, axis=1)))
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
    return notes


def _stuck_warnings(sensors: Mapping[str, SensorData]) -> list[str]:
    """Signals that never change: real sensors always show some noise, so such a signal
    comes from a dead, disconnected or saturated sensor (or a filler value)."""
    notes = []
    for name, sd in sensors.items():
        for kind, unit in (("gyr", "rad/s"), ("acc", "m/s^2")):
            arr = getattr(sd, kind)
            if (arr == arr[0]).all():
                value = ", ".join(f"{v:g}" for v in arr[0])
                notes.append(
                    f"sensor '{name}' {kind} never changes (all {arr.shape[0]} samples are "
                    f"[{value}] {unit}): a dead or disconnected sensor? estimates that use "
                    "it have nothing to go on"
                )
    return notes


def _as_n_by_3(value, what: str) -> np.ndarray:
    if np.iscomplexobj(value):
        raise InputError(f"{what} holds complex numbers; expected real numbers")
    try:
        arr = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError, OverflowError):
        raise InputError(f"{what} is not numeric") from None
    if arr.ndim == 2 and arr.shape[1] == 3:
        return np.ascontiguousarray(arr)
    if arr.ndim == 2 and arr.shape[0] == 3 and arr.shape[1] != 3:
        raise InputError(
            f"{what} has shape {arr.shape}: looks transposed, expected (N, 3) with one row "
            "per sample (transpose it)"
        )
    raise InputError(
        f"{what} has shape {arr.shape}, expected (N, 3): one row per sample, columns x, y, z"
    )


def _check_plausible_rate(rate: float, source: str, origin: str = "") -> None:
    """Body-worn IMUs sample at a few Hz to a few kHz; outside MIN/MAX_RATE_HZ the number
    is a unit mistake (ms for s, kHz for Hz), not a sample rate."""
    if not MIN_RATE_HZ <= rate <= MAX_RATE_HZ:
        raise InputError(
            f"{source}: sample rate {rate:g} Hz{origin} is outside the {MIN_RATE_HZ:g} to "
            f"{MAX_RATE_HZ:g} Hz of body-worn IMUs; check the rate's units"
        )


def _check_timing(rate, time, n: int, source: str) -> tuple[float, np.ndarray]:
    if rate is not None:
        try:
            rate = float(rate)
        except (TypeError, ValueError, OverflowError):
            raise InputError(
                f"{source}: sample rate {str(rate)[:40]!r} is not a number of Hz"
            ) from None
        if not np.isfinite(rate) or rate <= 0:
            raise InputError(
                f"{source}: sample rate must be a positive number of Hz, got {rate:g}; fix "
                "the 'sample_rate' attribute or give --rate"
            )
        _check_plausible_rate(rate, source)
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
        return rate, time_out

    if np.iscomplexobj(time):
        raise InputError(f"{source}: 'time' holds complex numbers; expected seconds")
    try:
        time = np.asarray(time, dtype=np.float64).reshape(-1)
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
    _check_plausible_rate(time_rate, source, " from the 'time' steps (are they in seconds?)")
    if rate is not None and abs(time_rate - rate) > TIME_JITTER_TOLERANCE * rate:
        raise InputError(
            f"{source}: 'sample_rate' says {rate:g} Hz but 'time' says {time_rate:g} Hz; "
            "fix one of them (or drop --rate)"
        )
    return (rate if rate is not None else time_rate), time
