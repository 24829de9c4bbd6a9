"""Read recordings from HDF5 or CSV files into a validated :class:`~imucal.recording.Recording`.

Two input formats are accepted (full description with examples: ``docs/formats.md``):

HDF5 (``.h5``, ``.hdf5``)
    Root attribute ``sample_rate`` (Hz) and/or root dataset ``time`` (s). One group per
    sensor (any name) holding datasets ``gyr`` and ``acc`` of shape (N, 3). An optional
    ``units`` attribute on each dataset: ``rad/s`` (default) or ``deg/s`` for ``gyr``,
    ``m/s^2`` (default) or ``g`` for ``acc``. Groups holding neither dataset are skipped.

CSV (``.csv``, ``.txt``, or ``-`` for standard input)
    One header row; an optional ``time`` column (s); for every sensor the six columns
    ``<sensor>_gyr_x/y/z`` and ``<sensor>_acc_x/y/z``. Sensor names may contain
    underscores (the name is split at the last ``_gyr_``/``_acc_``). Units are given by
    the caller (``gyr_units``/``acc_units``), the same for all sensors. Other columns
    are ignored (and listed in ``Recording.warnings``).

Non-finite samples are kept and described (``Recording.gaps``); only the sensors and the
window an estimate uses are checked and repaired (:meth:`Recording.select`).

Any other suffix is recognised by content (the HDF5 signature, else CSV). This module only
parses; checking and unit conversion happen in :func:`imucal.recording.make_recording`.
Every problem is reported as one :class:`~imucal.errors.InputError` naming the file.
"""

from __future__ import annotations

import difflib
import errno
import io
import os
import re
import stat
import sys
from collections.abc import Mapping
from dataclasses import replace
from pathlib import Path
from typing import TYPE_CHECKING

import h5py
import numpy as np

if TYPE_CHECKING:  # pandas is imported where CSV is parsed: it costs ~0.2 s of start-up
    import pandas as pd

from .errors import InputError
from .errors import one_line as _one_line
from .formats import (
    CUT_RULE_ROWS,
    HDF5_SIGNATURE,
    HDF5_SUFFIXES,
    cut_in_number,
    decode_text,
    ends_line,
)
from .recording import Recording, make_recording
from .sensor_checks import check_units
from .timing import check_rate

__all__ = ["load_recording"]

CSV_SUFFIXES = {".csv", ".txt"}
#: Most bytes read from standard input or another stream (a pipe, a device): a file
#: there has no size to check first, and /dev/zero never ends. 4 GiB is a day of seven
#: sensors at 100 Hz as CSV; a larger recording is read from a file.
MAX_STREAM_BYTES = 4 << 30

_KINDS = ("gyr", "acc")
_AXES = ("x", "y", "z")
#: ``<sensor>_gyr_x`` etc.; the greedy ``.+`` splits at the LAST ``_gyr_``/``_acc_``.
_COLUMN_RE = re.compile(r"^(?P<sensor>.+)_(?P<kind>gyr|acc)_(?P<axis>[xyz])$", re.IGNORECASE)
_EXPECTED_COLUMNS = (
    "'<sensor>_gyr_x', '<sensor>_gyr_y', ..., '<sensor>_acc_z' (and optionally 'time')"
)
#: Cell text read as NaN (reported later by make_recording as non-finite, not as text).
_NAN_TEXT = ("nan", "+nan", "-nan")


