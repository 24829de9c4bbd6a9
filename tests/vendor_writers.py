"""Write a simulated recording in vendors' export layouts, as the vendors' tools write them.

Layouts follow docs/formats.md (where each detail came from is stated there). Options:
``names`` maps imucal's sensor names to the vendor's labels; ``late[name] = k`` drops the
first k samples of a sensor (it started late); ``drops[name]`` lists sample indices lost
(dropped packets); ``truncate`` cuts the last file in the middle of its last row.
"""

from __future__ import annotations

from pathlib import Path

import h5py
import numpy as np

RAD2DEG = 180.0 / np.pi
G = 9.80665
SERIALS = {"thigh": "00B42D4F", "shank": "00B42D50", "foot": "00B42D51"}
DOT_MACS = {"thigh": "D4-22-CD-00-12-01", "shank": "D4-22-CD-00-12-02",
            "foot": "D4-22-CD-00-12-03"}
APDM_IDS = {"thigh": "1234", "shank": "1235", "foot": "1236"}


def _rows(rec, name, late=None, drops=None):
    """Sample indices a device writes: all but the late start and the dropped ones."""
    n = rec.n_samples
    keep = np.ones(n, dtype=bool)
    keep[: (late or {}).get(name, 0)] = False
    keep[list((drops or {}).get(name, []))] = False
    return np.flatnonzero(keep)


def _cut(path: Path) -> None:
    text = path.read_bytes()
    path.write_bytes(text[: len(text) - 25])


def xsens(rec, folder: Path, *, names=None, late=None, drops=None, newer=False,
          truncate=False, sep="\t", gyr_scale=1.0) -> Path:
    """MT Manager text export, one ``MT_<prefix>_<deviceID>.txt`` per sensor."""
    folder.mkdir(parents=True, exist_ok=True)
    names = names or SERIALS
    rate = rec.rate
    for name, s in rec.sensors.items():
        dev = names[name]
        rows = _rows(rec, name, late, drops)
        if newer:
            head = ["// General information: ", "//  MT Manager version: 2022.2.0 ",
                    "// Device information: ", f"//  DeviceId: {dev}",
                    "//  ProductCode: MTW2-3A7G6", "// Device settings: ",
                    "//  Filter Profile: human(46.1)", "// Coordinate system: ENU"]
        else:
            head = ["// Start Time: Unknown", f"// Update Rate: {rate:.1f}Hz",
                    "// Filter Profile: human (46.1)",
                    "// Option Flags: AHS Disabled, In-Run Compass Calibration Disabled",
                    "// Firmware Version: 4.0.2"]
        cols = ["PacketCounter", "SampleTimeFine", "Acc_X", "Acc_Y", "Acc_Z",
                "Gyr_X", "Gyr_Y", "Gyr_Z", "Mag_X", "Mag_Y", "Mag_Z", "Roll", "Pitch", "Yaw"]
        lines = head + [sep.join(cols)]
        ticks = int(round(10_000 / rate))
        for i in rows:
            counter = (65_000 + i) % 65_536  # the shared counter wraps at 2^16
            fine = 123_456 + i * ticks
            vals = [*s.acc[i], *(s.gyr[i] * gyr_scale), 0.3, -0.1, 0.9, 1.0, 2.0, 3.0]
            lines.append(sep.join([str(counter), str(fine)] + [f"{v:.9f}" for v in vals]))
        suffix = ".txt" if sep == "\t" else ".csv"
        path = folder / f"MT_012005D6_031-000_{dev}{suffix}"
        path.write_text("\n".join(lines) + "\n", encoding="utf-8")
    if truncate:
        _cut(path)
    return folder


