"""APDM Opal / Mobility Lab HDF5 files (all sensors of a session in one file).

Format version 5 (root attribute ``FileFormatVersion`` = 5)::

    /Sensors/<serial>/Accelerometer   (N, 3) m/s^2
    /Sensors/<serial>/Gyroscope       (N, 3) rad/s
    /Sensors/<serial>/Time            (N,) microseconds since 1970-01-01 UTC
    /Sensors/<serial>/Configuration   attributes "Label 0" (the sensor's label), "Sample Rate"

Versions 3 and 4: root attributes ``MonitorLabelList`` and ``CaseIdList`` (same order);
``/<case id>/Time`` (microseconds), ``/<case id>/Calibrated/Accelerometers`` and
``Gyroscopes`` (N, 3), the case group's attribute ``SampleRate``.

A dataset attribute ``Units`` is honoured when present. The ``Time`` stamps of one file
share the access point's clock. Sensors are named by their label; the serial (case ID)
is the alternative. A sensor whose configuration or data cannot be read is skipped with
a warning.
"""

from __future__ import annotations

from pathlib import Path

import h5py
import numpy as np

from ..errors import InputError
from . import HDF5_SIGNATURE, RawRecording, RawSensor, normalise_units

NAME = "APDM Opal HDF5"
US_PER_S = 1e6


def sniff(path: Path) -> bool:
    """Whether ``path`` holds an APDM Opal HDF5 file (the plug-in ``sniff``,
    :mod:`imucal.formats`).

    Returns
    -------
    bool
        True for a file with the HDF5 signature holding a ``Sensors`` group (v5 layout) or
        the ``MonitorLabelList`` and ``CaseIdList`` attributes (v3/v4); False otherwise,
        also for a folder or an HDF5 file h5py cannot open.
    """
    if not path.is_file():
        return False
    with open(path, "rb") as fh:
        if fh.read(8) != HDF5_SIGNATURE:
            return False
    try:
        with h5py.File(path, "r") as h5:
            return ("Sensors" in h5 and isinstance(h5["Sensors"], h5py.Group)) or (
                "MonitorLabelList" in h5.attrs and "CaseIdList" in h5.attrs)
    except OSError:
        return False


def _text(value) -> str:
    if isinstance(value, np.ndarray):
        value = value.reshape(-1)[0] if value.size else ""
    if isinstance(value, (bytes, np.bytes_)):
        value = bytes(value).decode("utf-8", errors="replace")
    return str(value).replace("\x00", "").strip()


def _units(ds, kind: str, default: str) -> str:
    for key in ("Units", "units"):
        if key in ds.attrs:
            return normalise_units(kind, _text(ds.attrs[key]), default)
    return default


def read(path: Path, source: str | None = None) -> RawRecording:
    """``path`` read as an APDM Opal HDF5 file (the plug-in ``read``, :mod:`imucal.formats`).

    Returns
    -------
    RawRecording
        ``format`` "APDM Opal HDF5 v5" or "... v3/v4"; one :class:`RawSensor` per
        readable device (named by its label, else its serial or case ID, which ``serial``
        holds), ``gyr``/``acc`` (N, 3) in the datasets' declared units (rad/s, m/s^2 by
        default), ``time`` s from the earliest device's first stamp (the stamps are us
        since 1970), ``claimed_rate`` Hz (None where the file's is no rate); ``notes``
        the devices skipped, ``info`` the file format version and the clock's time 0.

    Raises
    ------
    InputError
        Naming ``source`` (default ``str(path)``): the file cannot be opened as HDF5
        (corrupted, truncated), the v3/v4 label and case-ID lists do not pair up, or no
        device is readable.
    """
    source = source or str(path)
    try:
        with h5py.File(path, "r") as h5:
            version = _version(h5.attrs.get("FileFormatVersion"))
            if "Sensors" in h5:
                sensors, notes = _read_v5(h5, source)
                layout = "v5"
            else:
                sensors, notes = _read_v3(h5, source)
                layout = "v3/v4"
    except OSError as err:
        raise InputError(
            f"{source}: corrupted or truncated HDF5 file ({' '.join(str(err).split())})"
        ) from None
    if not sensors:
        why = "".join(f"; {n}" for n in notes)
        raise InputError(f"{source}: APDM file ({layout} layout) holds no "
                         f"{'readable sensor' if notes else 'sensor'}{why}")
    # Stamps are integer microseconds since 1970: subtract the earliest in integers, so
    # that seconds keep their microsecond precision (1.7e9 s as float64 would not).
    epoch = min(int(s.time[0]) for s in sensors)
    for s in sensors:
        s.time = (s.time - epoch).astype(np.float64) / US_PER_S
    info = [f"APDM file format version {version} ({layout} layout); time 0 of the clock = "
            f"{epoch} us since 1970-01-01 UTC"]
    return RawRecording(format=f"{NAME} {layout}", sensors=sensors, notes=notes, info=info)


def _version(value) -> int | str | None:
    """The file's format version for the note ``info`` prints: a number when it is one,
    else the text (only the note uses it: the layout is read from the groups)."""
    if value is None:
        return None
    first = np.asarray(value).reshape(-1)
    if first.size == 0:
        return None
    try:
        return int(first[0])
    except (TypeError, ValueError, OverflowError):
        return repr(_text(first[0]))[:20]