def load_recording(
    path: str | Path,
    *,
    rate: float | None = None,
    gyr_units: str | None = None,
    acc_units: str | None = None,
    names: Mapping[str, str] | str | Path | None = None,
) -> Recording:
    """Load an HDF5 or CSV recording and return it validated, in SI units.

    Parameters
    ----------
    path
        File to read; ``"-"`` reads CSV (or HDF5, recognised by its signature) from
        standard input.
    rate
        Sample rate in Hz. Required for CSV files without a ``time`` column; for HDF5 it
        overrides the ``sample_rate`` attribute. When ``time`` exists too, both must agree.
    gyr_units, acc_units
        Units of the gyroscope (``rad/s`` or ``deg/s``) and accelerometer (``m/s^2`` or
        ``g``) data. For CSV they apply to all sensors (default rad/s and m/s^2); for HDF5
        they override the files' ``units`` attributes.
    names
        A study's sensor map: device names or serials (as the files give them, matched
        ignoring case, spaces, underscores and hyphens) -> the names to use, e.g.
        ``{"00B4D7D3": "left_thigh"}``, or the path of a map file (JSON or ``KEY = NAME``
        lines; :mod:`imucal.sensor_map`, ``--map`` on the command line). A name none of
        whose keys is in the recording is an error listing the sensors there are.

    Returns
    -------
    Recording
        Validated and in SI units (:func:`imucal.recording.make_recording`): per sensor
        ``gyr`` (rad/s) and ``acc`` (m/s^2) in the sensor's frame, the common ``rate``
        (Hz) and ``time`` (s); for vendor exports also each device's provenance
        (``sensor_info``, ``provenance``).

    Raises
    ------
    InputError
        One line naming the file and the problem, for every unusable input.

    Examples
    --------
    >>> from imucal import load_recording
    >>> rec = load_recording("sample_data/circling.h5")
    >>> rec.rate, sorted(rec.sensors), rec.duration
    (100.0, ['foot', 'shank', 'thigh'], 20.0)
    >>> rec.sensor("thigh").gyr.shape  # rad/s, the thigh sensor's frame
    (2000, 3)
    """
    if isinstance(path, bytes):  # as a str: it keeps its trailing '/', which Path drops
        path = os.fsdecode(path)
    if not isinstance(path, str):
        from .atomic import as_path

        path = as_path(path, "a recording's file name")
    try:
        _check_given_rate(path, rate)
        recording = _load(path, rate=rate, gyr_units=gyr_units, acc_units=acc_units)
        if names is not None:
            from .sensor_map import apply_sensor_map

            recording = apply_sensor_map(recording, names)
        return recording
    except InputError as err:
        message = str(err)
        if "\n" in message or "\r" in message:  # a column name or library text with newlines
            raise InputError(_one_line(message)) from None
        raise


def _check_given_rate(path, rate) -> None:
    """InputError unless a given ``rate`` is a sample rate imucal reads: checked before
    any format's reader, which would otherwise each meet inf or 0 in its own way (a
    vendor export divided by it: exit 3)."""
    if rate is None:
        return
    try:
        check_rate(rate)
    except InputError as err:
        raise InputError(f"{path}: --rate: {err}") from None


def _load(path, *, rate, gyr_units, acc_units) -> Recording:
    if str(path) == "-":
        source = "<stdin>"
        parsed = _parse_bytes(_read_stdin(), source)
    elif _is_stream(path, source := str(path)):
        # a pipe (<(...), /dev/stdin, a FIFO) or a device: it can be read only once, so
        # it is read whole and parsed as standard input is (each format's sniffing
        # reopened it, and lost what the one before had read)
        parsed = _parse_bytes(_read_stream(path, source), source)
    else:
        path = Path(path)
        vendor = _vendor(path, source)
        if vendor is not None:
            return _from_vendor(vendor, path, source, rate=rate, gyr_units=gyr_units,
                                acc_units=acc_units)
        suffix = path.suffix.lower()
        head = _read_bytes(path, source, limit=len(HDF5_SIGNATURE))
        if not head:
            raise InputError(f"{source}: file is empty")
        if suffix in HDF5_SUFFIXES or (
            suffix not in CSV_SUFFIXES and head.startswith(HDF5_SIGNATURE)
        ):
            parsed = _guarded(_parse_hdf5, path, source, what="HDF5")
        else:
            data = _read_bytes(path, source)
            parsed = _guarded(_parse_csv, data, source, what="CSV")

    sensors, file_rate, time, units, notes = parsed
    unread = [n for n in notes if isinstance(n, NotTime)]
    if time is None and rate is None and file_rate is None and unread:
        raise InputError(f"{source}: no sample rate and no time stamps: {unread[0]}; name it "
                         "'time' or give --rate")
    for kind, unit in (("gyr", gyr_units), ("acc", acc_units)):
        if unit is not None:
            check_units(kind, unit, f"{source}: --{kind}-units ({kind}_units=)")
    for name in units:
        if gyr_units is not None:
            units[name]["gyr"] = gyr_units
        if acc_units is not None:
            units[name]["acc"] = acc_units
    recording = make_recording(
        sensors,
        rate=rate if rate is not None else file_rate,
        time=time,
        units=units,
        source=source,
        rate_name="--rate" if rate is not None else "the 'sample_rate' attribute",
    )
    # facts about the file that are no problem of its data (columns that are not sensor
    # data: a counter, a temperature): `imucal info` prints them as notes; as warnings
    # they had turned every estimate from such a file into "use with care"
    return replace(recording, provenance={"notes": notes}) if notes else recording


