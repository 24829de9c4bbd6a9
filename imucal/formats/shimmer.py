"""Shimmer Consensys CSV exports.

Layout: a first line ``"sep=<TAB>"`` (or ``sep=,``) declaring the separator; a header of
device-prefixed names ``Shimmer_<ID>_Timestamp_Unix_CAL``, ``Shimmer_<ID>_Accel_LN_X_CAL``
(or ``Accel_WR_X_CAL``), ``Shimmer_<ID>_Gyro_X_CAL``, ...; optionally a row of ``CAL``/
``RAW``; a units row (``ms``, ``m/(s^2)``, ``deg/s``); then one row per sample. The Unix
time stamps are milliseconds and may repeat and jitter (they are fitted, see
``imucal.clock``). A file may hold several devices (several prefixes). Sensors are named
``Shimmer_<ID>``; ``<ID>`` is the serial.
"""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np

from ..errors import InputError
from . import (
    RawRecording,
    RawSensor,
    ends_line,
    head_text,
    normalise_units,
    parse_table,
    read_text,
    sep_line,
    twice,
)

NAME = "Shimmer Consensys"
_COL = re.compile(r"^(?P<dev>Shimmer_[0-9A-Za-z]+)_(?P<what>.+?)(?:_(?P<cal>CAL|RAW|UNCAL))?$")
_ACC = ("Accel_LN", "Accel_WR")


def _split(lines):
    sep = sep_line(lines[0]) if lines else None
    start = 1 if sep else 0
    if sep is None and lines:
        sep = max(("\t", ",", ";"), key=lines[0].count)
    return sep, start


def sniff(path: Path) -> bool:
    """Whether ``path`` holds a Shimmer Consensys export (the plug-in ``sniff``,
    :mod:`imucal.formats`).

    Returns
    -------
    bool
        True for a ``.csv``/``.txt``/``.tsv``/``.dat`` file whose header row has a
        ``Shimmer_...Timestamp...`` column; False otherwise (folders too).
    """
    if not path.is_file() or path.suffix.lower() not in (".csv", ".txt", ".tsv", ".dat"):
        return False
    lines = head_text(path, 4096).splitlines()
    sep, start = _split(lines)
    if len(lines) <= start:
        return False
    cols = [c.strip().strip('"') for c in lines[start].split(sep)]
    return any(c.startswith("Shimmer_") and "Timestamp" in c for c in cols)


def read(path: Path, source: str | None = None) -> RawRecording:
    """``path`` read as a Shimmer Consensys export (the plug-in ``read``, :mod:`imucal.formats`).

    Returns
    -------
    RawRecording
        ``format`` Shimmer Consensys; one :class:`RawSensor` per device with calibrated
        accelerometer, gyroscope and Unix time stamp columns (its rows only), ``gyr``
        (deg/s by default) and ``acc`` (m/s^2 by default) (N, 3) in the units row's
        units, ``time`` s from the earliest device's first stamp; ``notes`` the devices
        skipped and a truncated last row.

    Raises
    ------
    InputError
        Naming ``source`` (default ``str(path)``): the file cannot be read, a column used is
        named twice, a cell is not a number, or no device has calibrated accelerometer,
        gyroscope and Unix time stamps.
    """
    source = source or str(path)
    text = read_text(path, source)
    lines = text.splitlines()
    sep, start = _split(lines)
    names = [c.strip().strip('"') for c in lines[start].split(sep)]
    row = start + 1
    units_row = None
    for _ in range(2):  # an optional CAL/RAW row, then the units row
        cells = [c.strip().strip('"') for c in lines[row].split(sep)] if row < len(lines) else []
        if cells and all(c in ("CAL", "RAW", "UNCAL", "") for c in cells):
            row += 1
        elif units_row is None and cells and not any(_numeric(c) for c in cells if c):
            # (not the first cell alone: a data row whose first device has no sample
            # there starts with an empty cell)
            units_row = cells
            row += 1
    # a row may leave off the cells of the devices at its end that have no sample in it
    device = [n.split("_")[1] if n.startswith("Shimmer_") else n for n in names]
    ends = frozenset(k for k in range(1, len(names)) if device[k] != device[k - 1])
    values, notes = parse_table(lines[row:], sep, row + 1, source, names,
                                 ended=ends_line(text), short_widths=ends)
    devices: dict[str, dict] = {}
    for i, c in enumerate(names):
        m = _COL.match(c)
        if not m or (m["cal"] or "CAL") != "CAL":
            continue
        what, d = m["what"], devices.setdefault(m["dev"], {})
        if c in names[:i]:  # two devices of one name: their columns merged into one
            raise twice(source, c, names.index(c), i)
        unit = units_row[i] if units_row and i < len(units_row) else None
        if what == "Timestamp_Unix":
            d["time"], d["time_units"] = i, unit
        for prefix in _ACC:
            for a in "XYZ":
                if what == f"{prefix}_{a}" and ("acc", a) not in d:
                    d["acc", a], d["acc_units"] = i, unit
        for a in "XYZ":
            if what == f"Gyro_{a}":
                d["gyr", a], d["gyr_units"] = i, unit
    sensors = []
    for dev, d in devices.items():
        missing = [f"{k} {a}" for k in ("gyr", "acc") for a in "XYZ" if (k, a) not in d]
        if missing or "time" not in d:
            notes.append(f"{dev} skipped: no calibrated {', '.join(missing) or 'Timestamp_Unix'}")
            continue
        scale = 1.0 if d.get("time_units") in ("s", "secs") else 1e-3  # ms by default
        mine = np.isfinite(values[:, d["time"]])  # rows of this device (others: empty)
        if not mine.any():
            notes.append(f"{dev} skipped: no row has its Unix time stamp")
            continue
        d["rows"] = mine
        sensors.append(RawSensor(
            name=dev, serial=dev.split("_", 1)[1],
            gyr=values[mine][:, [d["gyr", a] for a in "XYZ"]],
            acc=values[mine][:, [d["acc", a] for a in "XYZ"]],
            gyr_units=normalise_units("gyr", d.get("gyr_units"), "deg/s"),
            acc_units=normalise_units("acc", d.get("acc_units"), "m/s^2"),
            time=values[mine, d["time"]] * scale, files=[path.name],
        ))
    if not sensors:
        raise InputError(f"{source}: no Shimmer device with calibrated accelerometer, "
                         f"gyroscope and Unix time stamps; " + "; ".join(notes))
    # One shared Unix clock: subtract its earliest stamp, keeping the devices' offsets
    # (seconds since 1970 as float64 would lose the sub-millisecond digits).
    first = min(float(s.time[0]) for s in sensors)
    for s in sensors:
        s.time = s.time - first
    # (kept, as APDM's epoch is: a lab aligning force plates or video by wall-clock time
    # lost the recording's start, a new-user trial)
    info = [f"time 0 of the clock = {first:.3f} s since 1970-01-01 UTC (the earliest Unix "
            "time stamp)"]
    return RawRecording(format=NAME, sensors=sensors, notes=notes, info=info)


def _numeric(text: str) -> bool:
    try:
        float(text)
        return True
    except ValueError:
        return False
