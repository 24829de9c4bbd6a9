"""The validated recording object every estimator receives.

Loaders (``imucal.loaders``) parse files; :func:`make_recording` is the one place where
their output is checked and converted to SI units: ``float64`` arrays of shape (N, 3),
gyroscope in rad/s, accelerometer (specific force) in m/s^2, one common sample rate in Hz.

Non-finite samples (NaN or Inf: dropped packets, a sensor that started late) are kept as
they are and described in ``Recording.gaps``: whether they matter depends on which
sensors and which time an estimate uses. :meth:`Recording.select` validates and repairs
exactly that part; what it returns (and what :meth:`Recording.sensor` returns) is finite,
which is what every estimator may assume.
"""

from __future__ import annotations

import difflib
import os
import re
from collections.abc import Mapping
from dataclasses import dataclass, field

import numpy as np

from .errors import InputError
from .settings import as_real, is_bool

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
class SensorData:
    """One inertial sensor: ``gyr`` in rad/s and ``acc`` in m/s^2, each (N, 3), own frame."""

    gyr: np.ndarray
    acc: np.ndarray

    def __post_init__(self) -> None:
        # arrays, also when built by hand from lists (select failed on those)
        for name in ("gyr", "acc"):
            value = getattr(self, name)
            if not isinstance(value, np.ndarray):
                object.__setattr__(self, name, np.asarray(value, dtype=np.float64))


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