# ----------------------------------------------------------------------------- vendor files


def _vendor(path: Path, source: str):
    """The vendor format module that reads ``path``, None for imucal's own layouts; a
    folder no format claims raises, naming the formats and what the folder holds."""
    from . import formats

    module = formats.detect(path)
    if module is not None or not path.is_dir():
        return module
    try:
        found = sorted(p.name + ("/" if p.is_dir() else "") for p in path.iterdir())
        files = [p for p in path.iterdir() if p.is_file() and not p.name.startswith(".")]
    except OSError as err:
        raise InputError(f"{source}: cannot read folder ({err.strerror or err})") from None
    if files and all(formats.is_empty(p) for p in files):
        raise InputError(f"{source}: every file in the folder is empty: "
                         f"{_short_list(sorted(p.name for p in files), limit=8)}")
    raise InputError(
        f"{source}: is a folder, and not an export imucal reads ({formats.describe_formats()}); "
        f"it holds: {_short_list(found, limit=8) if found else 'nothing'}"
    )


def _check_shapes(s, source: str) -> None:
    """One row of x, y, z per sample in gyr and acc, one time stamp and packet count per
    row: a reader that let a damaged export through ended in an internal error."""
    n = s.gyr.shape[0] if s.gyr.ndim == 2 else -1
    per_row = [("time stamps", s.time), ("packet counters", s.counter)]
    if (n < 1 or s.gyr.shape != (n, 3) or s.acc.shape != (n, 3)
            or any(v is not None and np.shape(v) != (n,) for _, v in per_row)):
        found = [f"gyroscope {s.gyr.shape}", f"accelerometer {s.acc.shape}"] + [
            f"{what} {np.shape(v)}" for what, v in per_row if v is not None]
        raise InputError(f"{source}: sensor '{s.name}': the samples do not line up ("
                         f"{', '.join(found)}; expected N x 3 and N, N > 0)")


def _from_vendor(module, path: Path, source: str, *, rate, gyr_units, acc_units) -> Recording:
    """Read a vendor export, put its devices on one time grid, check it as any recording."""
    from .clock import align

    raw = _guarded(lambda p, src: module.read(p, source=src), path, source,
                   what=module.NAME)
    for kind, unit in (("gyr", gyr_units), ("acc", acc_units)):
        if unit is not None:
            check_units(kind, unit, f"{source}: --{kind}-units ({kind}_units=)")
    milli = []
    for s in raw.sensors:
        _check_shapes(s, source)
        if gyr_units is not None:
            s.gyr_units = gyr_units
        if acc_units is not None:
            s.acc_units = acc_units
        if s.acc_units == "mg":  # milli-g: not one of imucal's units, converted here
            s.acc, s.acc_units = s.acc * 1e-3, "g"
            milli.append(s.name)
        finite = np.isfinite(s.gyr).all(axis=1) & np.isfinite(s.acc).all(axis=1)
        if finite.sum() > 1 and np.array_equal(s.gyr[finite], s.acc[finite]):
            raise InputError(
                f"{source}: sensor '{s.name}': the gyroscope columns repeat the "
                "accelerometer columns (the export mapped the same data twice)"
            )
    _check_one_file_per_sensor(raw.sensors, source)
    aligned = align(raw.sensors, source, rate=rate)
    info = list(raw.info)
    if milli:  # a declared unit converted is no problem: wrong scales are caught by size
        info.append(f"acc of sensor {', '.join(repr(n) for n in milli)} read in mg and "
                    "converted to g")
    units_read = {s.name: {"gyr": s.gyr_units, "acc": s.acc_units} for s in raw.sensors}
    notes = list(raw.notes) + [n for s in raw.sensors for n in s.notes] + aligned.notes
    recording = make_recording(
        {n: {"gyr": g, "acc": a} for n, (g, a) in aligned.data.items()},
        time=aligned.time, units=units_read, source=source, notes=notes,
    )
    provenance = {
        "source_format": raw.format,
        "source": source,
        "files": sorted({f for s in raw.sensors for f in s.files}),
        "serials": {s.name: s.serial for s in raw.sensors},
        "original_rates_hz": {n: i["rate_hz"] for n, i in aligned.info.items()},
        "time_origin": aligned.origin,
        "grid_sensor": aligned.grid_sensor,
        "time_from": {n: i["time_from"] for n, i in aligned.info.items()},
        "dropped_samples": {n: i["dropped"] for n, i in aligned.info.items()},
        "notes": info,
    }
    # imucal info details it per device (imucal.provenance.rate_origin)
    return replace(recording, sensor_info=aligned.info, provenance=provenance,
                   rate_from="--rate" if rate is not None else "the fastest device's clock")