def dot(rec, folder: Path, *, names=None, late=None, drops=None, truncate=False,
        gyr_unit_scale=RAD2DEG) -> Path:
    """Movella DOT CSV export, one ``<tag>_<MAC>_<date>.csv`` per sensor, CRLF lines."""
    folder.mkdir(parents=True, exist_ok=True)
    names = names or {n: n.title() for n in rec.sensors}
    rate = rec.rate
    pad = ",,,,,,,"
    for name, s in rec.sensors.items():
        rows = _rows(rec, name, late, drops)
        lines = ["sep=,", f"DeviceTag:,{names[name]}{pad}", f"FirmwareVersion:,2.6.0{pad}",
                 f"AppVersion:,2023.6.0{pad}", f"SyncStatus:,Synced{pad}",
                 f"OutputRate:,{rate:g}Hz{pad}", f"FilterProfile:,General{pad}",
                 f"Measurement Mode:,Custom Mode 5{pad}",
                 f"StartTime:,2024-03-01 10:00:00.000 +0100{pad}",
                 "\u00a9 Movella Technologies B. V. 2005-2024,,", "",
                 "PacketCounter,SampleTimeFine,Quat_W,Quat_X,Quat_Y,Quat_Z,"
                 "Acc_X,Acc_Y,Acc_Z,Gyr_X,Gyr_Y,Gyr_Z"]
        step = int(round(1e6 / rate))
        for j, i in enumerate(rows):
            fine = (4_294_000_000 + i * step) % 2**32  # the microsecond clock wraps
            vals = [1.0, 0.0, 0.0, 0.0, *s.acc[i], *(s.gyr[i] * gyr_unit_scale)]
            lines.append(",".join([str(j + 1), str(fine)] + [f"{v:.9f}" for v in vals]))
        path = folder / f"{names[name]}_{DOT_MACS[name]}_20240301_100000.csv"
        path.write_bytes(("\r\n".join(lines) + "\r\n").encode("utf-8"))
    if truncate:
        _cut(path)
    return folder


def apdm(rec, path: Path, *, names=None, late=None, drops=None, v3=False,
         skip_config=None, gyr_scale=1.0) -> Path:
    """APDM Opal HDF5, the v5 layout (``/Sensors/<id>``) or the v3/v4 layout."""
    names = names or {"thigh": "Right Thigh", "shank": "Right Lower Leg", "foot": "Right Foot"}
    epoch_us = 1_709_287_200_000_000
    step = int(round(1e6 / rec.rate))
    with h5py.File(path, "w") as h5:
        h5.attrs["FileFormatVersion"] = 3 if v3 else 5
        if v3:
            h5.attrs["MonitorLabelList"] = [names[n].encode() for n in rec.sensors]
            h5.attrs["CaseIdList"] = [f"SI-00{APDM_IDS[n]}".encode() for n in rec.sensors]
        for name, s in rec.sensors.items():
            rows = _rows(rec, name, late, drops)
            time = np.uint64(epoch_us) + rows.astype(np.uint64) * np.uint64(step)
            if v3:
                g = h5.create_group(f"SI-00{APDM_IDS[name]}")
                g.attrs["SampleRate"] = np.uint16(rec.rate)
                g["Time"] = time
                g["Calibrated/Accelerometers"] = s.acc[rows].astype(np.float32)
                g["Calibrated/Gyroscopes"] = (s.gyr[rows] * gyr_scale).astype(np.float32)
                continue
            g = h5.create_group(f"Sensors/{APDM_IDS[name]}")
            g["Time"] = time
            g["Accelerometer"] = s.acc[rows].astype(np.float32)
            g["Accelerometer"].attrs["Units"] = b"m/s^2"
            g["Gyroscope"] = (s.gyr[rows] * gyr_scale).astype(np.float32)
            g["Gyroscope"].attrs["Units"] = b"rad/s"
            g["Magnetometer"] = np.zeros((rows.size, 3), np.float32)
            if name != skip_config:
                c = g.create_group("Configuration")
                c.attrs["Label 0"] = names[name].encode()
                c.attrs["Sample Rate"] = np.uint16(rec.rate)
        h5.create_group("Processed")
        h5.create_group("Annotations")
    return path


