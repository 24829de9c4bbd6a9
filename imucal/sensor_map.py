"""Study-wide sensor names: map the devices' names or serials to the names commands use.

A map is given once per study (``--map FILE``, or ``load_recording(path, names=...)``)
instead of naming devices per command. Keys are what the files call the sensors (APDM
label, DOT device tag, x-IMU3 device name, BIDS tracked point, Xsens device ID, an
imucal HDF5 group or CSV prefix) or their serials, matched like ``--sensors`` is:
ignoring case, spaces, underscores, hyphens and dots. Values are the new names::

    {"00B4D7D3": "left_thigh", "Opal 1234": "left_shank"}

or, as text, one ``KEY = NAME`` per line (``#`` starts a comment)::

    # participant 1          # participant 2
    00B4D7D3 = left_thigh    00B4D7E1 = left_thigh
    Opal 1234 = left_shank   Opal 1301 = left_shank

Keys that map to the same name are alternatives (one per participant of a study, say):
each name needs exactly one of its keys among the recording's sensors. A name none of
whose keys is found (a typing error, or a sensor missing from this recording) is an
error naming the map file and listing the sensors the recording has; so is a sensor
that two names claim, and a new name that another (unmapped) sensor already has.
Sensors the map does not mention keep their names. See docs/formats.md.
"""

from __future__ import annotations

import errno
import json
import os
import re
from collections.abc import Mapping
from dataclasses import replace
from pathlib import Path

from .errors import InputError, one_line
from .recording import Recording
from .sensor_names import normalised_name

__all__ = ["read_sensor_map", "apply_sensor_map"]

#: Largest map file read, bytes (a map has a line per device; anything bigger is a
#: mistaken path, such as a recording).
MAX_MAP_BYTES = 1_000_000


def read_sensor_map(path: str | Path) -> dict[str, str]:
    """The mapping in a map file (JSON object, or ``KEY = NAME`` lines).

    Returns
    -------
    dict[str, str]
        Device name or serial (as written, stripped) -> the name to use, in file order.

    Raises
    ------
    InputError
        Naming the file (and the line or key): ``-``, a folder, a missing or unreadable
        file, one over :data:`MAX_MAP_BYTES` or holding binary data, invalid JSON or a
        JSON list, a name that is not text, a line without ``=``, an empty key or name,
        a name with a comma or a control character, a key mapped to two names, or no
        entry at all.

    Examples
    --------
    >>> import tempfile
    >>> from pathlib import Path
    >>> from imucal.sensor_map import read_sensor_map
    >>> with tempfile.TemporaryDirectory() as folder:
    ...     path = Path(folder) / "map.txt"
    ...     _ = path.write_text("00B4D7D3 = left_thigh  # participant 1\\n")
    ...     read_sensor_map(path)
    {'00B4D7D3': 'left_thigh'}
    """
    source = str(path)
    p = Path(path)
    if source == "-":
        raise InputError("-: --map reads a file, not standard input; save the map to a file")
    try:
        if p.is_dir():
            raise InputError(f"{source}: --map needs a file, this is a folder")
        # read up to the limit rather than trusting the size: a device or a pipe has
        # none (/dev/zero never ends)
        with open(p, "rb") as fh:
            data = fh.read(MAX_MAP_BYTES + 1)
        if len(data) > MAX_MAP_BYTES:
            raise InputError(f"{source}: too large for a sensor map (more than "
                             f"{MAX_MAP_BYTES} bytes); is it a recording?")
    except FileNotFoundError:
        raise InputError(f"{source}: no such file (--map)") from None
    except OSError as err:
        reason = ("symbolic link loop" if err.errno == errno.ELOOP
                  else f"cannot read sensor map ({err.strerror or err})")
        raise InputError(f"{source}: {reason}") from None
    from .formats import decode_text

    text = decode_text(data, source, "sensor map", hint="; is it a recording?")
    if text.lstrip().startswith("["):  # JSON, but not the object a map is
        raise InputError(f"{source}: a sensor map in JSON is one object, "
                         '{"device name or serial": "name to use", ...}, not a list')
    if text.lstrip().startswith("{"):
        try:
            # pairs, not a dict: a key given twice is reported, not silently dropped
            pairs = json.loads(text, object_pairs_hook=lambda pairs: pairs)
        except json.JSONDecodeError as err:
            raise InputError(f"{source}: invalid JSON at line {err.lineno}, column "
                             f"{err.colno}: {err.msg}") from None
        # ValueError: an integer of thousands of digits; RecursionError: arrays nested a
        # hundred thousand deep
        except (ValueError, RecursionError) as err:
            detail = one_line(str(err))[:80] or type(err).__name__
            raise InputError(f"{source}: invalid JSON ({detail})") from None
        for key, value in pairs:
            if not isinstance(value, str):
                raise InputError(f"{source}: the name for {key!r} must be text, got "
                                 f"{json.dumps(value)}")
        where = [f"key {k!r}" for k, _ in pairs]
    else:
        pairs, where = [], []
        for number, line in enumerate(text.splitlines(), start=1):
            content = line.split("#", 1)[0].strip()
            if not content:
                continue
            if "=" not in content:
                raise InputError(f"{source}: line {number}: expected KEY = NAME (a device "
                                 f"name or serial, '=', the name to use), got {content!r}")
            key, value = (part.strip() for part in content.split("=", 1))
            pairs.append((key, value))
            where.append(f"line {number}")
    return _check_pairs(pairs, where, source)