def _check_one_file_per_sensor(sensors, source: str) -> None:
    """Two devices read as one sensor name (two takes of one device in a folder, the same
    export as .txt and .csv, two files without a device ID of one base name): refused,
    naming the files, since which one is meant cannot be guessed."""
    names = [s.name for s in sensors]
    dupes = [n for i, n in enumerate(names) if n in names[:i]]
    if not dupes:
        return
    name = dupes[0]
    same = [s for s in sensors if s.name == name]
    files = [f for s in same for f in (s.files or ["?"])]
    if len(set(files)) < len(files):  # several devices in one file (Shimmer)
        raise InputError(f"{source}: {files[0]} holds {len(files)} devices called {name!r}; "
                         "a sensor name must be unique")
    head = (f"{source}: {' and '.join(files)} are {'both' if len(files) == 2 else 'all'} "
            f"read as sensor {name!r}")
    serials = {s.serial for s in same}
    if None not in serials and len(serials) == len(same):
        raise InputError(f"{head}, devices {', '.join(sorted(serials))}; give each device "
                         "its own name (its file or folder name, or the name set on it)")
    raise InputError(f"{head}; a recording is one file per sensor: move the other take (or "
                     "copy) out of the folder")


# ---------------------------------------------------------------------------------- reading


def _read_stdin() -> bytes:
    stream = getattr(sys.stdin, "buffer", None)
    if stream is None:
        raise InputError("<stdin>: standard input is not available")
    try:
        terminal = stream.isatty()
    except (OSError, ValueError):
        terminal = False
    if terminal:  # it would wait, silently, for a recording typed in
        raise InputError("<stdin>: standard input is a terminal; pipe a recording in "
                         "(imucal axis - < rec.csv) or give its file name")
    try:
        data = _read_capped(stream, "<stdin>")
    except (OSError, ValueError) as err:  # ValueError: read from a closed stream
        raise InputError(f"<stdin>: cannot read standard input ({err})") from None
    if not data:
        raise InputError("<stdin>: standard input is empty (nothing was piped in)")
    return data


def _is_stream(path, source: str) -> bool:
    """Whether ``path`` is an existing file that is neither regular nor a folder (a pipe,
    a FIFO, a device); InputError naming why it cannot be looked at."""
    if source == "":  # an unset shell variable ("$f"): Path("") would be the folder "."
        raise InputError("'': empty file name")
    try:
        st = os.stat(path)
    except ValueError as err:  # a NUL byte in the name
        raise InputError(f"{source}: invalid file name ({err})") from None
    except OSError as err:
        reasons = {errno.ENOENT: "no such file", errno.ELOOP: "symbolic link loop",
                   errno.ENOTDIR: "no such file (a part of the path is not a folder)"}
        if err.errno == errno.ENOTDIR and source.endswith("/") and os.path.isfile(source[:-1]):
            reasons[errno.ENOTDIR] = "is a file, not a folder (drop the trailing '/')"
        reason = reasons.get(err.errno)
        if reason is None:
            kind = "invalid file name" if err.errno == errno.ENAMETOOLONG else "cannot read file"
            reason = f"{kind} ({err.strerror or err})"
        raise InputError(f"{source}: {reason}") from None
    return not (stat.S_ISREG(st.st_mode) or stat.S_ISDIR(st.st_mode))


def _read_stream(path, source: str) -> bytes:
    try:
        with open(path, "rb") as fh:
            if fh.isatty():  # /dev/stdin or /dev/tty on a terminal: it would wait
                raise InputError(f"{source}: is a terminal; pipe a recording in or give "
                                 "its file name")
            data = _read_capped(fh, source)
    except OSError as err:
        raise InputError(f"{source}: cannot read file ({err.strerror or err})") from None
    if not data:
        raise InputError(f"{source}: file is empty")
    return data


