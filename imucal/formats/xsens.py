"""Xsens MT Manager exports (MTw, MTi): one text file per sensor, ``MT_<prefix>_<deviceID>.txt``.

Layout: optional ``//`` header lines (``// Update Rate: 100.0Hz`` in older exports, absent
in newer ones; ``//  DeviceId: 00B42D4F`` in newer ones), then a tab-separated header row
and one row per sample: ``PacketCounter``, optional ``SampleTimeFine`` (10 kHz ticks, may
be empty or ``NaN``), ``Acc_X..Z`` (m/s^2), ``Gyr_X..Z`` (rad/s); other columns (UTC
time, orientation, magnetometer) are ignored. The same data exported as CSV (commas or
semicolons) is read the same way. A folder of such files is one recording.

Sensors are named by their device ID (file name, else ``DeviceId`` header line).
"""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np

from ..errors import InputError
from . import (
    RawRecording,
    RawSensor,
    column_index,
    ends_line,
    export_files,
    head_text,
    header_names,
    header_rate,
    parse_table,
    read_export,
    read_text,
)

NAME = "Xsens MT Manager"
#: SampleTimeFine counts 10 kHz ticks in a 32-bit register; PacketCounter is 16-bit.
TICKS_PER_S = 10_000.0
TIME_WRAP = 2**32 / TICKS_PER_S
COUNTER_WRAP = 2**16
_SUFFIXES = {".txt", ".csv", ".tsv"}
_FILE_ID = re.compile(r"^MT_.*?_?([0-9A-Fa-f]{8})(?:[-_]\d{3})*\.(?:txt|csv|tsv)$")
_RATE = re.compile(r"update\s*rate\s*:\s*([0-9.]+)\s*hz", re.IGNORECASE)
_DEVICE = re.compile(r"device\s*id\s*:\s*([0-9A-Fa-f]{6,})", re.IGNORECASE)


def _is_file(path: Path) -> bool:
    if path.suffix.lower() not in _SUFFIXES:
        return False
    head = head_text(path)
    lines = [ln for ln in head.splitlines() if ln.strip()]
    if not lines or lines[0].lower().startswith(("sep=", '"sep=')):
        return False  # Movella DOT and Shimmer start with a separator line
    if any("devicetag" in ln.lower() for ln in lines[:12]):
        return False
    header = next((ln for ln in lines if not ln.startswith("//")), "")
    cols = set(header_names(header, max(("\t", ",", ";"), key=header.count)))
    return "PacketCounter" in cols and ("Acc_X" in cols or "Gyr_X" in cols)


def _files(path: Path) -> list[Path]:
    return export_files(path, _is_file)


def sniff(path: Path) -> bool:
    """Whether ``path`` holds an Xsens MT Manager export (the plug-in ``sniff``,
    :mod:`imucal.formats`).

    Returns
    -------
    bool
        True when ``path`` is, or is a folder holding, an MT Manager ``.txt``/``.csv``
        export (recognised by its content).
    """
    return bool(_files(path))


def read(path: Path, source: str | None = None) -> RawRecording:
    """``path`` read as an Xsens MT Manager export (the plug-in ``read``, :mod:`imucal.formats`).

    Returns
    -------
    RawRecording
        ``format`` Xsens MT Manager; one :class:`RawSensor` per file (sorted by name),
        ``gyr`` rad/s and ``acc`` m/s^2 (N, 3), ``counter`` the packet counter,
        ``time`` s from ``SampleTimeFine`` where the file has it (else None); ``notes``
        the folder's files not read.

    Raises
    ------
    InputError
        Naming ``source`` (default ``str(path)``): no export file found, or one that cannot
        be read (:func:`imucal.formats.read_export`).
    """
    source = source or str(path)
    return read_export(path, source, _files(path), _read_file, NAME, "Xsens MT Manager export")


def _read_file(file: Path, source: str, many: bool) -> RawSensor:
    where = f"{source}/{file.name}" if many else source
    text = read_text(file, where)
    lines = text.splitlines()
    comments = [ln for ln in lines if ln.startswith("//")]
    start = next((i for i, ln in enumerate(lines) if ln.strip() and not ln.startswith("//")),
                 None)
    if start is None:
        raise InputError(f"{where}: has only '//' header lines and no data")
    header_line = lines[start]
    sep = max(("\t", ",", ";"), key=header_line.count)
    names = header_names(header_line, sep)
    need = ("Acc_X", "Acc_Y", "Acc_Z", "Gyr_X", "Gyr_Y", "Gyr_Z")
    col = column_index(names, where, (*need, "PacketCounter", "SampleTimeFine"))
    missing = [c for c in need if c not in col]
    if missing:
        raise InputError(
            f"{where}: no {', '.join(missing)} columns; export calibrated inertial data "
            f"(Acc and Gyr) from MT Manager (columns found: {', '.join(names[:12])})"
        )
    values, notes = parse_table(lines[start + 1:], sep, start + 2, where, names,
                                 ended=ends_line(text))
    gyr = values[:, [col["Gyr_X"], col["Gyr_Y"], col["Gyr_Z"]]]
    acc = values[:, [col["Acc_X"], col["Acc_Y"], col["Acc_Z"]]]
    counter = values[:, col["PacketCounter"]]
    time = None
    if "SampleTimeFine" in col:
        fine = values[:, col["SampleTimeFine"]]
        if np.isfinite(fine).any():  # (one missing stamp is named by its row)
            time = fine / TICKS_PER_S
    rate = None
    for ln in comments:
        found = header_rate(ln, _RATE, where)
        rate = rate if found is None else found
    match = _FILE_ID.match(file.name)
    device = match.group(1).upper() if match else None
    if device is None:
        device = next((m.group(1).upper() for ln in comments if (m := _DEVICE.search(ln))),
                      None)
    name = device or file.stem
    return RawSensor(
        name=name, serial=device, gyr=gyr, acc=acc, gyr_units="rad/s", acc_units="m/s^2",
        time=time, time_wrap=TIME_WRAP, counter=counter, counter_wrap=COUNTER_WRAP,
        claimed_rate=rate, files=[file.name], notes=[f"{name}: {n}" for n in notes],
    )