@dataclass(frozen=True)
class Recording:
    """A checked multi-sensor recording.

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
    gaps : tuple[Gap, ...]
        Runs of non-finite samples left in ``sensors``, by sensor, signal and time; empty
        for a recording returned by :meth:`select`.
    notes : tuple[str, ...]
        The warnings about the file as a whole (not about one sensor), which every
        :meth:`select` passes on.
    window : tuple[int, int] | None
        For a recording returned by :meth:`select`: the samples ``[i0, i1)`` that form
        the window it checked; samples outside it are finite context (see ``context``).
    sensor_info : Mapping[str, Mapping]
        Per sensor, what the file said about it (vendor files, see ``imucal.formats``):
        ``serial``, ``label``, ``rate_hz`` (from its time stamps), ``start_s``,
        ``duration_s``, ``samples``, ``units_read``, ``dropped`` (samples missing from
        its counter or time stamps), ``files``. Empty for imucal's own layouts.
    provenance : Mapping[str, object]
        Where the data came from: ``format``, ``files``, ``serials``, original rates and
        how the clocks were aligned. Empty for imucal's own layouts.
    rate_from : str
        Where ``rate`` came from, as a phrase for ``imucal info`` ("the median step of
        'time'", "--rate, checked against 'time'", the common grid of a vendor export).
    """

    rate: float
    sensors: Mapping[str, SensorData]
    time: np.ndarray
    source: str = "<memory>"
    units: Mapping[str, Mapping[str, str]] = field(default_factory=dict)
    warnings: list[str] = field(default_factory=list)
    gaps: tuple[Gap, ...] = ()
    notes: tuple[str, ...] = ()
    window: tuple[int, int] | None = None
    sensor_info: Mapping[str, Mapping] = field(default_factory=dict)
    provenance: Mapping[str, object] = field(default_factory=dict)
    rate_from: str = ""

    @property
    def n_samples(self) -> int:
        """Samples per sensor (on the shared time grid)."""
        return int(self.time.shape[0])

    @property
    def duration(self) -> float:
        """Duration in seconds (N / rate)."""
        return self.n_samples / self.rate

    def sensor(self, name: str) -> SensorData:
        """The sensor called ``name``, finite over the whole recording.

        Short gaps are interpolated as :meth:`select` does; an :class:`InputError` names a
        sensor that does not exist (listing the ones that do), the first gap too long to
        repair, or non-finite samples at the recording's start or end, which only
        :meth:`select` can drop (from all the sensors an estimate uses alike).
        """
        name = self.resolve(name)
        data = self._lookup(name)
        if not any(g.sensor == name for g in self.gaps):
            return data
        used = self.select([name])
        if used.n_samples != self.n_samples:
            raise InputError(
                f"{self.source}: sensor '{name}' has non-finite samples (NaN or Inf) at the "
                "start or end of the recording; Recording.select([...], start, end) drops "
                "them from all the sensors an estimate uses"
            )
        return used.sensors[name]

    def window_slice(self, start: float | None = None, end: float | None = None) -> slice:
        """The samples of the window ``[start, end)``, s on the recording's time axis
        (None: its start / end); InputError naming the file for a window outside it or
        holding fewer than 2 samples."""
        if start is None and end is None:
            return slice(0, self.n_samples)
        seconds = []
        for what, value in (("start", start), ("end", end)):
            number = None if value is None else as_real(value)
            if value is not None and number is None:
                raise InputError(f"{self.source}: window {what} must be a finite number of "
                                 f"seconds, got {value!r}")
            seconds.append(number)
        start, end = seconds
        t0 = float(self.time[0])
        try:
            win = window_slice(self.n_samples, self.rate, None if start is None else start - t0,
                               None if end is None else end - t0, origin=t0)
        except InputError as err:
            raise InputError(f"{self.source}: {err}") from None
        if win.stop - win.start < 2:  # the window itself, whatever its samples hold
            raise InputError(f"{self.source}: {self._span(win.start, win.stop)} holds "
                             f"{win.stop - win.start} sample(s); at least 2 are needed")
        return win

    def select(
        self,
        names,
        start: float | None = None,
        end: float | None = None,
        *,
        context: bool = False,
    ) -> Recording:
        """The sensors ``names`` over the window ``[start, end)``, checked and repaired.

        This is what an estimate uses, and only this can stop it: gaps in other sensors,
        or outside the window, do not matter. Inside the window, for the named sensors:

        * non-finite samples where the recording starts or ends (a sensor that started
          late or stopped early) are dropped from all of them, with a warning;
        * gaps of at most :data:`MAX_INTERPOLATED_GAP_S` are filled by linear
          interpolation, with a warning, as long as they make up at most
          :data:`MAX_INTERPOLATED_FRACTION` of a signal's samples in the window;
        * anything more raises an :class:`InputError` naming the first offending gap,
          its signal and its time.

        Parameters
        ----------
        names
            Sensor names; a missing one raises, listing the sensors that exist.
        start, end
            Window, s on the recording's time axis (None: its start / end).
        context
            Also keep the samples around the window as far as the named sensors are
            finite there: an estimator that low-passes before cutting out its window
            (its ``start``/``end``) then has no filter transients at the window's edges.
            ``window`` of the result says which samples form the window.

        Returns
        -------
        Recording
            Finite data of the named sensors only, its ``warnings`` those that concern
            them (the file's ``notes``, repairs, units, stuck signals in the window).
        """
        names = self._named(names)
        n, source = self.n_samples, self.source
        data = {name: self._lookup(name) for name in names}
        win = self.window_slice(start, end)
        w0, w1 = win.start, win.stop
        arrays = {(name, kind): getattr(data[name], kind) for name in names
                  for kind in ("gyr", "acc")}
        gaps = {key: [g for g in self.gaps if (g.sensor, g.kind) == key] for key in arrays}
        span = self._span(w0, w1)
        a0, a1 = self._finite_span(gaps, names, w0, w1, span)
        inner = {key: [g for g in runs if 0 < g.start and g.start + g.length < n
                       and g.start < a1 and g.start + g.length > a0]
                 for key, runs in gaps.items()}
        self._refuse_first_offence(inner, a0, a1, span)

        # the file's notes about one sensor ("sensor 'Foot': ...") concern only that one
        others = {f"sensor '{other}'" for other in self.sensors if other not in names}
        notes = [note for note in self.notes if not note.startswith(tuple(others))]
        if a0 > w0 or a1 < w1:
            notes.append(self._dropped_note(gaps, w0, w1, a0, a1, span))
        repaired, bad, repairs = self._repaired(arrays, gaps, inner, a0, a1)
        notes += repairs
        c0, c1 = a0, a1
        if context:  # as far as every signal used stays finite
            before, after = np.flatnonzero(bad[:a0]), np.flatnonzero(bad[a1:])
            c0 = int(before[-1]) + 1 if before.size else 0
            c1 = a1 + int(after[0]) if after.size else n
        sensors = {name: SensorData(gyr=repaired[name, "gyr"][c0:c1],
                                    acc=repaired[name, "acc"][c0:c1]) for name in names}
        checked = {name: SensorData(gyr=s.gyr[a0 - c0:a1 - c0], acc=s.acc[a0 - c0:a1 - c0])
                   for name, s in sensors.items()}
        units = {name: dict(self.units.get(name, {})) for name in names}
        return Recording(
            rate=self.rate, sensors=sensors, time=self.time[c0:c1].copy(), source=source,
            units=units,
            warnings=notes + _unit_warnings(checked, units) + _stuck_warnings(checked),
            notes=self.notes, window=(a0 - c0, a1 - c0),
            sensor_info={n: self.sensor_info[n] for n in names if n in self.sensor_info},
            provenance=self.provenance, rate_from=self.rate_from,
        )

    def _named(self, names) -> list[str]:
        """``names`` (one name or several) as the recording's own names, each once."""
        if isinstance(names, str | bytes) or (isinstance(names, np.ndarray) and names.ndim == 0):
            names = [names]
        try:
            names = [_sensor_name(n.item() if isinstance(n, np.ndarray) else n) for n in names]
        except TypeError:  # (None, a number)
            raise InputError(f"{self.source}: sensor names must be a name or a list of names, "
                             f"got {names!r}") from None
        names = list(dict.fromkeys(self.resolve(name) for name in names))
        if not names:
            raise InputError(f"{self.source}: no sensor named; sensors in this recording: "
                             f"{', '.join(self.sensors)}")
        return names

    def _finite_span(self, gaps: dict, names: list[str], w0: int, w1: int,
                     span: str) -> tuple[int, int]:
        """The window's samples without the runs of non-finite values that touch the
        recording's first or last sample (a sensor that started late or stopped early:
        nothing lies beyond them to interpolate from); InputError when fewer than 2 are
        left, or a signal has no finite sample at all."""
        n = self.n_samples
        for (name, kind), runs in gaps.items():
            if sum(g.length for g in runs) == n:
                raise InputError(
                    f"{self.source}: sensor '{name}' {kind} has no finite sample (all NaN or "
                    "Inf)"
                )
        lead = max((g.length for r in gaps.values() for g in r if g.start == 0), default=0)
        trail = max((g.length for r in gaps.values() for g in r if g.start + g.length == n),
                    default=0)
        a0, a1 = max(w0, lead), min(w1, n - trail)
        if a1 - a0 < 2:
            raise InputError(
                f"{self.source}: fewer than 2 samples are finite (not NaN or Inf) in every "
                f"sensor used ({', '.join(names)}) at once in {span}"
            )
        return a0, a1

    def _dropped_note(self, gaps: dict, w0: int, w1: int, a0: int, a1: int,
                      span: str) -> str:
        n = self.n_samples
        culprits = [f"'{g.sensor}' {g.kind}" for runs in gaps.values() for g in runs[:1]
                    + runs[-1:] if (g.start == 0 and g.length > w0)
                    or (g.start + g.length == n and g.start < w1)]
        return (f"dropped {a0 - w0} sample(s) at the start and {w1 - a1} at the end of "
                f"{span}, where sensor {', '.join(dict.fromkeys(culprits))} has non-finite "
                "values (NaN or Inf) up to the recording's start or end; the data used run "
                f"from t={self.time[a0]:g} to {self.time[a1 - 1]:g} s")

    def _repaired(self, arrays: dict, gaps: dict, inner: dict, a0: int,
                  a1: int) -> tuple[dict, np.ndarray, list[str]]:
        """Copies of the signals with the gaps inside the window filled by linear
        interpolation, where any signal is left non-finite (``bad``), and a note per
        repaired signal."""
        repaired = {key: arr.copy() for key, arr in arrays.items()}
        bad = np.zeros(self.n_samples, dtype=bool)
        notes = []
        for key, runs in gaps.items():
            for g in runs:
                if g in inner[key]:
                    _interpolate(repaired[key], g.start, g.length)
                else:
                    bad[g.start:g.start + g.length] = True
            if inner[key]:
                longest = max(inner[key], key=lambda g: g.length)
                count = sum(min(g.start + g.length, a1) - max(g.start, a0) for g in inner[key])
                notes.append(
                    f"sensor '{key[0]}' {key[1]}: {count} non-finite sample(s) (NaN or Inf) "
                    f"in {len(inner[key])} gap(s), the first at t={inner[key][0].time:g} s, "
                    f"the longest {longest.length} sample(s) ({longest.length / self.rate:g} "
                    "s), filled by linear interpolation"
                )
        return repaired, bad, notes

    def resolve(self, name: str) -> str:
        """The name of the sensor that ``name`` addresses (see :func:`match_sensor`).

        Raises
        ------
        InputError
            no sensor or several match ``name`` (:func:`match_sensor`); sensors whose files
            were empty are named.
        """
        if name in self.sensors:
            return name
        try:
            return match_sensor(name, list(self.sensors), self.sensor_info, self.source)
        except InputError as err:
            # the sensor asked for may be one whose file was empty: say so at once
            empty = [n for n in self.notes if "empty" in n and "not read" in n]
            if not empty:
                raise
            raise InputError(f"{err}; {'; '.join(empty)}") from None

    def _lookup(self, name: str) -> SensorData:
        return self.sensors[self.resolve(name)]

    def _span(self, i0: int, i1: int) -> str:
        if i0 == 0 and i1 == self.n_samples:
            return "the recording"
        # a start within the last sample period rounds to the end: an empty window there
        # (its first sample's index is then n)
        first = self.time[i0] if i0 < self.n_samples else self.time[-1] + 1 / self.rate
        last = self.time[i1 - 1] + 1 / self.rate if i1 > i0 else first
        return f"the window t={first:g} to {last:g} s"

    def _refuse_first_offence(self, inner, a0: int, a1: int, span: str) -> None:
        """Raise for the earliest gap that cannot be repaired, if any (see :meth:`select`)."""
        rate, max_gap = self.rate, max_gap_samples(self.rate)
        offences = []  # (time order, rank, message)
        for (name, kind), runs in inner.items():
            what = f"{self.source}: sensor '{name}' {kind}"
            long = [g for g in runs if g.length > max_gap]
            for g in long[:1]:
                more = f" (the first of {len(long)} such gaps)" if len(long) > 1 else ""
                offences.append((g.start, 0, (
                    f"{what} has a gap of {g.length} non-finite samples (NaN or Inf, "
                    f"{g.length / rate:g} s) from t={g.time:g} s in {span}{more}; imucal "
                    f"interpolates gaps of at most {MAX_INTERPOLATED_GAP_S:g} s ({max_gap} "
                    "samples); repair the data, or choose a window (--start/--end) before "
                    "or after the gap"
                )))
            count = sum(min(g.start + g.length, a1) - max(g.start, a0) for g in runs)
            if runs and count > MAX_INTERPOLATED_FRACTION * (a1 - a0):
                offences.append((runs[0].start, 1, (
                    f"{what} has {count} non-finite samples (NaN or Inf), "
                    f"{count / (a1 - a0):.1%} of {a1 - a0} in {span}, the first at "
                    f"t={runs[0].time:g} s; imucal interpolates at most "
                    f"{MAX_INTERPOLATED_FRACTION:.0%}"
                )))
        if offences:
            raise InputError(min(offences, key=lambda o: o[:2])[2])


