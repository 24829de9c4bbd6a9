"""BIDS-motion: ``*_motion.tsv`` with its ``*_channels.tsv`` and ``*_motion.json``.

``*_motion.tsv`` has no header: one column per channel, in the order of the rows of
``*_channels.tsv`` (tab-separated, with a header naming at least ``name``, ``component``
(x, y, z), ``type`` (ACCEL, GYRO; others ignored), ``tracked_point`` and ``units``).
``*_motion.json`` gives ``SamplingFrequency`` (Hz). A ``LATENCY`` channel, when present,
holds each sample's time (s). Each tracked point with ACCEL and GYRO x, y, z is a sensor,
named by its tracked point. The path may be the ``*_motion.tsv`` file or its folder.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from ..errors import InputError
from . import (
    RawRecording,
    RawSensor,
    ends_line,
    normalise_units,
    parse_table,
    read_text,
    twice,
)

NAME = "BIDS-motion"


def _motion_files(path: Path) -> list[Path]:
    if path.is_dir():
        return sorted(path.glob("*_motion.tsv"))
    return [path] if path.name.endswith("_motion.tsv") else []


def sniff(path: Path) -> bool:
    """Whether ``path`` holds a BIDS-motion recording (the plug-in ``sniff``,
    :mod:`imucal.formats`).

    Returns
    -------
    bool
        True when ``path`` is, or is a folder holding, a ``*_motion.tsv`` file.
    """
    return bool(_motion_files(path))


def _sidecar(motion: Path, suffix: str) -> Path:
    return motion.with_name(motion.name[: -len("_motion.tsv")] + suffix)


def _channels(path: Path) -> list[dict[str, str]]:
    """The rows of a ``_channels.tsv`` ({column: value}, header lower case).

    Raises
    ------
    InputError
        an empty file, a header without name, component, type and tracked_point, or a
        row too short to hold them (with its line; optional columns may be left off).
    """
    lines = [(n, ln) for n, ln in enumerate(read_text(path, str(path)).splitlines(), start=1)
             if ln.strip()]
    if not lines:
        raise InputError(f"{path}: empty; a BIDS channels file lists one row per column")
    header = [h.strip().lower() for h in lines[0][1].split("\t")]
    missing = [c for c in ("name", "component", "type", "tracked_point") if c not in header]
    if missing:
        raise InputError(f"{path}: no column {', '.join(missing)} in the header")
    # only the columns read must be there: a row may leave optional ones off its end
    needed = 1 + max(header.index(c) for c in ("name", "component", "type", "tracked_point"))
    rows = []
    for n, ln in lines[1:]:
        cells = [c.strip() for c in ln.split("\t")]
        if len(cells) < needed:
            raise InputError(f"{path}: row {n} has {len(cells)} fields; name, component, "
                             "type and tracked_point need "
                             f"{needed}")
        rows.append(dict(zip(header, cells + [""] * (len(header) - len(cells)), strict=False)))
    return rows


def read(path: Path, source: str | None = None) -> RawRecording:
    """``path`` read as a BIDS-motion recording (the plug-in ``read``, :mod:`imucal.formats`).

    Returns
    -------
    RawRecording
        ``format`` BIDS-motion; one :class:`RawSensor` per tracked point with ACCEL and GYRO
        x, y, z channels, ``gyr``/``acc`` (N, 3) in the channels file's units (rad/s,
        m/s^2 by default), ``time`` s from the LATENCY channel, else row / rate, rows
        where the point has no value left out; ``claimed_rate`` the JSON's
        ``SamplingFrequency``, Hz; ``notes`` points skipped and a truncated last row.

    Raises
    ------
    InputError
        Naming ``source`` (default ``str(path)``): several motion files, a missing
        ``_channels.tsv`` or ``_motion.json``, no usable positive ``SamplingFrequency``,
        channel rows that do not match the columns, a channel given twice, a cell that is
        not a number, or no usable tracked point.
    """
    source = source or str(path)
    files = _motion_files(path)
    if len(files) > 1:
        raise InputError(
            f"{source}: holds {len(files)} BIDS motion files "
            f"({', '.join(f.name for f in files[:4])}); give one of them"
        )
    motion = files[0]
    channels_path, json_path = _sidecar(motion, "_channels.tsv"), _sidecar(motion, "_motion.json")
    for needed in (channels_path, json_path):
        if not needed.exists():
            raise InputError(f"{source}: BIDS motion file without its {needed.name}")
    try:
        meta = json.loads(read_text(json_path, str(json_path)))
        rate = float(meta["SamplingFrequency"])
    except (ValueError, KeyError, TypeError) as err:
        raise InputError(f"{json_path}: no usable 'SamplingFrequency' ({err})") from None
    if isinstance(meta["SamplingFrequency"], bool):  # (float(True) is 1 Hz)
        raise InputError(f"{json_path}: no usable 'SamplingFrequency' (true or false is no "
                         "number of Hz)")
    if not (np.isfinite(rate) and rate > 0):
        raise InputError(f"{json_path}: 'SamplingFrequency' must be a positive number (Hz), "
                         f"got {meta['SamplingFrequency']!r}")
    rows = _channels(channels_path)
    names = [r.get("name", f"column {i + 1}") for i, r in enumerate(rows)]
    text = read_text(motion, source)
    data = text.splitlines()
    first = next((ln for ln in data if ln.strip()), "")
    cells = first.split("\t")
    while len(cells) > len(rows) and not cells[-1].strip():  # a tab at each row's end
        cells.pop()
    width = len(cells)
    if first and width != len(rows):
        # matched by position, every channel after a missing row read its neighbour's
        # column (a thigh's data as the shank's), without a word
        raise InputError(f"{channels_path}: lists {len(rows)} channels, but {motion.name} has "
                         f"{width} columns; the channels file needs one row per column, in "
                         "order")
    values, notes = parse_table(data, "\t", 1, str(motion), names, ended=ends_line(text))
    time = None
    by_point: dict[str, dict] = {}
    for i, r in enumerate(rows):
        kind = {"ACCEL": "acc", "GYRO": "gyr"}.get(r.get("type", "").upper())
        if r.get("type", "").upper() == "LATENCY":
            time = values[:, i]
        if kind is None or r.get("component", "").lower() not in ("x", "y", "z"):
            continue
        point = by_point.setdefault(r["tracked_point"], {})
        if (kind, r["component"].lower()) in point:
            raise twice(str(channels_path), f"{r['tracked_point']} {r['type']} "
                        f"{r['component']}", point[kind, r["component"].lower()], i)
        point[(kind, r["component"].lower())] = i
        point.setdefault(f"{kind}_units", r.get("units"))
    sensors = []
    for point, cols in by_point.items():
        need = [(k, a) for k in ("gyr", "acc") for a in "xyz"]
        absent = [f"{'GYRO' if k == 'gyr' else 'ACCEL'} {a}" for k, a in need if (k, a) not in cols]
        if absent:
            notes.append(f"tracked point '{point}' skipped: no {', '.join(absent)} channel")
            continue
        sensors.append(RawSensor(
            name=point, gyr=values[:, [cols["gyr", a] for a in "xyz"]],
            acc=values[:, [cols["acc", a] for a in "xyz"]],
            gyr_units=normalise_units("gyr", cols.get("gyr_units"), "rad/s"),
            acc_units=normalise_units("acc", cols.get("acc_units"), "m/s^2"),
            time=time, claimed_rate=rate,
            files=[motion.name, channels_path.name, json_path.name],
        ))
    if not sensors:
        raise InputError(f"{source}: no tracked point has ACCEL and GYRO x, y, z channels; "
                         + "; ".join(notes))
    if time is None:  # rows are regular at SamplingFrequency
        time = np.arange(values.shape[0]) / rate
    for s in sensors:
        # Rows where a point has no value at all (n/a: not yet started, a dropped packet)
        # are not its samples; the clock then sees them as a late start or a drop.
        keep = ~(np.isnan(s.gyr).all(axis=1) & np.isnan(s.acc).all(axis=1))
        s.gyr, s.acc, s.time = s.gyr[keep], s.acc[keep], time[keep]
    return RawRecording(format=NAME, sensors=sensors, notes=notes)
