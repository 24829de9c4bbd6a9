"""Write a :class:`~imucal.recording.Recording` to HDF5 or CSV in the layout the loaders read.

See ``docs/formats.md`` for the layout. Files are written atomically
(:func:`imucal.atomic.write_atomic`): to a temporary file in the target folder first, then
moved onto the target, so a failed write never leaves a half-written file behind.
"""

from __future__ import annotations

import io
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from .atomic import write_atomic, write_hdf5_atomic
from .errors import InputError
from .formats import HDF5_SUFFIXES
from .recording import Recording

__all__ = ["save_recording"]

_CSV_SUFFIXES = {".csv"}


def save_recording(
    recording: Recording,
    path: str | Path,
    *,
    extra_attrs: Mapping[str, Any] | None = None,
) -> None:
    """Save ``recording`` (SI units) to ``path``; the format follows the suffix.

    ``.h5``/``.hdf5``: root attribute ``sample_rate``, root dataset ``time``, one group per
    sensor with float64 datasets ``gyr`` (``units="rad/s"``) and ``acc``
    (``units="m/s^2"``); ``extra_attrs`` become further root attributes (they cannot
    replace ``sample_rate``).

    ``.csv``: columns ``time`` then ``<sensor>_gyr_x..z``, ``<sensor>_acc_x..z`` per sensor.
    Sensor values are written with 9 significant digits, times exactly. ``extra_attrs``
    has no place in CSV and is ignored.

    Raises
    ------
    InputError
        Naming ``path``: a suffix other than ``.h5``, ``.hdf5`` or ``.csv``; for HDF5 a
        sensor name HDF5 cannot hold (empty, ``.``, ``time`` or with a ``/``) or an
        ``extra_attrs`` item that is not a non-empty text key with numbers, text or
        arrays of them; a ``path`` that is a folder; or a file that cannot be written
        (:func:`imucal.atomic.write_atomic`).

    Examples
    --------
    >>> import tempfile
    >>> from pathlib import Path
    >>> import imucal
    >>> rec = imucal.load_recording("sample_data/circling.h5")
    >>> part = rec.select(["thigh", "shank"], 0.0, 5.0)
    >>> with tempfile.TemporaryDirectory() as folder:
    ...     imucal.save_recording(part, Path(folder) / "part.csv")
    ...     back = imucal.load_recording(Path(folder) / "part.csv")
    ...     print(sorted(back.sensors), back.n_samples, round(back.rate, 6))
    ['shank', 'thigh'] 500 100.0
    """
    path = Path(path)
    suffix = path.suffix.lower()
    if suffix in HDF5_SUFFIXES:
        write = _write_hdf5
        for name in recording.sensors:
            if "/" in name or name in {"", ".", "time"}:
                raise InputError(f"{path}: sensor name '{name}' cannot be stored in HDF5")
        for key, value in (extra_attrs or {}).items():
            # (h5py raised from inside on a dict or an empty name: a new-user trial)
            if not (isinstance(key, str) and key) or not _storable(value):
                raise InputError(f"{path}: attribute {key!r} ({type(value).__name__}) cannot "
                                 "be stored in HDF5; give numbers, text or arrays of them")
    elif suffix in _CSV_SUFFIXES:
        write = _write_csv
    else:
        raise InputError(
            f"{path}: unknown output format '{suffix or path.name}'; use .h5, .hdf5 or .csv"
        )
    if path.is_dir():
        raise InputError(f"{path}: is a folder; give a file name ending in {suffix}")

    extra = dict(extra_attrs or {})
    if write is _write_hdf5:
        # (track_order: readers list the sensor groups in the recording's order)
        write_hdf5_atomic(path, lambda h5: _write_hdf5(recording, h5, extra))
    else:
        write_atomic(path, lambda tmp: write(recording, tmp, extra))


def _storable(value) -> bool:
    """Whether an HDF5 attribute can hold ``value``: a number, text, or an array of them."""
    if isinstance(value, (str, bytes)):
        return True
    try:
        return np.asarray(value).dtype.kind in "biufcSU"
    except (TypeError, ValueError):
        return False


def _write_hdf5(recording: Recording, h5, extra_attrs: dict) -> None:
    """Fill the open, empty ``h5py.File`` ``h5`` with ``recording``."""
    for key, value in extra_attrs.items():
        if key != "sample_rate":
            h5.attrs[key] = value
    h5.attrs["sample_rate"] = float(recording.rate)
    h5.create_dataset("time", data=np.asarray(recording.time, dtype=np.float64))
    for name, sensor in recording.sensors.items():
        group = h5.create_group(name)
        for kind, unit in (("gyr", "rad/s"), ("acc", "m/s^2")):
            data = np.asarray(getattr(sensor, kind), dtype=np.float64)
            group.create_dataset(kind, data=data).attrs["units"] = unit


def csv_text(recording: Recording) -> str:
    """``recording`` in imucal's CSV layout (as :func:`save_recording` writes a ``.csv``),
    as text: ``imucal convert REC -`` writes it to standard output for a pipeline.

    Returns
    -------
    str
        The CSV file's content.
    """
    buffer = io.StringIO()
    _write_csv(recording, buffer, {})
    return buffer.getvalue()


def _write_csv(recording: Recording, tmp: Path | io.StringIO, extra_attrs: dict) -> None:
    # Times are written exactly (shortest round-trip text): with only 9 significant digits
    # long recordings would gain visible timestamp jitter.
    columns: dict[str, Any] = {"time": [repr(t) for t in np.asarray(recording.time).tolist()]}
    for name, sensor in recording.sensors.items():
        for kind in ("gyr", "acc"):
            data = np.asarray(getattr(sensor, kind), dtype=np.float64)
            for axis, values in zip("xyz", data.T, strict=True):
                columns[f"{name}_{kind}_{axis}"] = values
    # A loaded recording keeps its gaps; "nan" reads back as one, an empty cell would not.
    pd.DataFrame(columns).to_csv(tmp, index=False, float_format="%.9g", na_rep="nan")