def _check_pairs(pairs, where, source: str) -> dict[str, str]:
    mapping: dict[str, str] = {}
    seen: dict[str, tuple[str, str, str]] = {}  # normalised key -> (key, value, where)
    for (key, value), at in zip(pairs, where, strict=True):
        key, value = str(key).strip(), str(value).strip()
        if not key or not normalised_name(key):
            raise InputError(f"{source}: {at}: the device name or serial is empty")
        if not value:
            raise InputError(f"{source}: {at}: no name given for {key!r}")
        if "," in value:
            raise InputError(f"{source}: {at}: the name {value!r} contains a comma; "
                             "--sensors could not address it")
        if any(not ch.isprintable() for ch in value):
            # (a NUL cut the name short in HDF5 and made a CSV unreadable as text)
            raise InputError(f"{source}: {at}: the name {value!r} contains a control "
                             "character (a tab, a line break, NUL); names are printable text")
        previous = seen.get(normalised_name(key))
        if previous is not None and previous[1] != value:
            raise InputError(f"{source}: {at}: {key!r} is mapped twice, to {previous[1]!r} "
                             f"({previous[2]}) and to {value!r}")
        seen[normalised_name(key)] = (key, value, at)
        mapping[key] = value
    if not mapping:
        raise InputError(f"{source}: the sensor map is empty (expected a JSON object or "
                         "KEY = NAME lines)")
    return mapping


def apply_sensor_map(recording: Recording, names: Mapping[str, str] | str | Path,
                     source: str | None = None) -> Recording:
    """``recording`` with its sensors renamed by ``names`` (a mapping, or a map file).

    ``source`` names the map in messages (default: the file, or ``names=``). The renamed
    sensors keep their serials and labels in ``sensor_info``; ``provenance["sensor_map"]``
    records the map and what it renamed.

    Returns
    -------
    Recording
        A copy with the mapped sensors renamed in ``sensors``, ``units``, ``gaps``,
        ``sensor_info`` (with ``name_in_file``), ``provenance`` and the warnings and
        notes that name them; data unchanged. Unmapped sensors keep their names.

    Raises
    ------
    InputError
        the map cannot be read or is not a mapping; a key matches no sensor or several; two
        sensors get one name; one sensor is mapped twice; or a new name is that of a sensor
        the map leaves as it is. Each message names ``source``.

    Examples
    --------
    >>> import imucal
    >>> from imucal.sensor_map import apply_sensor_map
    >>> rec = imucal.load_recording("sample_data/walking.h5")
    >>> list(apply_sensor_map(rec, {"thigh": "left_thigh"}).sensors)
    ['left_thigh', 'shank', 'foot']
    """
    if isinstance(names, str | bytes | os.PathLike):
        if not isinstance(names, str):
            names = os.fsdecode(names)
        source = source or str(names)
        names = read_sensor_map(names)
    else:
        source = source or "sensor map (names=)"
        if not isinstance(names, Mapping):
            raise InputError(f"{source}: expected a mapping from device names or serials to "
                             f"sensor names, got {type(names).__name__}")
        names = _check_pairs(list(names.items()), [f"key {k!r}" for k in names], source)

    sensors = list(recording.sensors)
    info = recording.sensor_info or {}

    def matches(key: str) -> list[str]:
        k = normalised_name(key)
        return [n for n in sensors
                if k in {normalised_name(n), normalised_name(info.get(n, {}).get("serial") or ""),
                         normalised_name(info.get(n, {}).get("label") or "")}]

    renamed: dict[str, str] = {}  # sensor in the file -> new name
    claimed_by: dict[str, str] = {}  # sensor in the file -> key that claimed it
    targets: dict[str, list[str]] = {}
    for key, value in names.items():
        targets.setdefault(value, []).append(key)
    for value, keys in targets.items():
        found = {}
        for key in keys:
            hits = matches(key)
            if len(hits) > 1:
                raise InputError(
                    f"{source}: {key!r} matches several sensors of {recording.source}: "
                    f"{', '.join(map(repr, hits))}; use their serials")
            if hits:
                found.setdefault(hits[0], key)
        if not found:
            alternatives = " or ".join(repr(k) for k in keys)
            raise InputError(
                f"{source}: no sensor {alternatives} (mapped to {value!r}) in "
                f"{recording.source}; sensors there: {_present(sensors, info)}")
        if len(found) > 1:
            which = ", ".join(f"{k!r} (sensor '{n}'{_files_of(n, info, ' in {}')})"
                              for n, k in found.items())
            raise InputError(
                f"{source}: {which} are all mapped to {value!r} and are all in "
                f"{recording.source}; map each sensor to its own name")
        (sensor, key), = found.items()
        if sensor in renamed:
            raise InputError(
                f"{source}: sensor '{sensor}' of {recording.source} is mapped twice: by "
                f"{claimed_by[sensor]!r} to {renamed[sensor]!r} and by {key!r} to {value!r}")
        renamed[sensor] = value
        claimed_by[sensor] = key
    for sensor in sensors:
        if sensor not in renamed and sensor in targets:
            raise InputError(
                f"{source}: the name {sensor!r} is already a sensor of {recording.source}"
                f"{_files_of(sensor, info, ' (in {})')} that the map leaves as it is; map "
                "that sensor too, or choose another name")
    return _rename(recording, renamed, source, claimed_by)


