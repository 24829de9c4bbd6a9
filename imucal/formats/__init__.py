"""Vendor exports: one module per format. Each module has

* ``NAME``: the format's name in messages and in ``imucal info``;
* ``sniff(path: Path) -> bool``: whether ``path`` (a file or a folder) holds this format,
  judged by its content (cheap: the first bytes or lines, a folder's file names);
* ``read(path: Path, source: str | None = None) -> RawRecording``: every sensor's raw
  samples; ``source`` is the name used in messages (default ``str(path)``);
  :class:`imucal.errors.InputError` naming it and the problem for anything unusable.

A recording is a file or a folder (an export of one file or folder per sensor). Formats
are recognised by their content, not only the name; :func:`detect` asks each module in
:data:`FORMATS` in turn. A reader only parses: it returns every sensor's raw samples in
the units the file declares, with the device's own time stamps and/or packet counter.
:mod:`imucal.clock` then puts the devices on one common time grid, and
:func:`imucal.recording.make_recording` checks and converts to SI units.

The layouts, with where each detail came from, are in ``docs/formats.md``.
"""

from __future__ import annotations

import csv
import io
import re
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..errors import InputError

__all__ = ["RawSensor", "RawRecording", "FORMATS", "detect", "describe_formats",
           "HDF5_SIGNATURE", "HDF5_SUFFIXES"]

#: The first eight bytes of every HDF5 file (its format signature).
HDF5_SIGNATURE = b"\x89HDF\r\n\x1a\n"
#: Name endings imucal reads and writes as HDF5 (any case).
HDF5_SUFFIXES = frozenset({".h5", ".hdf5"})


@dataclass
class RawSensor:
    """One device's samples as the file holds them.

    ``gyr``/``acc`` are (N, 3) in ``gyr_units``/``acc_units`` (any of ``rad/s``,
    ``deg/s``; ``m/s^2``, ``g``, ``mg``). ``time`` is the device's time stamp per sample,
    s, on a clock the devices of one export share (or None); ``counter`` its packet
    counter (integers that wrap at ``counter_wrap``) or None. ``claimed_rate`` is what
    the header says, Hz.
    """

    name: str
    gyr: np.ndarray
    acc: np.ndarray
    gyr_units: str
    acc_units: str
    serial: str | None = None
    time: np.ndarray | None = None
    time_wrap: float | None = None
    counter: np.ndarray | None = None
    counter_wrap: int | None = None
    claimed_rate: float | None = None
    files: list[str] = field(default_factory=list)
    notes: list[str] = field(default_factory=list)


@dataclass
class RawRecording:
    """What a format reader found: its name, the sensors and notes about the files.

    ``notes`` are warnings (they reach a result's ``quality.warnings`` and its verdict);
    ``info`` are facts about the file that are not problems (its format version), shown
    by ``imucal info`` and kept in ``provenance["notes"]``.
    """

    format: str
    sensors: list[RawSensor]
    notes: list[str] = field(default_factory=list)
    info: list[str] = field(default_factory=list)


def export_files(path: Path, is_export) -> list[Path]:
    """The files of a one-file-per-sensor export.

    Returns
    -------
    list[pathlib.Path]
        For a folder ``path``: its files (not subfolders) that ``is_export(file)``
        recognises, sorted by name; for a file: ``[path]`` if ``is_export(path)``, else
        ``[]``.
    """
    if path.is_dir():
        return sorted(p for p in path.iterdir() if p.is_file() and is_export(p))
    return [path] if is_export(path) else []


