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
TIME_JITTER_TOLERANCE = 0.1


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
        (N,) sample times in seconds, strictly increasing.
    units
        ``{name: {"gyr": "rad/s" | "deg/s", "acc": "m/s^2" | "g"}}``; missing entries
        default to rad/s and m/s^2.
    source
        Name of the file, used in every message.

    Raises
    ------
    InputError
        With one line naming ``source`` and the problem.
    """
    units = {k: dict(v) for k, v in (units or {}).items()}
    if not sensors:
        raise InputError(f"{source}: no sensors found")

    converted: dict[str, SensorData] = {}
    lengths = {}
    for name, data in sensors.items():
        arrays = {}
        for kind, table in (("gyr", GYR_UNITS), ("acc", ACC_UNITS)):
            if kind not in data or data[kind] is None:
                raise InputError(f"{source}: sensor '{name}' has no '{kind}' data")
            unit = units.setdefault(name, {}).setdefault(kind, next(iter(table)))
            if unit not in table:
                raise InputError(
                    f"{source}: sensor '{name}' {kind} has unknown units '{unit}'; "
                    f"use one of {', '.join(table)}"
                )
            arr = _as_n_by_3(data[kind], f"{source}: sensor '{name}' {kind}")
            arrays[kind] = arr * table[unit]
        if arrays["gyr"].shape[0] != arrays["acc"].shape[0]:
            raise InputError(
                f"{source}: sensor '{name}' has {arrays['gyr'].shape[0]} gyr samples but "
                f"{arrays['acc'].shape[0]} acc samples"
            )
        lengths[name] = arrays["gyr"].shape[0]
        converted[name] = SensorData(**arrays)

    if len(set(lengths.values())) > 1:
        desc = ", ".join(f"{k}: {v}" for k, v in lengths.items())
        raise InputError(f"{source}: sensors have different lengths ({desc})")
    n = next(iter(lengths.values()))
    if n < 2:
        raise InputError(f"{source}: only {n} sample(s); a recording needs many seconds of data")

    for name, sd in converted.items():
        for kind in ("gyr", "acc"):
            arr = getattr(sd, kind)
            bad = ~np.isfinite(arr).all(axis=1)
            if bad.any():
                first = int(np.flatnonzero(bad)[0])
                raise InputError(
                    f"{source}: sensor '{name}' {kind} has {int(bad.sum())} non-finite "
                    f"sample(s) (NaN or Inf), the first at index {first}"
                )

    rate_out, time_out = _check_timing(rate, time, n, source)
    return Recording(
        rate=rate_out, sensors=converted, time=time_out, source=source, units=units,
        warnings=_unit_warnings(converted, units),
    )


def _unit_warnings(sensors: Mapping[str, SensorData], units) -> list[str]:
    """Plain-language doubts about the declared units, with the evidence."""
    notes = []
    for name, sd in sensors.items():
        peak = float(np.linalg.norm(sd.gyr, axis=1).max())
        if peak > MAX_LIMB_RATE:
            notes.append(
                f"sensor '{name}' gyr peaks at {peak:.0f} rad/s ({units[name]['gyr']}), faster "
                f"than a limb turns (< {MAX_LIMB_RATE:g} rad/s): is it in deg/s? "
                "(--gyr-units deg/s or a 'units' attribute)"
            )
        median = float(np.median(np.linalg.norm(sd.acc, axis=1)))
        if ACC_LOOKS_LIKE_G[0] <= median <= ACC_LOOKS_LIKE_G[1]:
            notes.append(
                f"sensor '{name}' acc has a median norm of {median:.2f} m/s^2, about 1 g in g "
                "units: is it in g? (--acc-units g or a 'units' attribute)"
            )
    return notes


def _as_n_by_3(value, what: str) -> np.ndarray:
    try:
        arr = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError):
        raise InputError(f"{what} is not numeric") from None
    if arr.ndim == 2 and arr.shape[1] == 3:
        return np.ascontiguousarray(arr)
    if arr.ndim == 2 and arr.shape[0] == 3 and arr.shape[1] != 3:
        raise InputError(f"{what} has shape {arr.shape}: looks transposed, expected (N, 3)")
    raise InputError(f"{what} has shape {arr.shape}, expected (N, 3)")


def _check_timing(rate, time, n: int, source: str) -> tuple[float, np.ndarray]:
    if rate is not None:
        try:
            rate = float(rate)
        except (TypeError, ValueError):
            raise InputError(f"{source}: sample rate '{rate}' is not a number") from None
        if not np.isfinite(rate) or rate <= 0:
            raise InputError(f"{source}: sample rate must be a positive number of Hz, got {rate}")
    if time is None:
        if rate is None:
            raise InputError(
                f"{source}: no sample rate and no time stamps; "
                "give a 'sample_rate' attribute, a 'time' column/dataset, or --rate"
            )
        return rate, np.arange(n) / rate

    time = np.asarray(time, dtype=np.float64).reshape(-1)
    if time.shape[0] != n:
        raise InputError(f"{source}: 'time' has {time.shape[0]} entries but sensors have {n}")
    if not np.isfinite(time).all():
        raise InputError(f"{source}: 'time' contains NaN or Inf")
    dt = np.diff(time)
    if (dt <= 0).any():
        i = int(np.flatnonzero(dt <= 0)[0])
        raise InputError(
            f"{source}: 'time' is not strictly increasing (t[{i}]={time[i]:g} s, "
            f"t[{i + 1}]={time[i + 1]:g} s)"
        )
    step = float(np.median(dt))
    jitter = np.abs(dt - step) / step
    if jitter.max() > TIME_JITTER_TOLERANCE:
        i = int(np.argmax(jitter))
        raise InputError(
            f"{source}: irregular sampling: interval {dt[i]:g} s at t={time[i]:g} s differs "
            f"from the median {step:g} s by more than {TIME_JITTER_TOLERANCE:.0%}; "
            "resample the recording to a constant rate first"
        )
    time_rate = 1.0 / step
    if rate is not None and abs(time_rate - rate) > TIME_JITTER_TOLERANCE * rate:
        raise InputError(
            f"{source}: 'sample_rate' says {rate:g} Hz but 'time' says {time_rate:g} Hz"
        )
    return (rate if rate is not None else time_rate), time
