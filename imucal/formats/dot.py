"""Movella (Xsens) DOT CSV exports: one file per sensor, a folder of them is one recording.

Layout: first line ``sep=,``; key/value metadata lines ``DeviceTag:,<tag>,,,``,
``FirmwareVersion:,...``, ``OutputRate:,60Hz,,,``, ``StartTime:,...``; a copyright line
(UTF-8); a blank line; the header ``PacketCounter,SampleTimeFine,...,Acc_X..Z,Gyr_X..Z``
and one row per sample. ``SampleTimeFine`` is in microseconds (32-bit, wraps after
71.6 min) on the clock the DOTs synchronise; ``PacketCounter`` restarts at 1 in every
file, so files are aligned on ``SampleTimeFine``. Acc is in m/s^2, Gyr in deg/s.

Sensors are named by their ``DeviceTag``; a Bluetooth address in the file name
(``D4-22-CD-00-12-34``) is the serial.
"""

from __future__ import annotations

import re
from pathlib import Path

from ..errors import InputError
from . import (
    RawRecording,
    RawSensor,
    check_comma_separated,
    column_index,
    ends_line,
    export_files,
    head_text,
    header_names,
    header_rate,
    header_starts,
    parse_table,
    read_export,
    read_text,
    sep_line,
)

NAME = "Movella DOT"
US_PER_S = 1e6
TIME_WRAP = 2**32 / US_PER_S
COUNTER_WRAP = 2**16
#: A Bluetooth address: six hex pairs, one separator throughout (or none), not part of a
#: longer run of hex digits. Pairs with separators mixed or digits only matched the date
#: of ``Thigh L_20230504_131211.csv`` ("20230504:1312", the serial of every device: a
#: new-user trial); the Movella DOT's addresses (D4:22:CD:...) have letters.
_MAC = re.compile(r"(?<![0-9A-Fa-f])([0-9A-Fa-f]{2}(?P<sep>[-:_]?)[0-9A-Fa-f]{2}"
                  r"(?:(?P=sep)[0-9A-Fa-f]{2}){4})(?![0-9A-Fa-f])")
_RATE = re.compile(r"([0-9.]+)\s*hz", re.IGNORECASE)


def _is_file(path: Path) -> bool:
    if path.suffix.lower() != ".csv":
        return False
    lines = [ln for ln in head_text(path).splitlines() if ln.strip()]
    if not lines:
        return False
    meta = any(ln.lower().startswith("devicetag") for ln in lines[:15])
    header = any(header_starts(ln, "PacketCounter") and "SampleTimeFine" in ln
                 for ln in lines[:20])
    return header and (meta or sep_line(lines[0]) == "," or _bare_dot(lines))


def _bare_dot(lines: list[str]) -> bool:
    """A DOT file without its metadata lines has the columns of an Xsens MT Manager CSV;
    only the unit of ``SampleTimeFine`` tells them apart: DOT microseconds step at least
    5000 per sample (DOTs record at up to 120 Hz), Xsens 10 kHz ticks would then mean a
    sample rate below 2 Hz, too slow for any motion imucal estimates."""
    names = header_names(lines[0], ",")
    if names[:2] != ["PacketCounter", "SampleTimeFine"]:
        return False
    try:
        stamps = [float(ln.split(",")[1]) for ln in lines[1:33]]
    except (IndexError, ValueError):
        return False
    steps = sorted(b - a for a, b in zip(stamps, stamps[1:], strict=False))
    return bool(steps) and steps[len(steps) // 2] >= 5000


def _files(path: Path) -> list[Path]:
    return export_files(path, _is_file)


def sniff(path: Path) -> bool:
    """Whether ``path`` holds a Movella DOT export (the plug-in ``sniff``,
    :mod:`imucal.formats`).

    Returns
    -------
    bool
        True when ``path`` is, or is a folder holding, a DOT export CSV (recognised by its
        content).
    """
    return bool(_files(path))


def read(path: Path, source: str | None = None) -> RawRecording:
    """``path`` read as a Movella DOT export (the plug-in ``read``, :mod:`imucal.formats`).

    Returns
    -------
    RawRecording
        ``format`` Movella DOT; one :class:`RawSensor` per file (sorted by name), named by
        its device tag, ``gyr`` deg/s and ``acc`` m/s^2 (N, 3), ``time`` s from
        ``SampleTimeFine`` (us, wrapping), ``counter`` the packet counter where the file
        has one; ``notes`` the folder's files not read.

    Raises
    ------
    InputError
        Naming ``source`` (default ``str(path)``): no DOT file found, or one that cannot be
        read (:func:`imucal.formats.read_export`).
    """
    source = source or str(path)
    return read_export(path, source, _files(path), _read_file, NAME, "Movella DOT export")


def _read_file(file: Path, source: str, many: bool) -> RawSensor:
    where = f"{source}/{file.name}" if many else source
    text = read_text(file, where)
    lines = text.splitlines()
    start = next((i for i, ln in enumerate(lines) if header_starts(ln, "PacketCounter")),
                 None)
    if start is None:
        raise InputError(f"{where}: no 'PacketCounter,SampleTimeFine,...' header row")
    meta = {}
    for ln in lines[:start]:
        fields = ln.split(",")
        if len(fields) >= 2 and fields[0].strip().endswith(":"):
            meta[fields[0].strip().rstrip(":").lower()] = fields[1].strip()
    names = header_names(lines[start], ",")
    check_comma_separated(names, where, "a DOT export")
    need = ("SampleTimeFine", "Acc_X", "Acc_Y", "Acc_Z", "Gyr_X", "Gyr_Y", "Gyr_Z")
    col = column_index(names, where, (*need, "PacketCounter"))
    missing = [c for c in need if c not in col]
    if missing:
        raise InputError(
            f"{where}: no {', '.join(missing)} columns; export Acceleration and Angular "
            f"velocity (not only orientation or free acceleration); columns found: "
            f"{', '.join(names[:12])}"
        )
    values, notes = parse_table(lines[start + 1:], ",", start + 2, where, names,
                                 ended=ends_line(text))
    mac = next((m for m in _MAC.finditer(file.stem) if re.search("[A-Fa-f]", m.group(1))),
               None)
    # without the metadata lines, the file name <tag>_<address>_<date> still holds the tag
    tag = (meta.get("devicetag") or (mac and file.stem[:mac.start()].strip("_- "))
           or file.stem)
    serial = re.sub(r"[-:_]", ":", mac.group(1)).upper() if mac else None
    rate = header_rate(meta.get("outputrate", ""), _RATE, where)
    counter = values[:, col["PacketCounter"]] if "PacketCounter" in col else None
    return RawSensor(
        name=tag, serial=serial,
        gyr=values[:, [col["Gyr_X"], col["Gyr_Y"], col["Gyr_Z"]]],
        acc=values[:, [col["Acc_X"], col["Acc_Y"], col["Acc_Z"]]],
        gyr_units="deg/s", acc_units="m/s^2",
        time=values[:, col["SampleTimeFine"]] / US_PER_S, time_wrap=TIME_WRAP,
        counter=counter, counter_wrap=COUNTER_WRAP,
        claimed_rate=rate,
        files=[file.name], notes=[f"{tag}: {n}" for n in notes],
    )