def read_export(path: Path, source: str, files: list[Path], read_file, format_name: str,
                what: str) -> RawRecording:
    """A :class:`RawRecording` of one-file-per-sensor ``files`` (from :func:`export_files`),
    each read by ``read_file(file, source, many)``; other files in the folder are named
    in a note (``what``: the export's name in messages).

    Returns
    -------
    RawRecording
        ``format=format_name``, one :class:`RawSensor` per file in the order of ``files``,
        and ``notes`` naming the folder's empty files and its other files (hidden ones
        left out).

    Raises
    ------
    InputError
        ``files`` is empty (no file of the export), or ``read_file`` cannot read one.
    """
    if not files:
        raise InputError(f"{source}: no {what} found")
    notes = []
    if path.is_dir():
        others = [p for p in path.iterdir() if p.is_file() and p not in files
                  and not p.name.startswith(".")]
        # An empty file may well be a sensor's failed export: say so, not "not an export"
        empty = sorted(p.name for p in others if is_empty(p))
        others = sorted(p.name for p in others if p.name not in empty)
        if empty:
            notes.append(f"empty files not read: {', '.join(empty)}")
        if others:
            notes.append(f"files not read (not {what}s): {', '.join(others)}")
    return RawRecording(format=format_name, sensors=[read_file(f, source, len(files) > 1)
                                                     for f in files], notes=notes)


def _modules():
    from . import apdm, bids, dot, shimmer, ximu3, xsens

    # Order matters only where two could claim a file: BIDS and x-IMU3 are recognised by
    # their file names, the others by content.
    return [bids, ximu3, apdm, dot, xsens, shimmer]


FORMATS = (
    "imucal HDF5/CSV", "Xsens MT Manager (.txt/.csv)", "Movella DOT (.csv)",
    "APDM Opal (.h5, v5 and v3/v4)", "BIDS-motion (*_motion.tsv)", "x-IMU3 (logged session)",
    "Shimmer Consensys (.csv)",
)


def describe_formats() -> str:
    """The formats imucal reads, as one line for messages and ``--help``.

    Returns
    -------
    str
        :data:`FORMATS` joined by ", ".

    Examples
    --------
    >>> from imucal.formats import describe_formats
    >>> describe_formats()
    'imucal HDF5/CSV, Xsens MT Manager (.txt/.csv), ..., Shimmer Consensys (.csv)'
    """
    return ", ".join(FORMATS)


def detect(path: Path):
    """The format module that reads ``path`` (file or folder).

    Returns
    -------
    module or None
        The first vendor module (BIDS, x-IMU3, APDM, DOT, Xsens, Shimmer, in this order)
        whose ``sniff(path)`` is true; None when none is (imucal's own layouts too), a
        module's sniff failing with a read or parse error counting as false.

    Examples
    --------
    >>> from pathlib import Path
    >>> from imucal.formats import detect
    >>> detect(Path("sample_data/walking.h5")) is None   # imucal's own layout
    True
    """
    for module in _modules():
        try:
            if module.sniff(path):
                return module
        except (OSError, RuntimeError, KeyError, UnicodeError, ValueError):
            # a damaged HDF5 header raises RuntimeError from h5py (exit 3 before); the
            # loader then names the problem
            continue
    return None


# ------------------------------------------------------------------------- text helpers


#: File signatures of archives a lab may hand over instead of the export inside them.
_ARCHIVES = ((b"PK\x03\x04", "zip"), (b"\x1f\x8b", "gzip"), (b"7z\xbc\xaf", "7-Zip"),
             (b"BZh", "bzip2"))