def _read_v5(h5, source: str):
    sensors, notes = [], []
    group = h5["Sensors"]
    for serial in group:
        g = group[serial]
        try:
            config = g["Configuration"].attrs
            label = _text(config["Label 0"]) or serial
            rate = _rate_attribute(config, "Sample Rate")
            sensors.append(_sensor(label, str(serial), rate, g["Accelerometer"],
                                   g["Gyroscope"], g["Time"], source))
        except _UNREADABLE as err:
            notes.append(_skipped(serial, err))
    return sensors, notes


def _rate_attribute(attrs, key: str) -> float:
    """The rate attribute ``key`` (Hz), NaN where it is missing or no number: the time
    stamps give the rate then (:func:`_sensor`). A file re-saved without it was refused
    whole, quoting h5py's "can't locate attribute" (a new-user trial)."""
    try:
        return float(np.asarray(attrs[key]).reshape(-1)[0])
    except (KeyError, OSError, TypeError, ValueError, IndexError):
        return float("nan")


#: What reading one sensor's configuration or data can raise in a damaged file.
_UNREADABLE = (KeyError, OSError, TypeError, ValueError, IndexError)


def _sensor(label, serial, rate, acc_ds, gyr_ds, time_ds, source) -> RawSensor:
    """One sensor from its datasets (units from their attributes, SI by default). A
    ValueError names what does not match (the sensor is then skipped with it)."""
    raw = {"Gyroscope": np.asarray(gyr_ds[()]), "Accelerometer": np.asarray(acc_ds[()])}
    for key, values in raw.items():
        # complex numbers would be cast to their real parts (with numpy's raw warning)
        if values.dtype.kind not in "iuf":
            raise ValueError(f"{key} is not real numbers ({values.dtype})")
    gyr, acc = raw["Gyroscope"].astype(float), raw["Accelerometer"].astype(float)
    time = np.asarray(time_ds[()])
    shapes = {"Gyroscope": gyr.shape, "Accelerometer": acc.shape, "Time": time.shape}
    n = time.shape[0] if time.ndim == 1 else -1
    if n < 1 or any(sh != (n, 3) for sh in (gyr.shape, acc.shape)):
        raise ValueError("expected Time (N,) and Gyroscope, Accelerometer (N, 3) with one "
                         "N > 0; found " + ", ".join(f"{k} {v}" for k, v in shapes.items()))
    if not np.issubdtype(time.dtype, np.integer):
        # a re-save (MATLAB, h5py) may store the microseconds as doubles: whole numbers
        # are read as they are; fractions would be another unit
        whole = (np.issubdtype(time.dtype, np.floating) and np.isfinite(time).all()
                 and np.array_equal(time, np.rint(time)))
        if not whole:
            raise ValueError(f"Time holds {time.dtype} values that are not whole "
                             "microseconds")
        if np.abs(time).max() >= 2.0**63:  # beyond int64 (the cast warned, then "do not
            # increase"); 2^63 us is 292 000 years
            raise ValueError(f"Time holds {np.abs(time).max():.3g} us, beyond any clock")
    notes = []
    if not (np.isfinite(rate) and rate > 0):  # checked against the stamps only if a rate
        said = "gives no sample rate" if np.isnan(rate) else f"gives {rate:g} Hz, no rate"
        notes.append(f"sensor '{label}': the file {said}; the time stamps' is used")
        rate = None
    return RawSensor(
        name=label, serial=serial, gyr=gyr, acc=acc,
        gyr_units=_units(gyr_ds, "gyr", "rad/s"), acc_units=_units(acc_ds, "acc", "m/s^2"),
        time=time.astype(np.int64), claimed_rate=rate, files=[Path(source).name],
        notes=notes,
    )


def _skipped(which, err) -> str:
    return (f"sensor {which} skipped: its configuration or data cannot be read "
            f"({' '.join(str(err).split())[:160]})")


def _read_v3(h5, source: str):
    sensors, notes = [], []
    labels = [_text(x) for x in np.asarray(h5.attrs["MonitorLabelList"]).reshape(-1)]
    cases = [_text(x) for x in np.asarray(h5.attrs["CaseIdList"]).reshape(-1)]
    # paired by position: lists of different lengths left sensors out without a word,
    # and a repeated case ID read one device's data under two labels
    if len(labels) != len(cases):
        raise InputError(f"{source}: MonitorLabelList has {len(labels)} entries but "
                         f"CaseIdList {len(cases)}; each device needs one of each")
    repeated = sorted({c for c in cases if cases.count(c) > 1})
    if repeated:
        raise InputError(f"{source}: CaseIdList names device '{repeated[0]}' twice")
    for label, case in zip(labels, cases, strict=True):
        try:
            g = h5[case]
            rate = _rate_attribute(g.attrs, "SampleRate")
            sensors.append(_sensor(label or case, case, rate,
                                   g["Calibrated/Accelerometers"], g["Calibrated/Gyroscopes"],
                                   g["Time"], source))
        except _UNREADABLE as err:
            notes.append(_skipped(case, err))
    return sensors, notes