#: Bytes per read of a stream: a read of the whole allowance at once reserves it first.
STREAM_CHUNK = 1 << 20


def _read_capped(stream, source: str) -> bytes:
    """All of ``stream``, in chunks, InputError beyond ``MAX_STREAM_BYTES`` or memory."""
    try:
        os.set_blocking(stream.fileno(), True)  # a non-blocking pipe read as empty
    except (AttributeError, OSError, ValueError, io.UnsupportedOperation):
        pass
    chunks, size = [], 0
    try:
        while size <= MAX_STREAM_BYTES:
            chunk = stream.read(min(STREAM_CHUNK, MAX_STREAM_BYTES + 1 - size))
            if not chunk:
                break
            chunks.append(chunk)
            size += len(chunk)
        if size > MAX_STREAM_BYTES:  # (before joining: /dev/zero peaked at twice the cap)
            cap = (f"{MAX_STREAM_BYTES >> 30} GiB" if MAX_STREAM_BYTES >= 1 << 30
                   else f"{MAX_STREAM_BYTES} bytes")
            raise InputError(f"{source}: more than {cap} without an end; save the recording "
                             "to a file and give its name")
        return b"".join(chunks)
    except MemoryError:
        raise InputError(f"{source}: too large to load into memory") from None


def _parse_bytes(data: bytes, source: str):
    """A whole recording read from a stream: imucal's HDF5 or CSV."""
    if data.startswith(HDF5_SIGNATURE):
        return _guarded(_parse_hdf5, io.BytesIO(data), source, what="HDF5")
    return _guarded(_parse_csv, data, source, what="CSV")


def _read_bytes(path: Path, source: str, limit: int = -1) -> bytes:
    try:
        with open(path, "rb") as fh:
            return fh.read(limit)
    except OSError as err:
        raise InputError(f"{source}: cannot read file ({err.strerror or err})") from None


def _guarded(parser, arg, source: str, *, what: str):
    """Run ``parser(arg, source)``; turn any non-InputError failure into an InputError."""
    try:
        return parser(arg, source)
    except InputError:
        raise
    except MemoryError:
        raise InputError(f"{source}: file is too large to load into memory") from None
    except Exception as err:  # final guard: parsers must only ever raise InputError
        detail = _one_line(str(err)) or type(err).__name__
        raise InputError(f"{source}: could not read {what} file: {detail}") from None


def _short_list(names, limit: int = 12) -> str:
    names = [repr(n if len(n) <= 40 else n[:37] + "...") for n in map(str, names)]
    if len(names) > limit:
        names = names[:limit] + [f"... ({len(names) - limit} more)"]
    return ", ".join(names) or "none"


# ------------------------------------------------------------------------------------- HDF5


def _parse_hdf5(file, source: str):
    """Return (sensors, sample_rate, time, units, warnings) from an HDF5 path or file object."""
    try:
        h5 = h5py.File(file, "r")
    except OSError:
        if _starts_with_signature(file):
            raise InputError(
                f"{source}: corrupted or truncated HDF5 file (HDF5 cannot open it)"
            ) from None
        raise InputError(
            f"{source}: not an HDF5 file (it lacks the HDF5 signature); "
            "for CSV data use a .csv name"
        ) from None

    sensors: dict[str, dict[str, np.ndarray]] = {}
    units: dict[str, dict[str, str]] = {}
    try:
        with h5:
            rate = h5.attrs["sample_rate"] if "sample_rate" in h5.attrs else None
            rate = _scalar(rate)
            time = None
            if "time" in h5:
                time = _numeric_dataset(_member(h5, "time", source), f"{source}: 'time'")
            for name in h5:
                obj = _member(h5, name, source)
                if not isinstance(obj, h5py.Group):
                    continue
                present = [k for k in _KINDS if k in obj]
                if not present:
                    continue  # not a sensor (e.g. metadata): skipped silently
                sensors[name] = {}
                units[name] = {}
                for kind in present:
                    what = f"{source}: sensor '{name}' {kind}"
                    data = _member(obj, kind, source, f"{name}/{kind}")
                    sensors[name][kind] = _numeric_dataset(data, what)
                    unit = _attr_text(data.attrs.get("units"))
                    if unit is not None:
                        units[name][kind] = unit
            if not sensors:
                raise InputError(
                    f"{source}: no sensor groups found; expected one group per sensor with "
                    f"datasets 'gyr' and 'acc' (root holds: {_short_list(h5.keys())})"
                )
    except OSError as err:
        raise InputError(
            f"{source}: corrupted or truncated HDF5 file ({_one_line(str(err))})"
        ) from None
    return sensors, rate, time, units, []