#: Segment synonyms, so that ``--sensors thigh,shank`` finds sensors labelled "Upper Leg"
#: or "tibia". Keys and values are normalised (:func:`normalised_name`).
SEGMENT_SYNONYMS = {
    "thigh": "thigh", "upperleg": "thigh", "femur": "thigh",
    "shank": "shank", "lowerleg": "shank", "tibia": "shank", "shin": "shank",
    "foot": "foot", "calcaneus": "foot",
}
_SIDES = {"left": "left", "l": "left", "right": "right", "r": "right"}


def normalised_name(text: str) -> str:
    """Lower case without spaces, underscores, hyphens or dots: "Left Upper_Leg" ->
    "leftupperleg"."""
    return "".join(ch for ch in str(text).lower() if ch not in " _-.\t")


def segment_of(text: str) -> tuple[str | None, str | None]:
    """(side, segment) a sensor name denotes, e.g. ("left", "thigh") for "L Upper Leg";
    (None, None) when it names no known segment."""
    words = [w for w in re.split(r"[\s_\-.]+", str(text).lower()) if w]
    side = next((_SIDES[w] for w in words if w in _SIDES), None)
    rest = "".join(w for w in words if w not in _SIDES)
    for prefix in ("left", "right"):  # "leftthigh" written as one word
        if side is None and rest.startswith(prefix) and rest[len(prefix):] in SEGMENT_SYNONYMS:
            side, rest = prefix, rest[len(prefix):]
    return side, SEGMENT_SYNONYMS.get(rest)


