"""x-IMU3 logged sessions: one folder per device, ``<device name> <serial> (<interface>)``,
each holding ``Inertial.csv`` (and other files, ignored).

``Inertial.csv``: comma-separated, a header ``Timestamp (us),Gyroscope X (deg/s),
Gyroscope Y (deg/s),Gyroscope Z (deg/s),Accelerometer X (g),Accelerometer Y (g),
Accelerometer Z (g)`` (units read from the parentheses), one row per sample; the
timestamp is the device's clock in microseconds. The path may be the session folder, one
device folder, or an ``Inertial.csv``. Sensors are named by the device name; the serial
is the alternative.
"""

from __future__ import annotations

import re
from pathlib import Path

from ..errors import InputError
from . import (
    UNIT_RE,
    RawRecording,
    RawSensor,
    check_comma_separated,
    ends_line,
    head_text,
    header_names,
    header_starts,
    is_empty,
    normalise_units,
    parse_table,
    read_text,
    twice,
)

NAME = "x-IMU3"
_FOLDER = re.compile(r"^(?P<name>.+?) (?P<serial>[0-9A-Fa-f]{8}) \((?P<iface>[^)]*)\)$")


def _is_inertial(path: Path) -> bool:
    return path.name == "Inertial.csv" and header_starts(head_text(path, 200), "Timestamp (us)")


def _devices(path: Path) -> list[Path]:
    if path.is_file():
        return [path] if _is_inertial(path) else []
    if (path / "Inertial.csv").is_file() and _is_inertial(path / "Inertial.csv"):
        return [path / "Inertial.csv"]
    return sorted(p / "Inertial.csv" for p in path.iterdir()
                  if p.is_dir() and (p / "Inertial.csv").is_file()
                  and _is_inertial(p / "Inertial.csv"))


def _empty(path: Path) -> list[Path]:
    """The empty ``Inertial.csv`` of the device folder ``path`` or of the session folder
    ``path``'s device folders (a device that logged nothing)."""
    if path.is_file():
        return [path] if path.name == "Inertial.csv" and is_empty(path) else []
    if not path.is_dir():
        return []
    if (path / "Inertial.csv").is_file():
        return [path / "Inertial.csv"] if is_empty(path / "Inertial.csv") else []
    return sorted(p / "Inertial.csv" for p in path.iterdir()
                  if _FOLDER.match(p.name) and (p / "Inertial.csv").is_file()
                  and is_empty(p / "Inertial.csv"))


def sniff(path: Path) -> bool:
    """Whether ``path`` holds an x-IMU3 logged session (the plug-in ``sniff``,
    :mod:`imucal.formats`).

    Returns
    -------
    bool
        True when ``path`` is, or is a folder holding device folders with, an
        ``Inertial.csv`` (empty ones too, so that the reader names them).
    """
    return bool(_devices(path) or _empty(path))


def read(path: Path, source: str | None = None) -> RawRecording:
    """``path`` read as an x-IMU3 logged session (the plug-in ``read``, :mod:`imucal.formats`).

    Returns
    -------
    RawRecording
        ``format`` x-IMU3; one :class:`RawSensor` per device's ``Inertial.csv``, ``gyr``
        (deg/s by default) and ``acc`` (g by default) (N, 3) in the header's units,
        ``time`` s (the file's us time stamps / 1e6); ``notes`` the empty device files
        and folders without ``Inertial.csv``.

    Raises
    ------
    InputError
        Naming ``source`` (default ``str(path)``): the file is empty, every ``Inertial.csv``
        is empty, or a device's file cannot be read.
    """
    source = source or str(path)
    files, empty = _devices(path), _empty(path)
    if not files and path.is_file():
        raise InputError(f"{source}: file is empty")
    if not files:
        raise InputError(f"{source}: Inertial.csv is empty in "
                         f"{', '.join(repr(f.parent.name) for f in empty)}; no device to read")
    notes = []
    if empty:
        notes.append(f"device folders whose Inertial.csv is empty, not read: "
                     f"{', '.join(f.parent.name for f in empty)}")
    if path.is_dir() and len(files) > 0 and files[0].parent != path:
        others = sorted(p.name for p in path.iterdir()
                        if p.is_dir() and not (p / "Inertial.csv").is_file())
        if others:
            notes.append(f"folders without Inertial.csv, not read: {', '.join(others)}")
    return RawRecording(format=NAME, sensors=[_read(f, source) for f in files], notes=notes)


def _read(file: Path, source: str) -> RawSensor:
    folder = file.parent.name
    where = f"{source}/{folder}/Inertial.csv" if Path(source).is_dir() else source
    m = _FOLDER.match(folder)
    name, serial = (m["name"], m["serial"].upper()) if m else (folder, None)
    text = read_text(file, where)
    lines = text.splitlines()
    cols = header_names(lines[0], ",")
    check_comma_separated(cols, where, "an x-IMU3 export")
    index, units = {}, {}
    for i, c in enumerate(cols):
        u = UNIT_RE.search(c)
        base = UNIT_RE.sub("", c).strip()
        parts = base.split()
        if len(parts) == 2 and parts[0] in ("Gyroscope", "Accelerometer") and parts[1] in "XYZ":
            kind = "gyr" if parts[0] == "Gyroscope" else "acc"
            if (kind, parts[1].lower()) in index:
                raise twice(where, base, index[kind, parts[1].lower()], i)
            index[kind, parts[1].lower()] = i
            units[kind] = u.group(1) if u else None
    missing = [f"{'Gyroscope' if k == 'gyr' else 'Accelerometer'} {a.upper()}"
               for k in ("gyr", "acc") for a in "xyz" if (k, a) not in index]
    if missing:
        raise InputError(f"{where}: no {', '.join(missing)} column")
    values, notes = parse_table(lines[1:], ",", 2, where, cols, ended=ends_line(text))
    return RawSensor(
        name=name, serial=serial,
        gyr=values[:, [index["gyr", a] for a in "xyz"]],
        acc=values[:, [index["acc", a] for a in "xyz"]],
        gyr_units=normalise_units("gyr", units.get("gyr"), "deg/s"),
        acc_units=normalise_units("acc", units.get("acc"), "g"),
        time=values[:, 0] / 1e6, files=[f"{folder}/Inertial.csv"],
        notes=[f"{name}: {n}" for n in notes],
    )