def bids(rec, folder: Path, *, late=None, drops=None, truncate=False, gyr_units="rad/s",
         gyr_scale=1.0, points=None) -> Path:
    """BIDS-motion: sub-01_task-walk_tracksys-imu_motion.tsv (+ _channels.tsv, _motion.json).

    One table for all tracked points: a late start or a drop is ``n/a`` in that point's
    columns."""
    folder.mkdir(parents=True, exist_ok=True)
    points = points or {"thigh": "RightThigh", "shank": "RightShank", "foot": "RightFoot"}
    stem = folder / "sub-01_task-walk_tracksys-imu"
    chans = ["name\tcomponent\ttype\ttracked_point\tunits"]
    cols = []
    for name, s in rec.sensors.items():
        keep = np.zeros(rec.n_samples, dtype=bool)
        keep[_rows(rec, name, late, drops)] = True
        for typ, unit, data in (("ACCEL", "m/s^2", s.acc),
                                ("GYRO", gyr_units, s.gyr * gyr_scale)):
            for a, column in zip("xyz", data.T, strict=True):
                chans.append(f"{points[name]}_{typ}_{a}\t{a}\t{typ}\t{points[name]}\t{unit}")
                cols.append(np.where(keep, column, np.nan))
    table = np.column_stack(cols)
    lines = ["\t".join("n/a" if np.isnan(v) else f"{v:.9f}" for v in row) for row in table]
    (folder / f"{stem.name}_channels.tsv").write_text("\n".join(chans) + "\n")
    (folder / f"{stem.name}_motion.json").write_text(
        f'{{"SamplingFrequency": {rec.rate:g}, "TrackingSystemName": "IMU"}}\n')
    path = folder / f"{stem.name}_motion.tsv"
    path.write_text("\n".join(lines) + "\n")
    if truncate:
        _cut(path)
    return folder


def ximu3(rec, folder: Path, *, late=None, drops=None, truncate=False, gyr_scale=RAD2DEG,
          names=None) -> Path:
    """x-IMU3 logged session: ``<name> <serial> (USB)/Inertial.csv`` per device."""
    names = names or {"thigh": "Thigh", "shank": "Shank", "foot": "Foot"}
    serials = {"thigh": "65577B49", "shank": "65577B4A", "foot": "65577B4B"}
    step = int(round(1e6 / rec.rate))
    for name, s in rec.sensors.items():
        dev = folder / f"{names[name]} {serials[name]} (USB)"
        dev.mkdir(parents=True, exist_ok=True)
        lines = ["Timestamp (us),Gyroscope X (deg/s),Gyroscope Y (deg/s),Gyroscope Z (deg/s),"
                 "Accelerometer X (g),Accelerometer Y (g),Accelerometer Z (g)"]
        for i in _rows(rec, name, late, drops):
            vals = [*(s.gyr[i] * gyr_scale), *(s.acc[i] / G)]
            lines.append(",".join([str(5_000_000 + i * step)] + [f"{v:.9f}" for v in vals]))
        path = dev / "Inertial.csv"
        path.write_text("\n".join(lines) + "\n")
        (dev / "Battery.csv").write_text("Timestamp (us),Percentage (%)\n0,90\n")
    if truncate:
        _cut(path)
    return folder


def shimmer(rec, path: Path, *, late=None, drops=None, truncate=False, gyr_scale=RAD2DEG,
            jitter_ms=0.0) -> Path:
    """Shimmer Consensys export: all devices in one tab-separated file, one shared
    millisecond Unix clock per device column, a units row."""
    ids = {"thigh": "D0A7", "shank": "D0A8", "foot": "D0A9"}
    rng = np.random.default_rng(0)
    heads, units, cols = [], [], []
    n = rec.n_samples
    for name, s in rec.sensors.items():
        p = f"Shimmer_{ids[name]}"
        keep = np.zeros(n, dtype=bool)
        keep[_rows(rec, name, late, drops)] = True
        stamp = 1_709_287_200_000 + np.arange(n) * 1000.0 / rec.rate
        stamp = np.round(stamp + rng.normal(0, jitter_ms, n) if jitter_ms else stamp, 3)
        heads += [f"{p}_Timestamp_Unix_CAL"] + [f"{p}_Accel_LN_{a}_CAL" for a in "XYZ"] + [
            f"{p}_Gyro_{a}_CAL" for a in "XYZ"]
        units += ["ms"] + ["m/(s^2)"] * 3 + ["deg/s"] * 3
        cols.append((keep, np.column_stack([stamp, s.acc, s.gyr * gyr_scale])))
    lines = ['"sep=\t"', "\t".join(heads), "\t".join(units)]
    for i in range(n):
        cells = []
        for keep, data in cols:
            cells += [f"{v:.3f}" if j == 0 else f"{v:.9f}" for j, v in enumerate(data[i])] \
                if keep[i] else [""] * 7
        if all(c == "" for c in cells):
            continue
        lines.append("\t".join(cells))
    path.write_text("\n".join(lines) + "\n")
    if truncate:
        _cut(path)
    return path