def match_sensor(name: str, names: list[str], info: Mapping[str, Mapping] | None = None,
                 source: str = "<memory>") -> str:
    """The one sensor in ``names`` that ``name`` addresses.

    Tried in turn: the exact name; the name or the serial (``info[n]["serial"]``)
    ignoring case, spaces, underscores and hyphens; the body segment (thigh = upper leg =
    femur, shank = lower leg = tibia, foot = calcaneus) with the side when one is given.
    Raises an :class:`InputError` with the sensors there are and a "did you mean" hint
    when none or several match.
    """
    info = info or {}
    if name in names:
        return name
    key = normalised_name(name)
    for how in ("name", "serial"):
        hits = [n for n in names if key and normalised_name(n if how == "name" else
                                                info.get(n, {}).get("serial") or "") == key]
        if len(hits) == 1:
            return hits[0]
    side, segment = segment_of(name)
    if segment is not None:
        hits = [n for n in names if segment_of(n)[1] == segment
                and (side is None or segment_of(n)[0] in (side, None))]
        if side is not None and len(hits) > 1:
            hits = [n for n in hits if segment_of(n)[0] == side]
        if len(hits) == 1:
            return hits[0]
        if len(hits) > 1:
            raise InputError(
                f"{source}: sensor '{name}' is ambiguous: {', '.join(map(repr, hits))} are all "
                f"a {segment}; name one of them (or give the side, e.g. left_{segment})"
            )
    keys = {normalised_name(n): n for n in names}
    keys.update({normalised_name(v["serial"]): n for n, v in info.items() if v.get("serial")})
    close = difflib.get_close_matches(key, list(keys), n=1, cutoff=0.6)
    hint = f" (did you mean '{keys[close[0]]}'?)" if close else ""
    serials = [f"{n} ({info[n]['serial']})" if info.get(n, {}).get("serial")
               and info[n]["serial"] != n else n for n in names]
    raise InputError(
        f"{source}: no sensor '{name}'{hint}; sensors in this file: "
        f"{', '.join(serials) or 'none'}"
    )