def _files_of(name: str, info, form: str) -> str:
    """``form`` filled with the files of a vendor export's sensor ``name`` ("" for imucal's
    own layouts, one file): a clash names the files to look at, not only the sensors."""
    files = info.get(name, {}).get("files") or []
    return form.format(", ".join(files)) if files else ""


def _present(sensors, info) -> str:
    out = []
    for n in sensors:
        serial = info.get(n, {}).get("serial")
        out.append(f"'{n}' (serial {serial})" if serial and serial != n else f"'{n}'")
    return ", ".join(out) or "none"


def _rename(recording: Recording, renamed: dict[str, str], source: str,
            claimed_by: dict[str, str]) -> Recording:
    def new(name):
        return renamed.get(name, name)

    def rekey(mapping):
        return {new(k): v for k, v in mapping.items()} if isinstance(mapping, Mapping) \
            else mapping

    sensor_info = {new(n): {**i, "name_in_file": n} if n in renamed else i
                   for n, i in recording.sensor_info.items()}
    provenance = {k: rekey(v) if k in ("serials", "original_rates_hz", "time_from",
                                       "dropped_samples") else v
                  for k, v in recording.provenance.items()}
    provenance["sensor_map"] = {"file": source, "renamed": dict(renamed),
                                "keys": {new(n): k for n, k in claimed_by.items()}}
    # the loader's notes name sensors as "sensor 'NAME'" (one form everywhere); they were
    # written before the map, and a warning about 'Shank' beside a table of 'left_shank'
    # left the reader to pair them (matched by the names themselves, longest first: a
    # name may hold an apostrophe)
    olds = sorted(renamed, key=len, reverse=True)
    pattern = re.compile("sensor '(" + "|".join(re.escape(n) for n in olds) + ")'")

    def renamed_in(note: str) -> str:
        return pattern.sub(lambda m: f"sensor '{renamed[m[1]]}' ('{m[1]}' in the file)",
                           note) if olds else note

    return replace(
        recording,
        sensors={new(n): s for n, s in recording.sensors.items()},
        warnings=[renamed_in(w) for w in recording.warnings],
        # (select keeps a window's notes by the sensors' names: the foot's dropped packets
        # entered the knee's warnings, and cost its "good")
        notes=tuple(renamed_in(n) for n in recording.notes),
        units={new(n): u for n, u in recording.units.items()},
        gaps=tuple(replace(g, sensor=new(g.sensor)) for g in recording.gaps),
        sensor_info=sensor_info,
        provenance=provenance,
    )