def _member(group, name: str, source: str, path: str | None = None):
    """``group[name]``; a link that leads nowhere (a soft link to a removed object, an
    external link to a file not beside it) is an InputError naming it: h5py's "Unable to
    synchronously open object (component not found)" named nothing."""
    try:
        return group[name]
    except (KeyError, OSError):
        link = group.get(name, getlink=True)
        kind = {"SoftLink": "a soft link", "ExternalLink": "an external link"}.get(
            type(link).__name__, "an object")
        target = (f" to '{link.path}'" if isinstance(link, h5py.SoftLink) else
                  f" to '{link.path}' in '{link.filename}'"
                  if isinstance(link, h5py.ExternalLink) else "")
        raise InputError(f"{source}: '{path or name}' is {kind}{target} that cannot be "
                         "opened; remove it or copy in what it points to") from None


def _starts_with_signature(file) -> bool:
    try:
        if isinstance(file, io.BytesIO):
            return file.getvalue().startswith(HDF5_SIGNATURE)
        with open(file, "rb") as fh:
            return fh.read(len(HDF5_SIGNATURE)) == HDF5_SIGNATURE
    except OSError:
        return False


def _numeric_dataset(obj, what: str) -> np.ndarray:
    if not isinstance(obj, h5py.Dataset):
        raise InputError(f"{what} is a {type(obj).__name__}, expected a dataset")
    if obj.dtype.kind in "cb":  # a float cast would drop imaginary parts / turn flags into 0, 1
        raise InputError(f"{what} is not real numbers (dtype {obj.dtype})")
    try:
        return np.asarray(obj[()], dtype=np.float64)
    except (TypeError, ValueError):
        raise InputError(f"{what} is not numeric (dtype {obj.dtype})") from None


def _scalar(value):
    """A size-1 array attribute as a plain value (make_recording checks it further)."""
    if isinstance(value, np.ndarray) and value.size == 1:
        value = value.reshape(-1)[0]
    if isinstance(value, np.generic):
        value = value.item()
    if isinstance(value, bytes):
        value = value.decode("utf-8", errors="replace")
    return value


def _attr_text(value) -> str | None:
    value = _scalar(value)
    return None if value is None else str(value).strip()


# -------------------------------------------------------------------------------------- CSV


def _parse_csv(data: bytes, source: str):
    """Return (sensors, None, time, units, warnings) from the bytes of a CSV file."""
    import pandas as pd

    if data.startswith(HDF5_SIGNATURE):
        raise InputError(f"{source}: not a CSV file; it looks like an HDF5 file, use a .h5 name")
    text = decode_text(data, source, "CSV file")
    ended = ends_line(text)
    # Trailing blank lines and spaces carry no data; leading ones would shift the header.
    text = text.rstrip()
    if not text:
        raise InputError(f"{source}: file is empty (only blank lines)")

    options = dict(header=None, skip_blank_lines=False, keep_default_na=False, low_memory=False)
    try:
        header_row = pd.read_csv(io.StringIO(text), nrows=1, dtype=str, **options)
    except (pd.errors.ParserError, pd.errors.EmptyDataError, ValueError) as err:
        raise InputError(f"{source}: not a valid CSV file: {_parser_detail(err)}") from None
    header = [str(h).strip() for h in header_row.iloc[0].tolist()]
    columns = _map_columns(header, source)
    _check_short_rows(text, len(header), source)
    if not ended:
        _check_cut_number(text, source)

    try:
        table = pd.read_csv(io.StringIO(text), skiprows=1, na_values=list(_NAN_TEXT), **options)
    except pd.errors.EmptyDataError:
        table = pd.DataFrame()
    except (pd.errors.ParserError, ValueError) as err:
        long = _LONG_ROW_RE.search(str(err))
        if long:  # the parser's "line" counts the file's lines, header included
            raise InputError(f"{source}: row {long['line']} has {long['saw']} fields, the "
                             f"header {len(header)}; remove the extra fields") from None
        raise InputError(f"{source}: not a valid CSV file: {_parser_detail(err)}") from None
    if table.shape[0] == 0:
        raise InputError(f"{source}: has a header but no data rows")
    _check_field_count(table, len(header), source)

    def numbers(index: int) -> np.ndarray:
        return _numeric_column(table, index, header[index], source)

    sensors = {
        name: {kind: np.column_stack([numbers(cols[kind, a]) for a in _AXES]) for kind in _KINDS}
        for name, cols in columns["sensors"].items()
    }
    time = numbers(columns["time"]) if columns["time"] is not None else None
    units = {name: {} for name in sensors}
    notes = []
    if columns["ignored"]:
        notes.append(f"ignored columns: {_short_list(columns['ignored'])}")
    like = next((n for n in columns["ignored"] if _TIME_LIKE.match(n)), None)
    if time is None and like is not None:
        notes.append(NotTime(f"column '{like}' is not read as time (only a column named "
                             "'time', in s, is)"))
    return sensors, None, time, units, notes