def utf16_text(data: bytes) -> str | None:
    """A file's bytes as UTF-16 text, where they are that.

    Returns
    -------
    str or None
        ``data`` decoded where it starts with a UTF-16 byte-order mark and decodes to
        text without NUL characters before any NUL padding at its end (UTF-32, zeros or
        binary after FF FE do not), the mark dropped; an odd last byte (a file cut off)
        is dropped. None otherwise.
    """
    if data[:2] not in (b"\xff\xfe", b"\xfe\xff"):
        return None
    text = data[:len(data) // 2 * 2].decode("utf-16", errors="replace")
    # (NUL padding after text, a file cut off, is the reader's to report, as in UTF-8)
    body = text.rstrip("\x00")
    return None if "\x00" in body or (body.strip() == "" and body != text) else text


def decode_text(data: bytes, source: str, what: str, hint: str = "",
                scan: int | None = None) -> str:
    """The text of a file's bytes: UTF-16 with its byte-order mark (Excel's "Unicode
    text"), else UTF-8 (with or without a byte-order mark), else Latin-1.

    Returns
    -------
    str
        The text, without a byte-order mark.

    Raises
    ------
    InputError
        "``source``: not a ``what`` (it contains binary data``hint``)": NUL bytes
        outside UTF-16, among the first ``scan`` bytes (None: anywhere; a vendor export
        cut off by a power loss may end in NUL padding, which its reader reports).
    """
    text = utf16_text(data)
    if text is not None:
        return text
    if b"\x00" in (data if scan is None else data[:scan]):
        archive = next((f": a {kind} archive, unpack it first" for magic, kind in _ARCHIVES
                        if data.startswith(magic)), "")
        raise InputError(f"{source}: not a {what} (it contains binary data{archive or hint})")
    try:
        return data.decode("utf-8-sig")
    except UnicodeDecodeError:
        return data.decode("latin-1")


def read_text(path: Path, source: str | None = None) -> str:
    """A text file's content (:func:`decode_text`).

    Returns
    -------
    str
        The whole file decoded, without a byte-order mark; ``source`` (default ``path``)
        names it in messages.

    Raises
    ------
    InputError
        the file cannot be read, or it holds binary data.
    """
    try:
        data = Path(path).read_bytes()
    except OSError as err:
        raise InputError(f"{source or path}: cannot read file ({err.strerror or err})") from None
    return decode_text(data, source or str(path), "text file", scan=4096)


def is_empty(path: Path) -> bool:
    """Whether a file holds nothing but white space (an export that wrote no data).

    Returns
    -------
    bool
        True for a file under 4096 bytes of nothing but white space and UTF-8 byte-order
        marks; False for anything else, and for a file that cannot be read.
    """
    try:
        with open(path, "rb") as fh:
            data = fh.read(4096)
    except OSError:
        return False
    return len(data) < 4096 and not data.replace(b"\xef\xbb\xbf", b"").strip()


def head_text(path: Path, limit: int = 8192) -> str:
    """The first ``limit`` bytes of a file as text (for sniffing).

    Returns
    -------
    str
        Decoded as UTF-8 or, with its byte-order mark, UTF-16 (the mark dropped,
        undecodable bytes replaced by U+FFFD); '' for a file that cannot be read or has
        a NUL byte there (binary).
    """
    try:
        with open(path, "rb") as fh:
            data = fh.read(limit)
    except OSError:
        return ""
    text = utf16_text(data)
    if text is not None:
        return text
    if b"\x00" in data:
        return ""
    return data.decode("utf-8-sig", errors="replace")


def sep_line(line: str) -> str | None:
    """The separator an Excel-style first line declares (``sep=,`` or ``"sep=<TAB>"``).

    Returns
    -------
    str or None
        The one character after ``sep=`` (a tab when the line ends there); None for a
        line that declares none.

    Examples
    --------
    >>> from imucal.formats import sep_line
    >>> sep_line("sep=;\\n"), sep_line("PacketCounter,Acc_X")
    (';', None)
    """
    # (a tab as the separator is stripped with the line's whitespace: "sep=" alone)
    text = line.strip().strip('"').strip("'")
    if text.lower().startswith("sep="):
        return text[4:5] or "\t"
    return None


def header_names(line: str, sep: str) -> list[str]:
    """The column names of a header ``line`` split at ``sep``, each without surrounding
    whitespace and quotes.

    A spreadsheet or script that re-saves an export may quote every header cell
    (``"PacketCounter","SampleTimeFine",...``): read unquoted, the file was not recognised.

    Returns
    -------
    list[str]
        One name per field, in column order.

    Examples
    --------
    >>> from imucal.formats import header_names
    >>> header_names('"PacketCounter", "Acc_X" ', ",")
    ['PacketCounter', 'Acc_X']
    """
    return [_unquoted(c) for c in line.split(sep)]


def _unquoted(cell: str) -> str:
    cell = cell.strip()
    if len(cell) >= 2 and cell[0] == cell[-1] == '"':
        cell = cell[1:-1].replace('""', '"').strip()
    return cell


def header_starts(line: str, name: str) -> bool:
    """Whether the header ``line``'s first cell starts with ``name``.

    Returns
    -------
    bool
        True also when the cell is quoted or indented.
    """
    return line.lstrip().lstrip('"').startswith(name)


def twice(source: str, name: str, first: int, second: int) -> InputError:
    """The error for a column the reader uses that the header names twice (0-based
    ``first``, ``second``): which of the two holds the data is not known, and taking
    either silently read a magnetometer as an accelerometer, or merged two devices.

    Returns
    -------
    InputError
        Not raised: the caller raises it. Its message names ``source``, ``name`` and both
        columns (1-based).
    """
    return InputError(f"{source}: column '{name}' appears twice (columns {first + 1} and "
                      f"{second + 1}); which one holds the data is not known: rename or "
                      "remove one")


def column_index(names: list[str], source: str, used) -> dict[str, int]:
    """Each header name's column.

    Returns
    -------
    dict[str, int]
        Header name -> its column (0-based); a name given twice maps to its first column.

    Raises
    ------
    InputError
        A name in ``used`` is given twice (:func:`twice`).
    """
    col: dict[str, int] = {}
    for i, n in enumerate(names):
        if n in col and n in used:
            raise twice(source, n, col[n], i)
        col.setdefault(n, i)
    return col


def ends_line(text: str) -> bool:
    """Whether ``text`` ends with a line break (NUL padding after it ignored).

    Returns
    -------
    bool
        True where the last row was written whole, up to its line break; a writer that
        never ends its last line looks the same as a file cut off after a number.
    """
    return text.rstrip("\x00").endswith(("\n", "\r"))


#: :func:`cut_in_number` compares the last number with this many rows above it, and judges
#: only files with at least ``CUT_RULE_MIN_ROWS`` rows above it.
CUT_RULE_ROWS = 200
CUT_RULE_MIN_ROWS = 20


def cut_in_number(lines: list[str], sep: str) -> str | None:
    """Why the last of ``lines`` looks cut off inside its last number, or None.

    A file cut off while written can stop inside its last row's last field and leave a
    shorter number ("-0" of "-0.061035") with every field present. Where the
    ``CUT_RULE_ROWS`` rows before it (at least ``CUT_RULE_MIN_ROWS``) all write that field
    with one fixed number of characters after the decimal point (exponent included), a
    last number with fewer is taken as cut. Numbers written with varying decimals (``%g``
    drops trailing zeros: over 200 rows one in ten values ending in 0 shows it; over 20 rows
    1.8 % of cut points misread, a review) are not judged, nor a last field that is no
    number (NaN, Inf, empty). Call it for a file whose text does not end with a line break
    only (:func:`ends_line`).

    Returns
    -------
    str or None
        e.g. "ends in '-0' where the rows above write 6 characters after the point";
        None where the last row is not judged cut.
    """
    if len(lines) < CUT_RULE_MIN_ROWS + 1:
        return None
    field = lines[-1].rstrip("\r\n\x00").rsplit(sep, 1)[-1].strip()
    if not any(ch.isdigit() for ch in field) or field.lower().lstrip("+-") in ("nan", "inf"):
        return None
    above = [ln.rstrip("\r\n").rsplit(sep, 1)[-1].strip() for ln in lines[-CUT_RULE_ROWS - 1:-1]]
    # the characters after the point, exponent included: "1.234e-0" is cut too
    tails = {len(a.partition(".")[2]) if "." in a else -1 for a in above}
    if len(tails) != 1 or (d := tails.pop()) < 1:
        return None
    if "." in field and len(field.partition(".")[2]) >= d:
        return None
    return f"ends in {field[:30]!r} where the rows above write {d} characters after the point"


def parse_table(lines: list[str], sep: str, first_row: int, source: str,
                names: list[str], ended: bool = True,
                short_widths: frozenset = frozenset()) -> tuple[np.ndarray, list[str]]:
    """Numbers of the data ``lines`` as a float (rows, len(names)) array.

    ``first_row`` is the line number of ``lines[0]`` in the file (1-based), for messages;
    ``ended`` says whether the file's text ends with a line break (:func:`ends_line`);
    a row with a number of fields in ``short_widths`` is read as ending in empty cells
    (Shimmer: a device without a sample in that row may leave its block of cells off)
    instead of being refused. Empty names at the header's end (a separator ending the
    header line) are no columns.
    Empty cells and ``NaN`` read as NaN. A last row with fewer fields than the header
    (a truncated file) is dropped with a note, and so is an unended last row whose last
    number is shorter than the rows above write it (:func:`cut_in_number`); a cell
    holding text stops loading with its row and column.

    Raises
    ------
    InputError
        a header without data rows, a table pandas cannot parse, or a cell that is not a
        number (with its row and column).

    Returns
    -------
    values : numpy.ndarray
        (rows, len(names)) float64, the file's numbers as they are (no unit conversion);
        NaN for empty and ``NaN``/``n/a`` cells; fields beyond ``names`` dropped.
    notes : list[str]
        Warnings: the dropped truncated last row, if any.
    """
    import pandas as pd

    notes = []
    while lines and not lines[-1].strip():
        lines = lines[:-1]
    if not lines:
        raise InputError(f"{source}: has a header but no data rows")
    width = len(names)
    while width > 1 and not names[width - 1].strip():  # (a separator ending the header)
        width -= 1
    last = lines[-1].rstrip("\r\n").split(sep)
    if len(last) < width and len(last) not in short_widths and len(lines) > 1:
        lines = lines[:-1]
        notes.append(f"the last row (row {first_row + len(lines)}) has {len(last)} of {width} "
                     "fields: the file was cut off; that row is dropped")
    elif not ended and (cut := cut_in_number(lines, sep)):
        lines = lines[:-1]
        notes.append(f"the last row (row {first_row + len(lines)}) {cut}: the file was cut "
                     "off; that row is dropped")
    _check_row_widths(lines, sep, width, first_row, source, short_widths)
    try:
        table = pd.read_csv(io.StringIO("\n".join(lines)), sep=sep, header=None, dtype=str,
                            keep_default_na=False, skip_blank_lines=False, engine="c",
                            names=range(max(width, len(last))), index_col=False)
    except (pd.errors.ParserError, ValueError) as err:
        raise InputError(f"{source}: not a valid table: {' '.join(str(err).split())}") from None
    table = table.iloc[:, :width]
    text = table.apply(lambda c: c.str.strip())
    lowered = text.apply(lambda c: c.str.lower())
    values = text.apply(pd.to_numeric, errors="coerce")
    blank = (text == "") | lowered.isin(["nan", "-nan", "+nan", "n/a", "na"])
    bad = values.isna() & ~blank & text.notna()
    if bad.to_numpy().any():
        i, j = np.argwhere(bad.to_numpy())[0]
        cell = str(text.iat[i, j])[:30]
        comma = bool(re.fullmatch(r"[-+]?\d*,\d+(?:[eE][-+]?\d+)?", cell))
        raise InputError(
            f"{source}: row {first_row + i}, column '{names[j]}': {cell!r} is not a number"
            + ("; the file writes decimal commas (a spreadsheet's re-save, or an export in "
               "a locale that does?): export it with decimal points" if comma else "")
        )
    return values.to_numpy(dtype=np.float64), notes


def check_comma_separated(names: list[str], where: str, what: str) -> None:
    """Refuse a comma-separated export's header that splits into one column holding ';'
    or a tab: a spreadsheet's re-save (Excel in a locale with decimal commas). A DOT file
    so re-saved was told to export other quantities, with every column there (a new-user
    trial).

    Raises
    ------
    InputError
        Naming ``where``, the separator found and ``what`` the file should be.
    """
    if len(names) == 1 and (sep := next((c for c in ";\t" if c in names[0]), None)):
        raise InputError(f"{where}: the header is one column containing {sep!r}; {what} is "
                         "comma-separated (re-saved by a spreadsheet? use the file as the "
                         "vendor's software exported it)")


def _check_row_widths(lines: list[str], sep: str, width: int, first_row: int,
                      source: str, short_widths: frozenset = frozenset()) -> None:
    """Refuse a data row with fewer fields than the header (unless ``short_widths`` holds
    its count), or with more than the header and the first row hold: the parser filled a
    short row's missing fields as NaN, read as a dropped sample and interpolated with a
    "NaN or Inf" warning naming no row, and a long row stopped loading with the parser's
    line count, not the file's (a new-user trial). imucal's own CSV refuses both the same
    way. Blank lines are left to the cells' rules; a line with quotes is split as the
    parser splits it (a quoted "0,5" is one field)."""
    fields = np.fromiter((ln.count(sep) for ln in lines), np.int64, len(lines)) + 1
    quoted = [i for i, ln in enumerate(lines) if '"' in ln]
    if quoted:  # (one reader for them all: a Shimmer hour quotes every cell)
        counts = [len(cells) for cells in
                  csv.reader((lines[i] for i in quoted), delimiter=sep)]
        if len(counts) != len(quoted):  # a quote left open joined lines: one by one
            counts = [len(next(csv.reader([lines[i]], delimiter=sep), [])) for i in quoted]
        fields[quoted] = counts
    blank = np.fromiter((not ln.strip() for ln in lines), bool, len(lines))
    short = (fields < width) & ~blank & ~np.isin(fields, list(short_widths))
    first = fields[~blank][0] if (~blank).any() else width  # (a tab ending every row)
    long = fields > max(width, int(first))
    if short.any() or long.any():
        i = int(np.argmax(short | long))
        what = (f"{fields[i]} of the header's {width} fields; complete or delete that row"
                if short[i] else
                f"{fields[i]} fields, the header {width}; remove the extra fields")
        raise InputError(f"{source}: row {first_row + i} has {what}")


UNIT_RE = re.compile(r"\(([^()]*)\)\s*$")


def normalise_units(kind: str, text: str | None, default: str) -> str:
    """A vendor's spelling of a unit as imucal's (``deg/s``, ``rad/s``, ``m/s^2``, ``g``,
    ``mg``).

    Returns
    -------
    str
        imucal's spelling; ``default`` for None or blank ``text``; an unknown spelling as
        it is, without spaces (make_recording then names it).

    Examples
    --------
    >>> from imucal.formats import normalise_units
    >>> normalise_units("gyr", "°/s", "rad/s"), normalise_units("acc", "m/s²", "g")
    ('deg/s', 'm/s^2')
    """
    if text is None or not str(text).strip():
        return default
    t = str(text).strip().replace(" ", "").replace("²", "^2").replace("°", "deg")
    low = t.lower()
    table = {
        "gyr": {"deg/s": "deg/s", "degrees/s": "deg/s", "dps": "deg/s", "deg/sec": "deg/s",
                "degs^-1": "deg/s", "rad/s": "rad/s", "rad/sec": "rad/s", "rads^-1": "rad/s"},
        "acc": {"m/s^2": "m/s^2", "m/(s^2)": "m/s^2", "m/s2": "m/s^2", "ms^-2": "m/s^2",
                "m/(s2)": "m/s^2", "g": "g", "mg": "mg"},
    }[kind]
    if t == "mG" or low == "mg":
        return "mg"
    return table.get(low, t)


def header_rate(text: str, pattern: re.Pattern, where: str) -> float | None:
    """The sample rate that ``pattern`` (one group: the number before "Hz") finds in a
    header line ``text``.

    Returns
    -------
    float or None
        The rate in Hz (as written, not checked for plausibility); None where ``pattern``
        finds none.

    Raises
    ------
    InputError
        Naming ``where`` and the line, where the "number" found is none (``.Hz``,
        ``1.0.0Hz``).
    """
    m = pattern.search(text)
    if m is None:
        return None
    try:
        return float(m.group(1))
    except ValueError:
        raise InputError(f"{where}: the header's rate '{text.strip()[:60]}' is not a number "
                         "of Hz; fix that line") from None
