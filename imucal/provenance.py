"""What ``imucal info`` and ``imucal convert`` say about a recording and where it came
from (:func:`describe`: the document ``imucal info --json`` prints).

For vendor exports (``imucal.formats``) every sensor has its label, serial, own rate (Hz,
from its time stamps, before it was put on the common grid), start (s on the recording's
time axis; negative: it started before the span all sensors share), duration (s, its own
samples), sample count, units as read and dropped samples; imucal's own layouts have none
of this and get an empty table.
"""

from __future__ import annotations

import json

from .recording import Recording
from .timing import reported_rate

#: How a device's clock gave its period (``sensor_info[...]["time_from"]``).
_CLOCKS = {"time stamps": "its time stamps", "packet counter": "its packet counter at the "
           "header's rate", "sample rate": "the header's rate"}


def describe(recording: Recording) -> dict:
    """The JSON-ready summary ``imucal info`` prints (docs/json.md, "imucal info --json").

    Returns
    -------
    dict
        "path", "sample_rate_hz", "sample_rate_from" (:func:`rate_origin`), "samples",
        "duration_s", "time_s" (first and last sample, s), "warnings" (the recording's
        notes) and per sensor under "sensors": "units" (as read), "gyr_rms_deg_s" and
        "gyr_peak_deg_s" (the rate's norm, deg/s), "acc_dynamic_rms_m_s2" (RMS of
        |acc| - 1 g, m/s^2), "motion" ("still" below
        :data:`imucal.preprocess.STILL_RATE_DEG_S`, "moves", or "no data" when no
        sample is finite; the statistics are then None); for a vendor export also
        "sensor_info" (each device's own rate, serial, start, dropped samples) and
        "provenance" (where it came from, the sensor map used).
    """
    import numpy as np

    from .preprocess import STILL_RATE_DEG_S, rms_rate_deg_s
    from .report import clean
    from .rest import GRAVITY_M_S2

    sensors = {}
    for name, s in recording.sensors.items():
        # gaps are reported as warnings; the statistics describe the samples there are
        fine = np.isfinite(s.gyr).all(axis=1) & np.isfinite(s.acc).all(axis=1)
        units = recording.units.get(name, {})
        if not fine.any():
            sensors[name] = {"units": units, "gyr_rms_deg_s": None, "gyr_peak_deg_s": None,
                             "acc_dynamic_rms_m_s2": None, "motion": "no data"}
            continue
        gyr, acc = s.gyr[fine], s.acc[fine]
        acc_dyn = np.linalg.norm(acc, axis=1) - GRAVITY_M_S2
        rms = rms_rate_deg_s(gyr)
        sensors[name] = {
            "units": units,
            "gyr_rms_deg_s": rms,
            "gyr_peak_deg_s": float(np.degrees(np.linalg.norm(gyr, axis=1)).max()),
            "acc_dynamic_rms_m_s2": float(np.sqrt(np.mean(acc_dyn**2))),
            "motion": "still" if rms < STILL_RATE_DEG_S else "moves",
        }
    doc = clean({
        "path": recording.source,
        "sample_rate_hz": reported_rate(recording.rate),
        "sample_rate_from": rate_origin(recording),
        "samples": recording.n_samples,
        "duration_s": recording.duration,
        "time_s": [recording.time[0], recording.time[-1]],
        "sensors": sensors,
        "warnings": recording.warnings,
    })
    if recording.sensor_info:  # a vendor export: what each device's file said
        doc["sensor_info"] = clean(recording.sensor_info)
    if recording.provenance:  # and where it came from (and the --map used)
        doc["provenance"] = clean(recording.provenance)
    return doc