class NotTime(str):
    """The note on a column that looks like time stamps but is not the 'time' column: a
    str (a note like the others) that :func:`_load` recognises by its type, not its
    words."""


#: A column a user meant as the time stamps ("time (s)", "timestamp", "Time_s") which is
#: not the 'time' column: without a rate, loading stopped at "no sample rate and no time
#: stamps" with no word of it (a new-user trial).
_TIME_LIKE = re.compile(r"^\s*(time|timestamps?|t)\b|^\s*time[_ ]", re.IGNORECASE)


#: pandas' message for a row longer than the rows before it.
_LONG_ROW_RE = re.compile(r"Expected \d+ fields in line (?P<line>\d+), saw (?P<saw>\d+)")


def _check_short_rows(text: str, n_header: int, source: str) -> None:
    """Refuse the first row with fewer fields than the header, naming it: the parser would
    fill the missing fields as empty cells, and a file cut off mid-row (a copy or a
    logger stopped while writing) then read as "column 'x' is empty"."""
    buf = np.frombuffer(text.encode("utf-8"), dtype=np.uint8)
    ends = np.flatnonzero(buf == ord("\n"))
    commas = np.flatnonzero(buf == ord(","))
    # commas before each line's end, less those before its start
    before_end = np.searchsorted(commas, np.append(ends, buf.size))
    fields = np.diff(before_end, prepend=0) + 1
    if fields[0] != n_header:  # quoted commas in the header: the parser's count rules
        return
    short = fields < n_header
    # cut right after a comma: all fields there, the last one empty
    # (unless every row ends so: a header with a trailing comma)
    trailing = buf[:ends[0] if ends.size else buf.size].tobytes().rstrip(b"\r").endswith(b",")
    short[-1] |= (fields.size > 1 and fields[-1] == n_header and text.endswith(",")
                  and not trailing)
    if not short.any():
        return
    i = int(np.argmax(short))
    start = 0 if i == 0 else ends[i - 1] + 1
    stop = ends[i] if i < ends.size else buf.size
    if not buf[start:stop].tobytes().strip():  # blank: reported as such with the cells
        return
    what = f"row {i + 1} has {fields[i]} of the header's {n_header} fields"
    if i == fields.size - 1:
        if fields[i] == n_header:
            what = f"row {i + 1} ends with a comma, its last field empty"
        raise InputError(f"{source}: {what}: the file ends in the middle of its last row "
                         "(cut short while written or copied?); delete that row or get the "
                         "whole file")
    raise InputError(f"{source}: {what}; complete or delete that row")


def _check_cut_number(text: str, source: str) -> None:
    """Refuse a file whose text stops inside its last number (:func:`cut_in_number`), as
    a row cut short is refused: the number would be read shorter than it was written."""
    cut = cut_in_number(text.rsplit("\n", CUT_RULE_ROWS + 1)[1:], ",")  # header excluded
    if cut:
        row = text.count("\n") + 1
        raise InputError(f"{source}: row {row} {cut}: the file ends in the middle of its last "
                         "row (cut short while written or copied?); delete that row or get the "
                         "whole file")


def _parser_detail(err: Exception) -> str:
    return _one_line(str(err)).replace("Error tokenizing data. C error: ", "")