def make_recording(
    sensors: Mapping[str, Mapping[str, np.ndarray]],
    *,
    rate: float | None = None,
    time: np.ndarray | None = None,
    units: Mapping[str, Mapping[str, str]] | None = None,
    source: str = "<memory>",
    notes: list[str] | tuple[str, ...] = (),
    rate_name: str = "the rate given",
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
    notes
        Warnings about the file as a whole (ignored CSV columns), kept by every
        :meth:`Recording.select`.
    rate_name
        What ``rate`` is called where it came from (``"--rate"``, ``"the 'sample_rate'
        attribute"``), for :attr:`Recording.rate_from`.

    Non-finite samples (NaN or Inf, e.g. dropped packets) are kept: they are listed in
    ``Recording.gaps`` and, one line per signal, in ``Recording.warnings``. Only the
    sensors and the window an estimate uses can stop it (:meth:`Recording.select`).

    Returns
    -------
    Recording
        Every sensor's ``gyr`` in rad/s and ``acc`` in m/s^2 (sensor frames, (N, 3)
        float64), ``rate`` in Hz, ``time`` in s, and what was found on the way
        (``gaps``, ``warnings``, ``units`` as given, ``rate_from``).

    Raises
    ------
    InputError
        With one line naming ``source`` and the problem.

    Examples
    --------
    >>> import numpy as np
    >>> from imucal import make_recording
    >>> t = np.arange(500) / 100.0
    >>> gyr = np.column_stack([np.sin(t), np.cos(t), 0 * t])         # rad/s
    >>> acc = np.tile([0.0, 0.0, 9.81], (500, 1))                     # m/s^2
    >>> rec = make_recording({"thigh": {"gyr": gyr, "acc": acc}}, rate=100.0)
    >>> rec.n_samples, rec.duration, rec.units["thigh"]["gyr"]
    (500, 5.0, 'rad/s')
    >>> in_deg = make_recording({"thigh": {"gyr": gyr, "acc": acc}}, rate=100.0,
    ...                         units={"thigh": {"gyr": "deg/s"}})  # converted to rad/s
    >>> bool(np.allclose(in_deg.sensor("thigh").gyr, np.radians(gyr)))
    True
    """
    if not isinstance(sensors, Mapping):
        raise InputError(f"{source}: sensors must be a mapping {{name: {{'gyr': array, "
                         f"'acc': array}}}}, got {type(sensors).__name__}")
    if not sensors:
        raise InputError(f"{source}: no sensors found")
    names = _names_once([_sensor_name(k) for k in sensors], "sensor '{}' is", source)
    units = _check_units_map(units, names, source)

    raw: dict[str, dict[str, np.ndarray]] = {}
    lengths = {}
    corrupt: list[tuple] = []  # (sensor, kind, count, first index, value): see _nonphysical
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
            corrupt += _nonphysical(arrays[kind], name, kind)
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

    rate_out, time_out, timing = _check_timing(rate, time, n, source)
    if time is None:
        rate_from = rate_name
    elif rate is None:
        rate_from = "the median step of 'time'"
    else:
        rate_from = f"{rate_name}, checked against 'time'"
    notes = list(notes) + _nonphysical_notes(corrupt, time_out) + timing
    gaps = _find_gaps(raw, time_out)
    converted = {name: SensorData(gyr=a["gyr"], acc=a["acc"]) for name, a in raw.items()}
    finite = {name: SensorData(gyr=s.gyr[_finite_rows(s)], acc=s.acc[_finite_rows(s)])
              for name, s in converted.items()}
    return Recording(
        rate=rate_out, sensors=converted, time=time_out, source=source, units=units,
        warnings=(list(notes) + _gap_warnings(gaps, raw, rate_out, n)
                  + _unit_warnings(finite, units) + _stuck_warnings(finite)),
        gaps=gaps, notes=tuple(notes), rate_from=rate_from,
    )


def _names_once(names: list[str], what: str, source) -> list[str]:
    """``names`` (keys made text), InputError if one comes twice: ``b"thigh"`` and
    ``"thigh"`` are one sensor, and one entry silently replaced the other. ``what``
    names the entry, ``{}`` standing for the name."""
    twice = sorted({n for n in names if names.count(n) > 1})
    if twice:
        raise InputError(f"{source}: {what.format(twice[0])} given twice (under keys that "
                         "differ only in type)")
    return names


def _check_units_map(units, names: list[str], source) -> dict[str, dict[str, str]]:
    """``units`` as {sensor: {"gyr"/"acc": unit}}, every sensor one of ``names``, else
    InputError: a misspelt sensor or kind ("Thigh", "gyro") left data in units it was not
    in, silently."""
    if units is None:
        return {}
    if not isinstance(units, Mapping) or not all(isinstance(v, Mapping)
                                                 for v in units.values()):
        raise InputError(f"{source}: units must be a mapping {{sensor: {{'gyr': unit, "
                         f"'acc': unit}}}}, got {units!r:.80}")
    _names_once([_sensor_name(k) for k in units], "units for sensor '{}'", source)
    out = {_sensor_name(k): dict(v) for k, v in units.items()}
    for name, kinds in out.items():
        if name not in names:
            raise InputError(f"{source}: units given for sensor '{name}', which is not among "
                             f"the sensors ({', '.join(names)})")
        wrong = sorted(set(kinds) - {"gyr", "acc"}, key=str)
        if wrong:
            raise InputError(f"{source}: units of sensor '{name}': unknown kind '{wrong[0]}'; "
                             "give 'gyr' and/or 'acc'")
    return out


def corrupt_readings(arr: np.ndarray, kind: str) -> np.ndarray:
    """(N,) readings of ``arr`` (N, 3, SI units) that are no measurement: beyond
    :data:`NONPHYSICAL`, or spikes beyond :data:`SENSOR_RANGE`: runs of at most
    :data:`MAX_SPIKE_SAMPLES` at least :data:`SPIKE_RATIO` times the readings on either
    side (a missing reading or the signal's end counts as 0)."""
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


def _nonphysical(arr: np.ndarray, name: str, kind: str) -> list[tuple]:
    """Readings of ``arr`` (N, 3, SI units) that are no measurement
    (:func:`corrupt_readings`) set to NaN in place, so they become gaps: [(name, kind,
    count, first index, its largest value)] or []. Before, one 1e30 sample stopped every
    estimate with "no restart produced a finite result", naming neither the sample nor
    the cause (a new-user review)."""
    bad = corrupt_readings(arr, kind)
    if not bad.any():
        return []
    i = int(np.flatnonzero(bad)[0])
    value = float(np.abs(arr[i]).max())
    arr[bad] = np.nan
    return [(name, kind, int(bad.sum()), i, value)]


def _nonphysical_notes(corrupt: list[tuple], time: np.ndarray) -> list[str]:
    return [f"sensor '{name}' {kind}: {count} reading(s) beyond any body-worn sensor's "
            f"range ({SENSOR_RANGE[kind]:g} {'rad/s' if kind == 'gyr' else 'm/s^2'}), the "
            f"first {value:.6g} at t="
            f"{time[i]:g} s (sample {i}): not a physical reading (a corrupt packet?), "
            "treated as missing"
            for name, kind, count, i, value in corrupt]


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


def max_gap_samples(rate: float) -> int:
    """Longest gap, in samples at ``rate`` Hz, that is filled by interpolation."""
    return int(np.floor(MAX_INTERPOLATED_GAP_S * rate + 1e-9))


def _find_gaps(raw, time: np.ndarray) -> tuple[Gap, ...]:
    gaps = []
    for name, arrays in raw.items():
        for kind, arr in arrays.items():
            starts, lengths = _runs(~np.isfinite(arr).all(axis=1))
            gaps += [Gap(name, kind, int(i), int(k), float(time[i]))
                     for i, k in zip(starts, lengths, strict=True)]
    return tuple(gaps)


def _finite_rows(sd: SensorData) -> np.ndarray:
    return np.isfinite(sd.gyr).all(axis=1) & np.isfinite(sd.acc).all(axis=1)


def _gap_warnings(gaps, raw, rate: float, n: int) -> list[str]:
    """One line per signal with gaps: where they are and what an estimate using it will do."""
    notes = []
    max_gap = max_gap_samples(rate)
    for name, arrays in raw.items():
        for kind in arrays:
            runs = [g for g in gaps if (g.sensor, g.kind) == (name, kind)]
            if not runs:
                continue
            count = sum(g.length for g in runs)
            if count == n:
                notes.append(f"sensor '{name}' {kind} has no finite sample (all NaN or Inf): "
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


def _interpolate(arr: np.ndarray, start: int, length: int) -> None:
    """Fill ``arr[start:start + length]`` in place on the line between its finite neighbours."""
    before, after = arr[start - 1], arr[start + length]
    weight = (np.arange(1, length + 1) / (length + 1))[:, None]
    arr[start:start + length] = before + weight * (after - before)


def _runs(mask: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Start indices and lengths of the runs of True in a 1-D boolean ``mask``."""
    edges = np.diff(np.concatenate([[0], mask.astype(np.int8), [0]]))
    starts = np.flatnonzero(edges == 1)
    return starts, np.flatnonzero(edges == -1) - starts


def _unit_warnings(sensors: Mapping[str, SensorData], units) -> list[str]:
    """Plain-language doubts about the declared units, with the evidence."""
    notes = []
    for name, sd in sensors.items():
        if sd.gyr.shape[0] == 0:
            continue
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
        elif not ACC_PLAUSIBLE[0] <= median <= ACC_PLAUSIBLE[1]:
            notes.append(f"sensor '{name}' acc "
                         f"{acc_scale_doubt(median)} (--acc-units or a 'units' attribute)")
    return notes


def acc_scale_doubt(median: float) -> str:
    """Why a median specific force (m/s^2) outside :data:`ACC_PLAUSIBLE` points to wrong
    accelerometer units, naming the likely mistake."""
    if median < ACC_PLAUSIBLE[0]:
        return (f"has a median norm of {median:.3g} m/s^2, far below 1 g = 9.81 m/s^2: the "
                "declared units look wrong (m/s^2 or g data declared as mg?), or gravity "
                "was removed (free acceleration)")
    return (f"has a median norm of {median:.4g} m/s^2 = {median / ACC_UNITS['g']:.3g} g, far above "
            "1 g: the declared units look wrong (m/s^2 data declared as g, or mg data as g "
            "or m/s^2?)")


def _stuck_warnings(sensors: Mapping[str, SensorData]) -> list[str]:
    """Signals that never change: real sensors always show some noise, so such a signal
    comes from a dead, disconnected or saturated sensor (or a filler value)."""
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


def window_slice(
    n: int, rate: float, start: float | None, end: float | None, *, origin: float = 0.0
) -> slice:
    """Sample slice for the window [start, end) in seconds from the first sample.

    ``origin`` is the first sample's time on the recording's own time axis; messages
    give times on that axis, as the user typed them.

    Raises
    ------
    InputError
        ``start`` or ``end`` is not finite or lies outside the recording, or ``end`` is not
        after ``start``.
    """
    duration = n / rate
    s = 0.0 if start is None else float(start)
    e = duration if end is None else float(end)
    span = f"the recording runs from {origin:g} to {origin + duration:g} s"
    if not (np.isfinite(s) and np.isfinite(e)):
        raise InputError(f"window start/end must be finite numbers of seconds, got {s}, {e}")
    if not 0 <= s < duration:
        raise InputError(f"window start {origin + s:g} s lies outside the recording ({span})")
    if e <= s:
        raise InputError(f"window end {origin + e:g} s must be after its start {origin + s:g} s")
    if e > duration + 0.5 / rate:
        raise InputError(f"window end {origin + e:g} s lies beyond the recording ({span})")
    return slice(int(round(s * rate)), min(n, int(round(e * rate))))


def check_recording(recording) -> None:
    """InputError unless ``recording`` is a :class:`Recording` (a file name, say, failed
    with an AttributeError deep inside)."""
    if not isinstance(recording, Recording):
        hint = (" (load it first: imucal.load_recording(path))"
                if isinstance(recording, str | os.PathLike) else "")
        raise InputError(f"expected a Recording, got {type(recording).__name__}{hint}")


def check_plausible_rate(rate: float, source: str = "", origin: str = "",
                         fix: str = "check the rate's units") -> None:
    """InputError unless ``rate`` (Hz) lies within MIN/MAX_RATE_HZ: body-worn IMUs sample
    at a few Hz to a few kHz, and outside that the number is a unit mistake (ms for s,
    kHz for Hz), not a sample rate. The one check of every rate imucal meets (given,
    stored, from a file's time steps or a device's stamps); ``source`` and ``origin``
    say whose and where from, ``fix`` what to check."""
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


def check_rate(rate) -> float:
    """A sample rate in Hz as a float, checked (:func:`check_plausible_rate`).

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


def _check_timing(rate, time, n: int, source: str) -> tuple[float, np.ndarray, list[str]]:
    """The rate and time axis of a recording, and notes on how they were reconciled."""
    if rate is not None:
        try:
            if is_bool(rate):  # (True read as 1 Hz)
                raise TypeError
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


def estimator_window(recording: Recording, names, start, end) -> tuple[Recording, dict]:
    """The sensors ``names`` in the window ``start``..``end`` (s on the recording's time
    axis), checked and repaired (Recording.select), and the estimators' keywords for it:
    the window counted from the first sample they are given, and that sample's time on the
    recording's clock (``time_origin``)."""
    used = recording.select(names, start, end, context=True)
    i0, i1 = used.window
    # Whole samples, so the estimators cut exactly the samples select checked; the finite
    # context around them keeps filter transients off the window's edges.
    rel = {"start": None if start is None and i0 == 0 else i0 / used.rate,
           "end": None if end is None and i1 == used.n_samples else i1 / used.rate,
           "time_origin": float(used.time[0])}
    return used, rel