def rate_origin(recording: Recording) -> str:
    """Where the recording's sample rate came from, as a phrase: for a vendor export the
    device whose samples form the common grid, and the devices interpolated onto it at
    rates of their own (Hz).

    Returns
    -------
    str
        ``recording.rate_from`` for imucal's own layouts (:attr:`Recording.rate_from`);
        for a vendor export "the samples of sensor '<name>' (<its clock>), the common
        grid" (the fastest device, ``provenance["grid_sensor"]``), and "; interpolated
        onto it: '<name>' (<rate> Hz), ..." where devices were.

    Examples
    --------
    >>> import imucal
    >>> from imucal.provenance import rate_origin
    >>> rate_origin(imucal.load_recording("sample_data/walking.h5"))
    "the 'sample_rate' attribute, checked against 'time'"
    """
    info = recording.sensor_info
    if not info:
        return recording.rate_from
    first = recording.provenance.get("grid_sensor")
    if first not in info:  # (a selection without it)
        first = next(iter(info))
    head = info[first]
    how = "--rate" if recording.rate_from == "--rate" else _CLOCKS.get(head["time_from"],
                                                                        head["time_from"])
    text = f"the samples of sensor '{first}' ({how}), the common grid"
    moved = [f"'{n}' ({i['rate_hz']:.6g} Hz)" for n, i in info.items() if i["interpolated"]]
    if moved:
        text += f"; interpolated onto it: {', '.join(moved)}"
    return text


def sensor_table(recording: Recording) -> list[str]:
    """A plain-text table of a vendor export's sensors, for ``imucal info``.

    Returns
    -------
    list[str]
        "format: ...", a header line, then one line per sensor: serial, own rate (Hz),
        start (s), length (s), samples, units read, dropped samples. ``[]`` for imucal's
        own layouts (no ``sensor_info``).
    """
    info = recording.sensor_info
    if not info:
        return []
    fmt = recording.provenance.get("source_format", "")
    w = max([18] + [len(n) + 2 for n in info])  # long names keep the columns in line
    lines = [f"format: {fmt}",
             f"{'sensor':<{w}}{'serial':<20}{'own rate Hz':>12}{'start s':>10}{'length s':>10}"
             f"{'samples':>9}  {'units read':<16}{'dropped':>8}"]
    for name, i in info.items():
        units = f"{i['units_read']['gyr']}, {i['units_read']['acc']}"
        start = round(i["start_s"], 3) + 0.0  # (+ 0.0: no "-0.000" for -0.0002 s)
        lines.append(
            f"{name:<{w}}{str(i.get('serial') or '-'):<20}{i['rate_hz']:>12.4f}"
            f"{start:>10.3f}{i['duration_s']:>10.2f}{i['samples']:>9}  {units:<16}"
            f"{i['dropped']:>8}"
        )
    return lines


def hdf5_attrs(recording: Recording) -> dict:
    """Root attributes recording the provenance in a converted HDF5 file (JSON text for
    the nested ones).

    Returns
    -------
    dict
        ``source`` always, ``sensor_map`` (JSON) after ``--map``; for a vendor export also
        ``source_format``, ``source_files``, ``serials``, ``original_rates_hz`` (Hz),
        ``dropped_samples``, ``sensor_info`` (JSON text each) and ``time_origin_s`` (s,
        float). For imucal's own layouts without a map, ``{"source": ...}`` alone.
    """
    p = recording.provenance
    attrs = {"source": recording.source}
    if "sensor_map" in p:  # --map: the map file and which sensor it renamed to what
        attrs["sensor_map"] = json.dumps(_plain(p["sensor_map"]))
    if "source_format" not in p:
        return attrs
    return {
        **attrs,
        "source_format": str(p.get("source_format", "")),
        "source_files": json.dumps(p.get("files", [])),
        "serials": json.dumps(p.get("serials", {})),
        "original_rates_hz": json.dumps(p.get("original_rates_hz", {})),
        "dropped_samples": json.dumps(p.get("dropped_samples", {})),
        "time_origin_s": float(p.get("time_origin", 0.0)),
        "sensor_info": json.dumps(_plain(recording.sensor_info)),
    }


def _plain(value):
    from .report import clean

    return clean(value)
