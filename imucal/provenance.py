"""What ``imucal info`` and ``imucal convert`` say about where a recording came from.

For vendor exports (``imucal.formats``) every sensor has its label, serial, own rate (Hz,
from its time stamps, before it was put on the common grid), start (s on the recording's
time axis; negative: it started before the span all sensors share), duration (s, its own
samples), sample count, units as read and dropped samples; imucal's own layouts have none
of this and get an empty table.
"""

from __future__ import annotations

import json

from .recording import Recording

#: How a device's clock gave its period (``sensor_info[...]["time_from"]``).
_CLOCKS = {"time stamps": "its time stamps", "packet counter": "its packet counter at the "
           "header's rate", "sample rate": "the header's rate"}


def rate_origin(recording: Recording) -> str:
    """Where the recording's sample rate came from, as a phrase: for a vendor export the
    device whose samples form the common grid, and the devices interpolated onto it at
    rates of their own (Hz)."""
    info = recording.sensor_info
    if not info:
        return recording.rate_from
    first, head = next(iter(info.items()))
    how = "--rate" if recording.rate_from == "--rate" else _CLOCKS.get(head["time_from"],
                                                                        head["time_from"])
    text = f"the samples of sensor '{first}' ({how}), the common grid"
    moved = [f"'{n}' ({i['rate_hz']:.6g} Hz)" for n, i in info.items() if i["interpolated"]]
    if moved:
        text += f"; interpolated onto it: {', '.join(moved)}"
    return text


def sensor_table(recording: Recording) -> list[str]:
    """Lines of a plain-text table, one per sensor of a vendor export ([] otherwise)."""
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
        lines.append(
            f"{name:<{w}}{str(i.get('serial') or '-'):<20}{i['rate_hz']:>12.4f}"
            f"{i['start_s']:>10.3f}{i['duration_s']:>10.2f}{i['samples']:>9}  {units:<16}"
            f"{i['dropped']:>8}"
        )
    return lines


def hdf5_attrs(recording: Recording) -> dict:
    """Root attributes recording the provenance in a converted HDF5 file (JSON text for
    the nested ones); empty for imucal's own layouts."""
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