def _map_columns(header: list[str], source: str) -> dict:
    """Find the time column and each sensor's six columns (by index) in the header."""
    seen = set()
    for name in header:
        if name in seen and name:
            raise InputError(f"{source}: column '{name}' appears more than once in the header")
        seen.add(name)

    for sep in (";", "\t", "|"):
        if len(header) == 1 and sep in header[0]:
            raise InputError(
                f"{source}: the header is one column containing {sep!r}; "
                "imucal expects comma-separated values"
            )

    time_col = None
    found: dict[str, dict[tuple[str, str], int]] = {}
    ignored = []
    for index, name in enumerate(header):
        match = _COLUMN_RE.match(name)
        if name.lower() == "time" and time_col is None:
            time_col = index
        elif match:
            key = (match["kind"].lower(), match["axis"].lower())
            found.setdefault(match["sensor"], {})[key] = index
        elif name:
            ignored.append(name)

    if not found:
        # stdin and pipes carry imucal's own CSV only: a vendor export piped in read as a
        # CSV whose columns were 'sep=', ''
        piped = ("; vendor exports are read from their file or folder, not from standard "
                 "input or a pipe" if source == "<stdin>" or not os.path.isfile(source)
                 else "")
        raise InputError(
            f"{source}: no sensor columns found; columns in the file: {_short_list(header)}; "
            f"expected {_EXPECTED_COLUMNS}{piped}"
        )

    incomplete = {s: cols for s, cols in found.items() if len(cols) < 6}
    if incomplete:
        # The sensor with the most columns present is the real one; others are typos of it.
        sensor = max(incomplete, key=lambda s: len(incomplete[s]))
        present = incomplete[sensor]
        missing = [f"{sensor}_{k}_{a}" for k in _KINDS for a in _AXES if (k, a) not in present]
        others = [h for i, h in enumerate(header) if i not in present.values() and i != time_col]
        hints = []
        for name in missing:
            close = difflib.get_close_matches(name, others, n=1, cutoff=0.75)
            if close:
                hints.append(f"'{close[0]}' for '{name}'?")
        hint = f"; did you mean {', '.join(hints)}" if hints else ""
        raise InputError(
            f"{source}: sensor '{sensor}' is missing columns {_short_list(missing)}{hint}"
        )
    return {"time": time_col, "sensors": found, "ignored": ignored}


def _check_field_count(table: pd.DataFrame, n_header: int, source: str) -> None:
    """Rows with more fields than the header are an error unless the extra ones are empty."""
    for index in range(n_header, table.shape[1]):
        column = table[index]
        filled = ~(column.isna() | (column.astype(str).str.strip() == ""))
        if filled.any():
            row = int(np.flatnonzero(filled.to_numpy())[0]) + 2
            raise InputError(
                f"{source}: row {row} has more fields than the header ({n_header} columns)"
            )
    for index in range(table.shape[1], n_header):
        table[index] = ""  # rows shorter than the header: report as empty cells


def _numeric_column(table: pd.DataFrame, index: int, name: str, source: str) -> np.ndarray:
    """Column ``index`` as float64; text or empty cells raise with the row number in the file.

    Rows are numbered as in the file: the header is row 1, the first data row is row 2.
    """
    import pandas as pd

    column = table[index]
    if pd.api.types.is_numeric_dtype(column.dtype):
        return column.to_numpy(dtype=np.float64)
    text = column.astype(str).fillna("nan").str.strip()
    values = pd.to_numeric(text, errors="coerce")
    bad = (values.isna() & ~text.str.lower().isin(_NAN_TEXT)).to_numpy()
    if bad.any():
        i = int(np.flatnonzero(bad)[0])
        row = i + 2
        if text.iloc[i] == "":
            if (table.iloc[i].astype(str).str.strip() == "").all():
                raise InputError(f"{source}: row {row} is blank")
            # pandas' to_csv writes NaN as an empty cell: refused with no word of how to
            # write a dropped sample (a new-user trial)
            hint = ("" if name.lower() == "time" else "; a missing sample is written nan "
                    "(pandas: to_csv(na_rep='nan'))")
            raise InputError(f"{source}: row {row}, column '{name}' is empty{hint}")
        cell = text.iloc[i]
        cell = cell if len(cell) <= 30 else cell[:27] + "..."
        raise InputError(f"{source}: row {row}, column '{name}': {cell!r} is not a number")
    return values.to_numpy(dtype=np.float64)
