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

import os
from collections.abc import Mapping
from dataclasses import dataclass, field

import numpy as np

from .equality import ByValue
from .errors import InputError
from .sensor_checks import (
    ACC_UNITS,
    GYR_UNITS,
    MAX_INTERPOLATED_FRACTION,
    MAX_INTERPOLATED_GAP_S,
    Gap,
    check_units,
    find_gaps,
    finite_rows,
    gap_warnings,
    interpolate_gap,
    max_gap_samples,
    nonphysical,
    nonphysical_notes,
    stuck_warnings,
    unit_warnings,
)
from .sensor_names import match_sensor
from .settings import as_real
from .timing import check_timing, reported_rate


@dataclass(frozen=True, eq=False)
class SensorData(ByValue):
    """One inertial sensor: ``gyr`` in rad/s and ``acc`` in m/s^2, each (N, 3), own frame."""

    gyr: np.ndarray
    acc: np.ndarray

    def __post_init__(self) -> None:
        # arrays, also when built by hand from lists (select failed on those)
        for name in ("gyr", "acc"):
            value = getattr(self, name)
            if not isinstance(value, np.ndarray):
                object.__setattr__(self, name, np.asarray(value, dtype=np.float64))


@dataclass(frozen=True, eq=False)
class Recording(ByValue):
    """A checked multi-sensor recording.

    Build one with :func:`make_recording` (from arrays, in any declared units) or a
    loader; one built directly is checked for what every recording holds (a rate,
    (N, 3) arrays of one length, no non-finite sample outside ``gaps``), with the SI
    units its arrays are in wherever ``units`` names none.

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

    def __post_init__(self) -> None:
        # a Recording built by hand (the fields are public) met no loader's checks: a NaN,
        # a missing unit, sensors of other lengths ended in KeyError, TypeError or a
        # motion blamed for a NaN deep inside (a new-user trial of the Python API)
        _check_fields(self)

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

        ``name`` may also be the sensor's serial or body segment (:meth:`resolve`). Short
        gaps are interpolated as :meth:`select` does.

        Returns
        -------
        SensorData
            ``gyr`` in rad/s and ``acc`` in m/s^2, each (N, 3) float64 in the sensor's own
            frame, N = :attr:`n_samples`, all finite. Without gaps, the recording's own
            arrays (not copies).

        Raises
        ------
        InputError
            A sensor that does not exist (listing the ones that do), the first gap too long
            to repair, or non-finite samples at the recording's start or end, which only
            :meth:`select` can drop (from all the sensors an estimate uses alike).

        Examples
        --------
        >>> import imucal
        >>> rec = imucal.load_recording("sample_data/walking.h5")
        >>> thigh = rec.sensor("thigh")
        >>> thigh.gyr.shape, thigh.acc.shape    # rad/s, m/s^2, thigh sensor frame
        ((3000, 3), (3000, 3))
        >>> rec.sensor("Upper Leg") is thigh    # by body segment
        True
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
        (None: its start / end).

        Returns
        -------
        slice
            Sample indices ``[i0, i1)`` into ``time`` and every sensor's arrays, step None;
            ``slice(0, n_samples)`` when neither ``start`` nor ``end`` is given.

        Raises
        ------
        InputError
            Naming the file, for a ``start`` or ``end`` that is not a finite number, a
            window outside the recording, or one holding fewer than 2 samples.

        Examples
        --------
        >>> import imucal
        >>> rec = imucal.load_recording("sample_data/walking.h5")  # 100 Hz, t = 0..30 s
        >>> rec.window_slice(1.0, 3.0)
        slice(100, 300, None)
        >>> rec.window_slice(end=0.5)
        slice(0, 50, None)
        """
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
            (its ``start``/``end``) then has no filter transients at the window's edges,
            and an axis can be checked against the rests around a window that has none
            of its own (as the command line checks it: a window cut out alone, the left
            knee of the shared recording at 60-75 s, was `use with care` where the
            command line refused it). ``window`` of the result says which samples form
            the window.

        Returns
        -------
        Recording
            Finite data of the named sensors only (rad/s, m/s^2, (M, 3) float64, sensor
            frames), ``time`` in s on the recording's clock, ``gaps`` empty, ``window``
            the samples of the window checked (all M of them unless ``context``), its
            ``warnings`` those that concern them (the file's ``notes``, repairs, units,
            stuck signals in the window).

        Raises
        ------
        InputError
            A name no sensor answers to (or none at all), a window outside the recording,
            a signal with no finite sample, fewer than 2 samples finite in every named
            sensor at once, or a gap in the window too long or too frequent to repair.

        Examples
        --------
        >>> import imucal
        >>> rec = imucal.load_recording("sample_data/walking.h5")
        >>> used = rec.select(["thigh", "shank"], 1.0, 3.0)   # t = 1 to 3 s
        >>> list(used.sensors), used.n_samples, float(used.time[0]), used.window
        (['thigh', 'shank'], 200, 1.0, (0, 200))
        >>> wide = rec.select(["thigh", "shank"], 1.0, 3.0, context=True)
        >>> wide.n_samples, wide.window                       # finite context kept
        (3000, (100, 300))
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
            warnings=notes + unit_warnings(checked, units) + stuck_warnings(checked),
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
                    f"{self.source}: sensor '{name}' {kind} has no finite sample (all NaN, Inf "
                    "or beyond any body-worn sensor's range)"
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
                    interpolate_gap(repaired[key], g.start, g.length)
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

        Returns
        -------
        str
            The key in ``sensors``: ``name`` itself when it is one, else the one sensor
            whose name, serial or body segment (with side) ``name`` gives.

        Raises
        ------
        InputError
            ``name`` is not text, or no sensor or several match it (:func:`match_sensor`);
            sensors whose files were empty are named.

        Examples
        --------
        >>> import imucal
        >>> rec = imucal.load_recording("sample_data/walking.h5")
        >>> rec.resolve("thigh"), rec.resolve("SHANK"), rec.resolve("tibia")
        ('thigh', 'shank', 'shank')
        """
        if not isinstance(name, str):  # (a list made `in` raise TypeError: a new-user trial)
            raise InputError(f"{self.source}: a sensor name is text, got "
                             f"{type(name).__name__} {str(name)[:40]}")
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


def make_recording(
    sensors: Mapping[str, Mapping[str, np.ndarray] | SensorData],
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
        ``{name: {"gyr": (N, 3) array, "acc": (N, 3) array}}`` in the declared units (or
        ``{name: SensorData}``, e.g. a recording's ``sensors`` after filtering).
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
        With one line naming ``source`` and the problem: ``sensors`` is not a mapping or
        is empty, a name is empty or given twice, a sensor has no ``gyr`` or no ``acc``,
        an array is not (N, 3) real numbers, ``units`` names an unknown sensor, kind or
        unit, a sensor's ``gyr`` and ``acc`` or two sensors differ in length, fewer than
        2 samples, or a rate or time axis :func:`imucal.timing.check_timing` refuses.

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
    if any(not n.strip() for n in names):  # (no file could name it, nor store it)
        raise InputError(f"{source}: a sensor's name is empty; name every sensor")
    units = _check_units_map(units, names, source)

    raw: dict[str, dict[str, np.ndarray]] = {}
    lengths = {}
    corrupt: list[tuple] = []  # (sensor, kind, count, first index, value): see nonphysical
    for name, data in sensors.items():
        name = _sensor_name(name)
        if isinstance(data, SensorData):  # a recording's own sensors, e.g. filtered
            declared = {k: u for k, u in units.get(name, {}).items()
                        if u not in ("rad/s", "m/s^2")}
            if declared:  # (rec.units, the file's, converted them a second time: a review)
                raise InputError(f"{source}: sensor '{name}' is a SensorData, in rad/s and "
                                 f"m/s^2 already; give it no other units (got {declared})")
            data = {"gyr": data.gyr, "acc": data.acc}
        if not isinstance(data, Mapping):
            raise InputError(f"{source}: sensor '{name}' must be a mapping {{'gyr': array, "
                             f"'acc': array}} or a SensorData, got {type(data).__name__}")
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
            corrupt += nonphysical(arrays[kind], name, kind)
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

    rate_out, time_out, timing = check_timing(rate, time, n, source)
    if time is None:
        rate_from = rate_name
    elif rate is None:
        rate_from = "the median step of 'time'"
    else:
        rate_from = f"{rate_name}, checked against 'time'"
    notes = list(notes) + nonphysical_notes(corrupt, time_out) + timing
    gaps = find_gaps(raw, time_out)
    converted = {name: SensorData(gyr=a["gyr"], acc=a["acc"]) for name, a in raw.items()}
    finite = {name: SensorData(gyr=s.gyr[finite_rows(s)], acc=s.acc[finite_rows(s)])
              for name, s in converted.items()}
    return Recording(
        rate=rate_out, sensors=converted, time=time_out, source=source, units=units,
        warnings=(list(notes) + gap_warnings(gaps, raw, rate_out, n)
                  + unit_warnings(finite, units) + stuck_warnings(finite)),
        gaps=gaps, notes=tuple(notes), rate_from=rate_from,
    )


def _check_fields(rec: Recording) -> None:
    """What every :class:`Recording` holds, however built: a rate in Hz, (N,) times,
    sensors of (N, 3) real arrays, and no non-finite sample that ``gaps`` does not list
    (those :meth:`Recording.sensor` would pass on). Lists become arrays, and a sensor's
    missing units the SI ones its arrays are in."""
    source = rec.source
    rate = as_real(rec.rate)
    if rate is None or rate <= 0:
        raise InputError(f"{source}: the recording's rate must be a positive number of Hz, "
                         f"got {rec.rate!r:.40}")
    object.__setattr__(rec, "rate", rate)
    time = np.asarray(rec.time, dtype=np.float64) if rec.time is not None else None
    if time is None or time.ndim != 1 or time.size < 2 or not np.isfinite(time).all():
        raise InputError(f"{source}: the recording's time must be (N,) finite seconds with "
                         "N >= 2 (build it with imucal.make_recording, which makes it from "
                         "the rate)")
    object.__setattr__(rec, "time", time)
    if not isinstance(rec.sensors, Mapping) or not rec.sensors:
        raise InputError(f"{source}: the recording's sensors must be a non-empty mapping "
                         "{name: SensorData}")
    for name, data in rec.sensors.items():
        _check_sensor(name, data, time.size, rec.gaps, source)
    if rec.units is None:  # (as make_recording takes it)
        object.__setattr__(rec, "units", {})
    if not isinstance(rec.units, Mapping) or not all(
            isinstance(v, Mapping) for v in rec.units.values()):
        raise InputError(f"{source}: the recording's units must be a mapping {{sensor: "
                         f"{{'gyr': unit, 'acc': unit}}}}, got {rec.units!r:.60}")
    units = {n: dict(rec.units.get(n, {})) for n in rec.sensors}
    for kinds in units.values():
        kinds.setdefault("gyr", next(iter(GYR_UNITS)))
        kinds.setdefault("acc", next(iter(ACC_UNITS)))
    object.__setattr__(rec, "units", {**rec.units, **units})


def _check_sensor(name, data, n: int, gaps, source) -> None:
    if not isinstance(name, str) or not isinstance(data, SensorData):
        raise InputError(f"{source}: sensor {name!r:.40}: a recording's sensors map names "
                         f"(str) to SensorData, got {type(data).__name__}; "
                         "imucal.make_recording builds one from arrays")
    listed = {g.kind for g in gaps if g.sensor == name}
    for kind in ("gyr", "acc"):
        arr = getattr(data, kind)
        if arr.shape != (n, 3) or arr.dtype.kind not in "iuf":
            raise InputError(f"{source}: sensor '{name}' {kind} is {arr.shape} "
                             f"{arr.dtype}; a recording of {n} samples needs ({n}, 3) numbers")
        if kind not in listed and not np.isfinite(arr).all():
            first = int(np.flatnonzero(~np.isfinite(arr).all(axis=1))[0])
            raise InputError(
                f"{source}: sensor '{name}' {kind} is NaN or Inf at sample {first} "
                "and the recording lists no gaps; build it with imucal.make_recording, "
                "which finds them (interpolating short ones, refusing long ones)")


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


def _sensor_name(name) -> str:
    """Sensor names are text: h5py gives bytes for a group name that is not UTF-8, most
    likely Latin-1 from an old Windows tool, and Latin-1 decodes any bytes."""
    return name.decode("latin-1") if isinstance(name, bytes) else str(name)


def _as_n_by_3(value, what: str) -> np.ndarray:
    if np.iscomplexobj(value):
        raise InputError(f"{what} holds complex numbers; expected real numbers")
    if getattr(value, "dtype", None) == np.bool_:  # (the estimators refuse them too)
        raise InputError(f"{what} holds True/False values; expected real numbers")
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

    ``n`` samples at ``rate`` Hz; ``start``/``end`` None for the recording's start / end.
    ``origin`` is the first sample's time on the recording's own time axis; messages
    give times on that axis, as the user typed them.

    Returns
    -------
    slice
        ``slice(round(start * rate), min(n, round(end * rate)))``; it may hold fewer than
        2 samples (:meth:`Recording.window_slice` refuses those).

    Raises
    ------
    InputError
        ``start`` or ``end`` is not finite or lies outside the recording, or ``end`` is not
        after ``start``.

    Examples
    --------
    >>> from imucal.recording import window_slice
    >>> window_slice(1000, 100.0, 1.0, 2.5)
    slice(100, 250, None)
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
    """Check that ``recording`` is a :class:`Recording` (a file name, say, failed with an
    AttributeError deep inside).

    Raises
    ------
    InputError
        ``recording`` is anything else; for a path, the hint to load it first.
    """
    if not isinstance(recording, Recording):
        hint = (" (load it first: imucal.load_recording(path))"
                if isinstance(recording, str | os.PathLike) else "")
        raise InputError(f"expected a Recording, got {type(recording).__name__}{hint}")


def input_info(recording: Recording, names, used: Recording) -> dict:
    """The ``input`` block of a result (docs/json.md) for the sensors ``names`` of
    ``recording`` and the part ``used`` (its window, in context) the estimate saw; with a
    sensor map, which device each name came from. Shared by the commands and by
    ``calibrate``'s joints (whose embedded results lacked ``sensor_map``).

    Returns
    -------
    dict
        ``path``, ``sensors``, ``sample_rate_hz`` (Hz), ``samples_total``, ``duration_s``
        (s, whole recording), ``units_in_file``, ``time_origin`` (s, ``used``'s first
        sample), ``load_warnings`` (``used``'s), and ``sensor_map`` ({"file", "sensors":
        name -> name in the file}) when the recording was loaded with one.
    """
    info = {
        "path": recording.source,
        "sensors": list(names),
        "sample_rate_hz": reported_rate(recording.rate),
        "samples_total": recording.n_samples,
        "duration_s": recording.duration,
        "units_in_file": {n: recording.units.get(n, {}) for n in names},
        "time_origin": float(used.time[0]),
        "load_warnings": list(used.warnings),
    }
    if "sensor_map" in recording.provenance:  # which device each name came from
        mapped = recording.provenance["sensor_map"]
        in_file = {v: k for k, v in mapped["renamed"].items()}
        info["sensor_map"] = {"file": str(mapped["file"]), "sensors": {
            m: in_file.get(m, m) for m in map(recording.resolve, names)}}
    return info


def estimator_window(recording: Recording, names, start, end) -> tuple[Recording, dict]:
    """The sensors ``names`` in the window ``start``..``end`` (s on the recording's time
    axis), checked and repaired (Recording.select), and the estimators' keywords for it:
    the window counted from the first sample they are given, and that sample's time on the
    recording's clock (``time_origin``).

    Returns
    -------
    used : Recording
        ``recording.select(names, start, end, context=True)``.
    window : dict
        ``start``, ``end`` (s from ``used``'s first sample, whole samples; each None
        where it was not given and the window reaches that end of ``used``) and ``time_origin``
        (s, ``used``'s first sample on the recording's clock).
    """
    used = recording.select(names, start, end, context=True)
    i0, i1 = used.window
    # Whole samples, so the estimators cut exactly the samples select checked; the finite
    # context around them keeps filter transients off the window's edges.
    rel = {"start": None if start is None and i0 == 0 else i0 / used.rate,
           "end": None if end is None and i1 == used.n_samples else i1 / used.rate,
           "time_origin": float(used.time[0])}
    return used, rel
