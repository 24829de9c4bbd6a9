"""Tests of loading (imucal.loaders, imucal.recording), writing (imucal.writers, imucal.atomic)
and of what the command line answers to every kind of bad input (issue 4's case list)."""

from __future__ import annotations

import io
import os
import re
import subprocess
import sys
from dataclasses import replace
from pathlib import Path
from types import SimpleNamespace

import h5py
import numpy as np
import pytest

from imucal import writers
from imucal.errors import InputError
from imucal.loaders import load_recording
from imucal.recording import make_recording
from imucal.writers import save_recording

N = 200
RATE = 100.0
HEADER = "time,t_gyr_x,t_gyr_y,t_gyr_z,t_acc_x,t_acc_y,t_acc_z\n"


def random_recording(names=("thigh", "shank"), n=N, rate=RATE, seed=0):
    rng = np.random.default_rng(seed)
    sensors = {
        name: {"gyr": rng.normal(0, 2, (n, 3)), "acc": rng.normal(0, 9, (n, 3))} for name in names
    }
    return make_recording(sensors, rate=rate, source="<test>")


def write_h5(path, sensors, *, rate=RATE, time=None, units=None):
    """Write raw arrays in the input layout; ``units``: {(sensor, kind): attribute value}."""
    with h5py.File(path, "w") as h5:
        if rate is not None:
            h5.attrs["sample_rate"] = rate
        if time is not None:
            h5["time"] = time
        for name, data in sensors.items():
            group = h5.create_group(name)
            for kind, arr in data.items():
                group[kind] = arr
                if units and (name, kind) in units:
                    group[kind].attrs["units"] = units[name, kind]
    return path


def csv_text(rows, header=HEADER):
    return header + "".join(",".join(str(v) for v in row) + "\n" for row in rows)


def good_rows(n=5):
    return [[i / RATE, 1, 2, 3, 4, 5, 6] for i in range(n)]


def expect_error(path, phrase, *, use=False, **kwargs):
    """Loading ``path`` (with ``use``, and selecting all its sensors for an estimate) fails
    with one line naming the file and containing ``phrase``."""
    with pytest.raises(InputError) as info:
        rec = load_recording(path, **kwargs)
        if use:
            rec.select(list(rec.sensors))
    message = str(info.value)
    assert phrase in message
    assert ("<stdin>" if path == "-" else str(path)) in message
    assert "\n" not in message
    return message


def assert_same(loaded, original, rtol):
    assert list(loaded.sensors) == list(original.sensors)
    for name, sensor in original.sensors.items():
        np.testing.assert_allclose(loaded.sensors[name].gyr, sensor.gyr, rtol=rtol, atol=0)
        np.testing.assert_allclose(loaded.sensors[name].acc, sensor.acc, rtol=rtol, atol=0)
    np.testing.assert_allclose(loaded.time, original.time, rtol=rtol, atol=1e-12)
    assert loaded.rate == pytest.approx(original.rate, rel=1e-9)


# ----------------------------------------------------------------------------- round trips


def test_round_trip_hdf5_is_exact(tmp_path):
    rec = random_recording(names=("thigh", "left_shank", "foot"))
    path = tmp_path / "rec.h5"
    save_recording(rec, path)
    loaded = load_recording(path)
    assert_same(loaded, rec, rtol=1e-9)
    assert loaded.rate == rec.rate
    assert loaded.source == str(path)
    assert loaded.units["thigh"] == {"gyr": "rad/s", "acc": "m/s^2"}


def test_round_trip_csv(tmp_path):
    rec = random_recording(names=("thigh", "left_shank"))
    path = tmp_path / "rec.csv"
    save_recording(rec, path)
    loaded = load_recording(path)
    # sensor values are written with 9 significant digits (relative error <= 5e-9)
    assert_same(loaded, rec, rtol=1e-8)
    np.testing.assert_array_equal(loaded.time, rec.time)  # times are written exactly


def test_round_trip_hdf5_suffix_and_sniffing(tmp_path):
    rec = random_recording()
    save_recording(rec, tmp_path / "rec.hdf5")
    (tmp_path / "rec.hdf5").rename(tmp_path / "rec.dat")
    assert_same(load_recording(tmp_path / "rec.dat"), rec, rtol=1e-9)
    save_recording(rec, tmp_path / "rec.csv")
    (tmp_path / "rec.csv").rename(tmp_path / "rec.log")
    assert_same(load_recording(str(tmp_path / "rec.log")), rec, rtol=1e-8)


def test_saved_hdf5_layout(tmp_path):
    rec = random_recording(names=("thigh",))
    path = tmp_path / "rec.h5"
    save_recording(rec, path, extra_attrs={"true_axis": [0.0, 0.0, 1.0], "sample_rate": 1})
    with h5py.File(path, "r") as h5:
        assert h5.attrs["sample_rate"] == RATE
        np.testing.assert_array_equal(h5.attrs["true_axis"], [0.0, 0.0, 1.0])
        np.testing.assert_array_equal(h5["time"][()], rec.time)
        assert h5["thigh/gyr"].dtype == np.float64
        assert h5["thigh/gyr"].attrs["units"] == "rad/s"
        assert h5["thigh/acc"].attrs["units"] == "m/s^2"
        assert h5["thigh/acc"].shape == (N, 3)


def test_saved_csv_columns(tmp_path):
    path = tmp_path / "rec.csv"
    save_recording(random_recording(names=("a", "b_c")), path)
    header = path.read_text().splitlines()[0].split(",")
    axes = [f"{k}_{a}" for k in ("gyr", "acc") for a in "xyz"]
    assert header == ["time"] + [f"a_{x}" for x in axes] + [f"b_c_{x}" for x in axes]


def test_save_replaces_atomically_and_cleans_up(tmp_path, monkeypatch):
    path = tmp_path / "rec.csv"
    path.write_text("old contents")

    def broken(*args):
        raise RuntimeError("disk on fire")

    monkeypatch.setattr(writers, "_write_csv", broken)
    with pytest.raises(RuntimeError):
        save_recording(random_recording(), path)
    assert path.read_text() == "old contents"
    assert os.listdir(tmp_path) == ["rec.csv"]


def test_save_unknown_suffix(tmp_path):
    with pytest.raises(InputError, match="unknown output format '.txt'"):
        save_recording(random_recording(), tmp_path / "rec.txt")


def test_save_into_missing_folder(tmp_path):
    target = tmp_path / "no" / "such" / "rec.h5"
    with pytest.raises(InputError, match="cannot write") as info:
        save_recording(random_recording(), target)
    assert str(target) in str(info.value)


def test_save_below_a_file_fails_cleanly(tmp_path):
    # A parent that is a file cannot hold a folder entry, even for root.
    blocker = tmp_path / "plain.txt"
    blocker.write_text("not a folder")
    with pytest.raises(InputError, match="cannot write"):
        save_recording(random_recording(), blocker / "rec.csv")
    assert blocker.read_text() == "not a folder"


# ----------------------------------------------------------------------- units and timing


def test_hdf5_units_attributes_are_converted(tmp_path):
    rng = np.random.default_rng(1)
    gyr, acc = rng.normal(size=(N, 3)), rng.normal(size=(N, 3))
    units = {("s", "gyr"): "deg/s", ("s", "acc"): b"g"}  # str and bytes attributes
    path = write_h5(tmp_path / "u.h5", {"s": {"gyr": gyr, "acc": acc}}, units=units)
    rec = load_recording(path)
    np.testing.assert_allclose(rec.sensors["s"].gyr, np.deg2rad(gyr), rtol=1e-12)
    np.testing.assert_allclose(rec.sensors["s"].acc, acc * 9.80665, rtol=1e-12)
    assert rec.units["s"] == {"gyr": "deg/s", "acc": "g"}


def test_unit_arguments_override_hdf5_attributes(tmp_path):
    gyr = np.ones((N, 3))
    units = {("s", "gyr"): "rad/s", ("s", "acc"): "m/s^2"}
    path = write_h5(tmp_path / "u.h5", {"s": {"gyr": gyr, "acc": gyr}}, units=units)
    rec = load_recording(path, gyr_units="deg/s", acc_units="g")
    np.testing.assert_allclose(rec.sensors["s"].gyr, np.deg2rad(gyr))
    np.testing.assert_allclose(rec.sensors["s"].acc, 9.80665 * gyr)


def test_hdf5_unknown_units(tmp_path):
    ones = np.ones((N, 3))
    path = write_h5(
        tmp_path / "u.h5", {"s": {"gyr": ones, "acc": ones}}, units={("s", "gyr"): "rpm"}
    )
    expect_error(path, "unknown units 'rpm'")


def test_csv_units_from_arguments(tmp_path):
    path = tmp_path / "u.csv"
    path.write_text(csv_text(good_rows()))
    rec = load_recording(path, gyr_units="deg/s", acc_units="g")
    np.testing.assert_allclose(rec.sensors["t"].gyr[0], np.deg2rad([1, 2, 3]))
    np.testing.assert_allclose(rec.sensors["t"].acc[0], 9.80665 * np.array([4, 5, 6]))
    assert rec.units == {"t": {"gyr": "deg/s", "acc": "g"}}


def test_hdf5_time_only(tmp_path):
    ones = np.ones((N, 3))
    time = 5.0 + np.arange(N) / 50.0
    path = write_h5(tmp_path / "t.h5", {"s": {"gyr": ones, "acc": ones}}, rate=None, time=time)
    rec = load_recording(path)
    assert rec.rate == pytest.approx(50.0)
    np.testing.assert_array_equal(rec.time, time)


def test_hdf5_rate_only(tmp_path):
    ones = np.ones((N, 3))
    path = write_h5(tmp_path / "r.h5", {"s": {"gyr": ones, "acc": ones}}, rate=200)
    rec = load_recording(path)
    assert rec.rate == 200.0
    np.testing.assert_allclose(rec.time, np.arange(N) / 200.0)


def test_rate_argument_overrides_sample_rate_attribute(tmp_path):
    ones = np.ones((N, 3))
    path = write_h5(tmp_path / "r.h5", {"s": {"gyr": ones, "acc": ones}}, rate=200)
    assert load_recording(path, rate=400).rate == 400.0


def test_rate_argument_must_agree_with_time(tmp_path):
    ones = np.ones((N, 3))
    path = write_h5(tmp_path / "r.h5", {"s": {"gyr": ones, "acc": ones}}, time=np.arange(N) / 100)
    expect_error(path, "the rate given ('sample_rate' or --rate) says 50 Hz but 'time' says "
                 "100 Hz", rate=50)


def test_csv_rate_only(tmp_path):
    path = tmp_path / "r.csv"
    path.write_text(csv_text([row[1:] for row in good_rows()], header=HEADER[5:]))
    rec = load_recording(path, rate=25)
    assert rec.rate == 25.0
    assert rec.n_samples == 5


def test_csv_without_time_needs_rate(tmp_path):
    path = tmp_path / "r.csv"
    path.write_text(csv_text([row[1:] for row in good_rows()], header=HEADER[5:]))
    expect_error(path, "no sample rate and no time stamps")


def test_csv_time_column_gives_rate(tmp_path):
    path = tmp_path / "t.csv"
    path.write_text(csv_text(good_rows(10)))
    rec = load_recording(path)
    assert rec.rate == pytest.approx(RATE)


# ------------------------------------------------------------------------ names and stdin


def test_sensor_names_with_underscores(tmp_path):
    header = "left_thigh_gyr_x,left_thigh_gyr_y,left_thigh_gyr_z,left_thigh_acc_x,"
    header += "left_thigh_acc_y,left_thigh_acc_z,a_gyr_b_gyr_x,a_gyr_b_gyr_y,a_gyr_b_gyr_z,"
    header += "a_gyr_b_acc_x,a_gyr_b_acc_y,a_gyr_b_acc_z\n"
    path = tmp_path / "names.csv"
    path.write_text(csv_text([list(range(12))] * 3, header=header))
    rec = load_recording(path, rate=10)
    assert list(rec.sensors) == ["left_thigh", "a_gyr_b"]
    np.testing.assert_array_equal(rec.sensors["a_gyr_b"].acc[0], [9, 10, 11])


def test_other_columns_are_ignored_with_a_note(tmp_path):
    # a note, not a warning: as a warning it turned every estimate from a lab export with
    # a counter or temperature column into "use with care" (docs/formats.md: a note)
    path = tmp_path / "extra.csv"
    header = HEADER.rstrip("\n") + ",temperature\n"
    path.write_text(csv_text([row + [21.5] for row in good_rows()], header=header))
    rec = load_recording(path)
    assert list(rec.sensors) == ["t"]
    assert rec.provenance["notes"] == ["ignored columns: 'temperature'"]
    assert not any("temperature" in w for w in rec.warnings)
    assert not any("temperature" in w for w in rec.select(["t"]).warnings)


def test_read_csv_from_stdin(monkeypatch):
    data = csv_text(good_rows()).encode()
    monkeypatch.setattr(sys, "stdin", SimpleNamespace(buffer=io.BytesIO(data)))
    rec = load_recording("-")
    assert rec.source == "<stdin>"
    assert rec.n_samples == 5
    np.testing.assert_array_equal(rec.sensors["t"].acc[-1], [4, 5, 6])


def test_a_vendor_export_on_stdin_is_told_to_come_as_a_file(monkeypatch):
    # a Movella DOT CSV piped in: "columns in the file: 'sep=', ''" and nothing more
    data = b"sep=,\nDeviceTag:,Left Shank\nPacketCounter,SampleTimeFine,Acc_X\n1,2,3\n"
    monkeypatch.setattr(sys, "stdin", SimpleNamespace(buffer=io.BytesIO(data)))
    expect_error("-", "vendor exports are read from their file or folder, not from "
                      "standard input")


def test_empty_stdin(monkeypatch):
    monkeypatch.setattr(sys, "stdin", SimpleNamespace(buffer=io.BytesIO(b"")))
    expect_error("-", "standard input is empty")


def test_utf8_bom_and_windows_line_endings(tmp_path):
    path = tmp_path / "bom.csv"
    path.write_bytes(b"\xef\xbb\xbf" + csv_text(good_rows()).replace("\n", "\r\n").encode())
    assert load_recording(path).n_samples == 5


@pytest.mark.parametrize("encoding", ["utf-16-le", "utf-16-be"])
def test_utf16_with_its_byte_order_mark(tmp_path, encoding):
    # Excel's "Unicode text" is UTF-16: it was refused as "binary data" (a new-user trial)
    path = tmp_path / "unicode.csv"
    bom = b"\xff\xfe" if encoding.endswith("le") else b"\xfe\xff"
    path.write_bytes(bom + csv_text(good_rows()).replace("\n", "\r\n").encode(encoding))
    rec = load_recording(path)
    plain = tmp_path / "plain.csv"
    plain.write_text(csv_text(good_rows()))
    assert rec.n_samples == 5
    np.testing.assert_array_equal(rec.sensor("t").gyr, load_recording(plain).sensor("t").gyr)


# ---------------------------------------------------------------------------------- errors


@pytest.mark.parametrize(("link", "name"), [("soft", "meta"), ("external", "meta"),
                                            ("soft", "time")])
def test_a_link_that_leads_nowhere_is_named(tmp_path, link, name):
    # "could not read HDF5 file: 'Unable to synchronously open object (component not
    # found)'" named no object (a new-user trial; 'time', an independent review)
    path = tmp_path / "linked.h5"
    rec = random_recording()
    write_h5(path, {n: {"gyr": s.gyr, "acc": s.acc} for n, s in rec.sensors.items()})
    with h5py.File(path, "a") as h5:
        h5[name] = (h5py.SoftLink("/nothere") if link == "soft"
                    else h5py.ExternalLink("missing.h5", "/x"))
    target = "'/nothere'" if link == "soft" else "'/x' in 'missing.h5'"
    expect_error(path, f"'{name}' is {'a soft' if link == 'soft' else 'an external'} link "
                 f"to {target} that cannot be opened")


def test_missing_file(tmp_path):
    expect_error(tmp_path / "nope.h5", "no such file")


def test_folder_instead_of_file(tmp_path):
    expect_error(tmp_path, "is a folder")


@pytest.mark.parametrize("name", ["empty.csv", "empty.h5", "empty.bin"])
def test_empty_file(tmp_path, name):
    path = tmp_path / name
    path.write_bytes(b"")
    expect_error(path, "file is empty")


def test_blank_lines_only(tmp_path):
    path = tmp_path / "blank.csv"
    path.write_text("\n \n\n")
    expect_error(path, "file is empty")


def test_not_hdf5(tmp_path):
    path = tmp_path / "text.h5"
    path.write_text(csv_text(good_rows()))
    expect_error(path, "not an HDF5 file")


def test_not_csv(tmp_path):
    path = tmp_path / "binary.csv"
    path.write_bytes(bytes(range(256)) * 4)
    expect_error(path, "not a CSV file")


def test_hdf5_named_csv(tmp_path):
    save_recording(random_recording(), tmp_path / "rec.h5")
    (tmp_path / "rec.h5").rename(tmp_path / "rec.csv")
    expect_error(tmp_path / "rec.csv", "looks like an HDF5 file")


def test_corrupted_hdf5(tmp_path):
    path = tmp_path / "bad.h5"
    path.write_bytes(b"\x89HDF\r\n\x1a\n" + b"\xff" * 500)
    expect_error(path, "corrupted or truncated HDF5")


def test_truncated_hdf5(tmp_path):
    good = tmp_path / "good.h5"
    save_recording(random_recording(), good)
    path = tmp_path / "cut.h5"
    path.write_bytes(good.read_bytes()[: good.stat().st_size // 2])
    expect_error(path, "corrupted or truncated HDF5")


def test_hdf5_group_without_acc(tmp_path):
    ones = np.ones((N, 3))
    path = write_h5(tmp_path / "g.h5", {"s": {"gyr": ones, "acc": ones}, "t": {"gyr": ones}})
    expect_error(path, "sensor 't' has no 'acc' data")


def test_hdf5_sensor_name_that_is_not_utf8(tmp_path):
    ones = np.ones((N, 3))
    path = tmp_path / "latin1.h5"
    with h5py.File(path, "w") as h5:
        h5.attrs["sample_rate"] = RATE
        for kind in ("gyr", "acc"):
            h5[b"b\xe9b\xe9/" + kind.encode()] = ones
    rec = load_recording(path)
    assert list(rec.sensors) == ["b\u00e9b\u00e9"]  # read as Latin-1, so it can be typed
    assert rec.sensor("bébé").gyr.shape == (N, 3)


def test_hdf5_groups_without_data_are_skipped(tmp_path):
    ones = np.ones((N, 3))
    path = write_h5(tmp_path / "g.h5", {"s": {"gyr": ones, "acc": ones}, "meta": {}})
    assert list(load_recording(path).sensors) == ["s"]


def test_hdf5_without_sensor_groups(tmp_path):
    path = tmp_path / "flat.h5"
    with h5py.File(path, "w") as h5:
        h5.attrs["sample_rate"] = RATE
        h5["gyr"] = np.ones((N, 3))
        h5["acc"] = np.ones((N, 3))
    message = expect_error(path, "no sensor groups found")
    assert "'acc', 'gyr'" in message


def test_hdf5_non_numeric_dataset(tmp_path):
    path = tmp_path / "text.h5"
    with h5py.File(path, "w") as h5:
        h5.attrs["sample_rate"] = RATE
        h5["s/gyr"] = np.array([b"a", b"b", b"c"] * 3).reshape(3, 3)
        h5["s/acc"] = np.ones((3, 3))
    expect_error(path, "sensor 's' gyr is not numeric")


def test_hdf5_transposed_data(tmp_path):
    path = write_h5(tmp_path / "tr.h5", {"s": {"gyr": np.ones((3, N)), "acc": np.ones((3, N))}})
    expect_error(path, "looks transposed")


def test_csv_without_sensor_columns(tmp_path):
    path = tmp_path / "cols.csv"
    path.write_text("time,ax,ay\n0,1,2\n0.01,1,2\n")
    message = expect_error(path, "no sensor columns found")
    assert "'time', 'ax', 'ay'" in message
    assert "<sensor>_gyr_x" in message


def test_csv_with_semicolons(tmp_path):
    path = tmp_path / "semi.csv"
    path.write_text(HEADER.replace(",", ";") + "0;1;2;3;4;5;6\n")
    expect_error(path, "one column containing ';'; imucal expects comma-separated")


def test_csv_incomplete_sensor_suggests_close_name(tmp_path):
    path = tmp_path / "typo.csv"
    path.write_text(csv_text(good_rows(), header=HEADER.replace("t_acc_z", "t_acc_zz")))
    message = expect_error(path, "sensor 't' is missing columns 't_acc_z'")
    assert "did you mean 't_acc_zz'" in message


def test_csv_misspelled_sensor_name(tmp_path):
    header = "thigh_gyr_x,thigh_gyr_y,thigh_gyr_z,thigh_acc_x,thigh_acc_y,thihg_acc_z\n"
    path = tmp_path / "typo.csv"
    path.write_text(csv_text([[1, 2, 3, 4, 5, 6]] * 3, header=header))
    message = expect_error(path, "sensor 'thigh' is missing columns 'thigh_acc_z'", rate=10)
    assert "'thihg_acc_z'" in message


def test_csv_duplicate_column(tmp_path):
    path = tmp_path / "dup.csv"
    path.write_text(csv_text([r + [1] for r in good_rows()], header=HEADER[:-1] + ",t_gyr_x\n"))
    expect_error(path, "column 't_gyr_x' appears more than once")


def test_csv_text_in_numeric_cell(tmp_path):
    rows = good_rows()
    rows[2][5] = "oops"  # third data row = fourth line of the file
    path = tmp_path / "text.csv"
    path.write_text(csv_text(rows))
    expect_error(path, "row 4, column 't_acc_y': 'oops' is not a number")


def test_csv_empty_cell(tmp_path):
    rows = good_rows()
    rows[0][1] = ""
    path = tmp_path / "hole.csv"
    path.write_text(csv_text(rows))
    expect_error(path, "row 2, column 't_gyr_x' is empty")


def test_csv_from_pandas_with_nan_as_empty_cells_says_how_to_write_them(tmp_path):
    # DataFrame.to_csv writes NaN as an empty cell by default: refused with no word of
    # na_rep (a new-user trial); written as its hint says, the gap loads
    import pandas as pd

    table = pd.read_csv(Path(__file__).parent.parent / "sample_data" / "circling_40hz.csv")
    table.loc[100:101, "shank_gyr_x"] = float("nan")
    path = tmp_path / "gap.csv"
    table.to_csv(path, index=False)
    message = expect_error(path, "row 102, column 'shank_gyr_x' is empty; a missing "
                           "sample is written nan (pandas: to_csv(na_rep='nan'))")
    assert message.startswith(f"{path}: ")
    table.to_csv(path, index=False, na_rep="nan")
    assert load_recording(path).n_samples == len(table)
    rows = good_rows()
    rows[0][0] = ""  # no sample to miss in the time column: no hint there
    path.write_text(csv_text(rows))
    message = expect_error(path, "row 2, column 'time' is empty")
    assert message.endswith("is empty")


def test_csv_blank_line_inside_data(tmp_path):
    path = tmp_path / "gap.csv"
    lines = csv_text(good_rows()).splitlines(keepends=True)
    path.write_text("".join(lines[:3] + ["\n"] + lines[3:]))
    expect_error(path, "row 4 is blank")


def test_csv_row_with_extra_fields(tmp_path):
    # was "not a valid CSV file: Expected 7 fields in line 7, saw 8"
    path = tmp_path / "long.csv"
    path.write_text(csv_text(good_rows()) + "0.05,1,2,3,4,5,6,7\n")
    message = expect_error(path, "row 7 has 8 fields, the header 7; remove the extra fields")
    assert "Expected" not in message


def test_csv_row_with_too_few_fields(tmp_path):
    # a row of 4 fields read as "row 3, column 't_acc_y' is empty"
    rows = good_rows()
    rows[1] = rows[1][:4]
    path = tmp_path / "short.csv"
    path.write_text(csv_text(rows))
    expect_error(path, "row 3 has 4 of the header's 7 fields; complete or delete that row")
    rows = good_rows()
    rows[1][5] = ""  # an empty cell among all seven fields is still an empty cell
    path.write_text(csv_text(rows))
    expect_error(path, "row 3, column 't_acc_y' is empty")


CUT = ("the file ends in the middle of its last row (cut short while written or copied?); "
       "delete that row or get the whole file")


@pytest.mark.parametrize("keep, what", [
    (-5, "row 6 has 5 of the header's 7 fields"),  # cut inside the row
    (-2, "row 6 ends with a comma, its last field empty"),  # cut right after a comma
])
def test_csv_cut_in_its_last_row_is_one_line_exit_2(tmp_path, keep, what):
    # was "row 6, column 't_acc_y' is empty": no word of a truncated file
    text = csv_text(good_rows())[:keep]
    path = tmp_path / "cut.csv"
    path.write_text(text)
    assert expect_error(path, what) == f"{path}: {what}: {CUT}"
    out = tmp_path / "out.json"
    for args in (["axis", path, "--out", out], ["convert", path, tmp_path / "c.h5"],
                 ["info", "-"]):
        result = cli(*args, stdin=text.encode())
        assert_one_line_error(result, "<stdin>" if "-" in args else str(path), what)
        assert result.stderr.strip().endswith(CUT)
    assert not out.exists() and not (tmp_path / "c.h5").exists()


def test_csv_cut_inside_its_last_number_is_refused(tmp_path):
    # all seven fields there, the last one shorter than the rows above write it: read as
    # 5.1 where 5.123456 was written, without a word
    rows = "".join(",".join(f"{v:.6f}" for v in [i / RATE, 1, 2, 3, 4, 5, 6 + i / 7]) + "\n"
                   for i in range(30))
    path = tmp_path / "cut.csv"
    path.write_text(HEADER + rows[:-6])
    what = "row 31 ends in '10.1' where the rows above write 6 characters after the point"
    assert expect_error(path, what) == f"{path}: {what}: {CUT}"
    path.write_text(HEADER + rows.rstrip("\n"))  # whole, only its line break missing
    assert load_recording(path).n_samples == 30
    path.write_text(HEADER + rows + "0.3,1,2,3,4,5,NaN")  # a NaN sample, not a cut number
    assert load_recording(path).n_samples == 31


@pytest.mark.parametrize("end", ["\n", ""])
def test_csv_with_a_trailing_comma_on_every_row_is_read(tmp_path, end):
    # an export that ends every line with a comma, header too: read before the cut-row
    # check, then refused as "row 6 ends with a comma ... ends in the middle of its last row"
    lines = csv_text(good_rows()).splitlines()
    path = tmp_path / "trailing.csv"
    path.write_text("\n".join(line + "," for line in lines) + end)
    rec = load_recording(path)
    assert rec.n_samples == 5 and rec.rate == pytest.approx(RATE)
    np.testing.assert_array_equal(rec.sensors["t"].gyr[-1], [1, 2, 3])
    # one cut short (a field less than its header) is still a cut file
    path.write_text("\n".join(line + "," for line in lines)[:-2])
    expect_error(path, "row 6 has 7 of the header's 8 fields: the file ends in the middle")


def test_csv_nan_text_is_read_as_a_non_finite_number(tmp_path):
    rows = good_rows(100)
    rows[40][4] = "nan"  # one sample of a 100 Hz recording: a short gap, interpolated
    path = tmp_path / "nan.csv"
    path.write_text(csv_text(rows))
    rec = load_recording(path)
    assert any("1 non-finite sample" in w for w in rec.select(["t"]).warnings)
    rows = good_rows(5)
    rows[3][4] = "nan"  # one sample in five is too large a share to repair
    path.write_text(csv_text(rows))
    expect_error(path, "1 non-finite samples (NaN or Inf), 20.0% of 5", use=True)


def test_csv_header_only(tmp_path):
    path = tmp_path / "header.csv"
    path.write_text(HEADER + "\n")
    expect_error(path, "has a header but no data rows")


@pytest.mark.parametrize(
    "data",
    [
        b"\x89HDF\r\n\x1a\n",
        b"\x89HDF\r\n\x1a\n\x00\x01",
        b",,,\n,,",
        b'"',
        b"\xff\xfe\xfd",
        b"a\rb",
    ],
)
@pytest.mark.parametrize("suffix", [".csv", ".h5", ".bin"])
def test_odd_bytes_raise_input_error(tmp_path, data, suffix):
    path = tmp_path / f"odd{suffix}"
    path.write_bytes(data)
    with pytest.raises(InputError) as info:
        load_recording(path, rate=10)
    assert str(path) in str(info.value)
    assert "\n" not in str(info.value)


def test_path_object_and_string_are_equivalent(tmp_path):
    path = tmp_path / "rec.csv"
    save_recording(random_recording(), str(path))
    assert isinstance(path, Path)
    assert load_recording(str(path)).source == load_recording(path).source


def test_units_that_look_wrong_give_warnings_with_evidence(tmp_path):
    rng = np.random.default_rng(3)
    n = 200
    gyr_deg = np.degrees(rng.normal(0, 2.0, (n, 3)))  # deg/s values, declared rad/s
    acc_g = np.tile([0.0, 0.0, 1.0], (n, 1)) + rng.normal(0, 0.01, (n, 3))  # g, declared m/s^2
    rec = make_recording({"thigh": {"gyr": gyr_deg, "acc": acc_g}}, rate=100.0)
    text = " ".join(rec.warnings)
    assert "is it in deg/s" in text and "is it in g" in text
    fine = make_recording(
        {"thigh": {"gyr": gyr_deg, "acc": acc_g}}, rate=100.0,
        units={"thigh": {"gyr": "deg/s", "acc": "g"}},
    )
    assert fine.warnings == []


# ------------------------------------------------------------- issue 4: the case list
# Each case of "Bad input never crashes, never lies, never loses a file" has a test here
# (or, where noted, above); docs/errors.md lists the messages.


def sensor_pair(n=N, seed=0, names=("thigh", "shank")):
    rng = np.random.default_rng(seed)
    return {name: {"gyr": rng.normal(0, 2, (n, 3)), "acc": rng.normal(0, 9, (n, 3))}
            for name in names}


def test_missing_sensor_names_the_sensors_that_exist(tmp_path):
    path = write_h5(tmp_path / "s.h5", sensor_pair(names=("left_thigh", "left_shank", "pelvis")))
    rec = load_recording(path)
    with pytest.raises(InputError) as info:
        rec.sensor("left_knee")
    message = str(info.value)
    assert str(path) in message and "no sensor 'left_knee'" in message
    # files without creation order list their groups alphabetically
    assert "sensors in this file: left_shank, left_thigh, pelvis" in message
    with pytest.raises(InputError, match="did you mean 'left_thigh'"):
        rec.sensor("left_thihg")


@pytest.mark.parametrize(("present", "missing"), [("gyr", "acc"), ("acc", "gyr")])
def test_sensor_with_only_gyr_or_only_acc(tmp_path, present, missing):
    data = sensor_pair()
    del data["shank"][missing]
    path = write_h5(tmp_path / "half.h5", data)
    message = expect_error(path, f"sensor 'shank' has no '{missing}' data (only '{present}')")
    assert "needs both gyr and acc" in message


@pytest.mark.parametrize(
    ("shape", "phrase"),
    [
        ((N, 2), f"has shape ({N}, 2), expected (N, 3): one row per sample"),
        ((N,), f"has shape ({N},), expected (N, 3)"),
        ((N, 3, 1), f"has shape ({N}, 3, 1), expected (N, 3)"),
        ((3, N), f"has shape (3, {N}): looks transposed, expected (N, 3)"),
        ((N, 4), f"has shape ({N}, 4), expected (N, 3)"),
    ],
)
def test_wrong_shapes_are_named(tmp_path, shape, phrase):
    data = sensor_pair()
    data["shank"]["gyr"] = np.ones(shape)
    path = write_h5(tmp_path / "shape.h5", data)
    message = expect_error(path, phrase)
    assert "sensor 'shank' gyr" in message


@pytest.mark.parametrize("dtype", [np.complex128, np.bool_])
def test_complex_or_boolean_data_is_refused(tmp_path, dtype):
    data = sensor_pair()
    data["thigh"]["acc"] = np.ones((N, 3), dtype=dtype)
    expect_error(write_h5(tmp_path / "c.h5", data), "sensor 'thigh' acc is not real numbers")


def test_sensors_of_different_lengths(tmp_path):
    data = sensor_pair()
    data["shank"] = sensor_pair(n=N - 7)["shank"]
    message = expect_error(write_h5(tmp_path / "len.h5", data), "sensors have different lengths")
    assert f"thigh: {N}" in message and f"shank: {N - 7}" in message


def test_gyr_and_acc_of_different_lengths(tmp_path):
    data = sensor_pair()
    data["shank"]["acc"] = data["shank"]["acc"][:-1]
    expect_error(write_h5(tmp_path / "len.h5", data),
                 f"sensor 'shank' has {N} gyr samples but {N - 1} acc samples")


def test_hdf5_without_sample_rate_or_time(tmp_path):
    path = write_h5(tmp_path / "norate.h5", sensor_pair(), rate=None)
    message = expect_error(path, "no sample rate and no time stamps")
    assert "--rate" in message
    assert load_recording(path, rate=50).rate == 50.0  # the advice works


@pytest.mark.parametrize("bad", [0.0, -100.0, np.nan, np.inf, "fast"])
def test_bad_sample_rate_attribute(tmp_path, bad):
    path = write_h5(tmp_path / "rate.h5", sensor_pair(), rate=bad)
    phrase = "is not a number of Hz" if isinstance(bad, str) else "must be a positive number"
    expect_error(path, phrase)


@pytest.mark.parametrize("bad", [0, -1, float("nan"), float("inf")])
def test_bad_rate_argument(tmp_path, bad):
    path = tmp_path / "r.csv"
    path.write_text(csv_text([row[1:] for row in good_rows()], header=HEADER[5:]))
    expect_error(path, "sample rate must be a positive number of Hz", rate=bad)


@pytest.mark.parametrize(
    ("index", "value", "phrase"),
    [
        (50, 0.49, "it repeats a value at index 50 (t[49]=0.49 s, t[50]=0.49 s)"),
        (50, 0.40, "it goes backwards at index 50 (t[49]=0.49 s, t[50]=0.4 s)"),
        (0, 5.00, "it goes backwards at index 1"),
    ],
)
def test_time_not_strictly_increasing(tmp_path, index, value, phrase):
    time = np.arange(N) / RATE
    time[index] = value
    path = write_h5(tmp_path / "t.h5", sensor_pair(), rate=None, time=time)
    message = expect_error(path, "'time' is not strictly increasing")
    assert phrase in message
    assert "remove duplicated or out-of-order rows" in message


def test_time_with_nan(tmp_path):
    time = np.arange(N) / RATE
    time[7] = np.nan
    path = write_h5(tmp_path / "t.h5", sensor_pair(), rate=None, time=time)
    expect_error(path, "'time' contains NaN or Inf (first at index 7)")


def test_csv_with_duplicated_row(tmp_path):
    rows = good_rows(10)
    rows.insert(4, list(rows[3]))
    path = tmp_path / "dup.csv"
    path.write_text(csv_text(rows))
    expect_error(path, "it repeats a value at index 4")


def test_jitter_within_the_documented_tolerance_is_accepted(tmp_path):
    from imucal.timing import TIME_JITTER_TOLERANCE

    rng = np.random.default_rng(2)
    step = 1.0 / RATE
    # every interval within 0.9 of the tolerance of the nominal one
    dt = step * (1 + rng.uniform(-0.9, 0.9, N - 1) * TIME_JITTER_TOLERANCE / 2)
    time = np.concatenate([[0.0], np.cumsum(dt)])
    rec = load_recording(write_h5(tmp_path / "j.h5", sensor_pair(), rate=None, time=time))
    np.testing.assert_array_equal(rec.time, time)  # kept as recorded, not resampled
    assert rec.rate == pytest.approx(1.0 / np.median(dt))


@pytest.mark.parametrize("kind", ["dropped packets", "jitter"])
def test_irregular_sampling_is_refused_not_resampled(tmp_path, kind):
    time = np.arange(N) / RATE
    if kind == "dropped packets":
        time[120:] += 3 / RATE  # three samples missing after t = 1.19 s
        where = "the interval of 0.04 s after t=1.19 s"
    else:
        time[120] += 0.3 / RATE  # one stamp 30 % late
        where = "the interval of 0.013 s after t=1.19 s"
    path = write_h5(tmp_path / "irr.h5", sensor_pair(), rate=None, time=time)
    message = expect_error(path, "irregular sampling")
    assert where in message
    assert "by more than 10%" in message and "imucal does not resample" in message


@pytest.mark.parametrize(
    ("kwargs", "phrase"),
    [
        ({"gyr_units": "dps"}, "--gyr-units (gyr_units=): unknown units 'dps' (did you mean "
                               "'deg/s'?); use one of rad/s, deg/s"),
        ({"acc_units": "m/s2"}, "--acc-units (acc_units=): unknown units 'm/s2' (did you mean "
                                "'m/s^2'?)"),
        ({"acc_units": "G"}, "unknown units 'G' (did you mean 'g'?)"),
        ({"gyr_units": "rpm"}, "unknown units 'rpm'; use one of rad/s, deg/s"),
        # a scale, not a misspelt 'g': "did you mean 'g'?" made the data 1000 x too large
        ({"acc_units": "mg"}, "unknown units 'mg' (milli-g: convert the values to g first)"),
    ],
)
def test_unknown_unit_arguments(tmp_path, kwargs, phrase):
    path = tmp_path / "u.csv"
    path.write_text(csv_text(good_rows()))
    expect_error(path, phrase, **kwargs)


def test_unknown_units_attribute_suggests_the_spelling(tmp_path):
    path = write_h5(tmp_path / "u.h5", sensor_pair(), units={("shank", "acc"): "m/s²"})
    expect_error(path, "sensor 'shank' acc: unknown units 'm/s²' (did you mean 'm/s^2'?)")


def test_units_that_look_wrong_reach_the_loaded_recording(tmp_path):
    rng = np.random.default_rng(5)
    data = {"thigh": {"gyr": np.degrees(rng.normal(0, 3, (N, 3))),
                      "acc": np.tile([0.0, 0.0, 1.0], (N, 1)) + rng.normal(0, 0.05, (N, 3))}}
    rec = load_recording(write_h5(tmp_path / "u.h5", data))
    gyr_note, acc_note = rec.warnings
    peak = np.linalg.norm(data["thigh"]["gyr"], axis=1).max()
    median = np.median(np.linalg.norm(data["thigh"]["acc"], axis=1))
    assert f"peaks at {peak:.0f} rad/s (rad/s)" in gyr_note and "is it in deg/s?" in gyr_note
    assert f"median norm of {median:.2f} m/s^2" in acc_note and "is it in g?" in acc_note


# --------------------------------------------------------------------- NaN and Inf samples


def test_short_gaps_are_interpolated_with_a_warning(tmp_path):
    data = sensor_pair()
    gyr = data["shank"]["gyr"]
    expected = gyr.copy()
    gyr[50:53, 1] = np.nan  # 3 samples = 0.03 s, within MAX_INTERPOLATED_GAP_S
    gyr[120, :] = np.inf
    expected[50:53] = np.linspace(expected[49], expected[53], 5)[1:-1]
    expected[120] = (expected[119] + expected[121]) / 2
    loaded = load_recording(write_h5(tmp_path / "gaps.h5", data))
    assert loaded.warnings == [
        "sensor 'shank' gyr: 4 non-finite sample(s) (NaN or Inf) in 2 gap(s), the first at "
        "t=0.5 s, the longest 3 sample(s) (0.03 s) at t=0.5 s; estimates that use them "
        "interpolate them"]
    rec = loaded.select(["thigh", "shank"])
    assert rec.n_samples == N
    np.testing.assert_allclose(rec.sensors["shank"].gyr, expected, rtol=1e-12, atol=1e-12)
    np.testing.assert_array_equal(loaded.sensor("shank").gyr, rec.sensors["shank"].gyr)
    assert rec.warnings == [
        "sensor 'shank' gyr: 4 non-finite sample(s) (NaN or Inf) in 2 gap(s), the first at "
        "t=0.5 s, the longest 3 sample(s) (0.03 s), filled by linear interpolation"]
    # the loaded data and the caller's arrays are left as they were
    assert np.isnan(loaded.sensors["shank"].gyr[50:53, 1]).all()
    make_recording(data, rate=RATE).select(["shank"])
    assert np.isnan(data["shank"]["gyr"][50:53, 1]).all()


def test_non_finite_samples_at_the_ends_are_dropped_with_a_warning(tmp_path):
    data = sensor_pair()
    data["thigh"]["acc"][:4] = np.nan  # a sensor that started late
    data["shank"]["gyr"][-2:, 0] = -np.inf
    loaded = load_recording(write_h5(tmp_path / "ends.h5", data))
    assert loaded.n_samples == N  # only an estimate's sensors decide what it drops
    rec = loaded.select(["thigh", "shank"])
    assert rec.n_samples == N - 6
    np.testing.assert_allclose(rec.time, np.arange(4, N - 2) / RATE)
    np.testing.assert_array_equal(rec.sensors["shank"].gyr, data["shank"]["gyr"][4:-2])
    assert rec.warnings[0] == (
        "dropped 4 sample(s) at the start and 2 at the end of the recording, where sensor "
        "'thigh' acc, 'shank' gyr has non-finite values (NaN or Inf) up to the recording's "
        "start or end; the data used run from t=0.04 to 1.97 s"
    )
    assert loaded.select(["shank"]).n_samples == N - 2
    with pytest.raises(InputError, match="sensor 'thigh' has non-finite samples .* at the "
                                         r"start or end of the recording; Recording.select"):
        loaded.sensor("thigh")


def test_long_gap_is_refused(tmp_path):
    data = sensor_pair()
    data["thigh"]["gyr"][100:110] = np.nan  # 0.1 s
    message = expect_error(write_h5(tmp_path / "gap.h5", data),
                           "sensor 'thigh' gyr has a gap of 10 non-finite samples", use=True)
    assert "(NaN or Inf, 0.1 s) from t=1 s" in message
    assert "interpolates gaps of at most 0.05 s (5 samples)" in message


def test_too_many_short_gaps_are_refused(tmp_path):
    data = sensor_pair()
    data["shank"]["acc"][10:190:10, 2] = np.nan  # 18 single samples, 9 % of the signal
    expect_error(write_h5(tmp_path / "holes.h5", data),
                 "sensor 'shank' acc has 18 non-finite samples (NaN or Inf), 9.0% of 200 in "
                 "the recording, the first at t=0.1 s; imucal interpolates at most 5%",
                 use=True)


def test_sensor_with_no_finite_sample(tmp_path):
    data = sensor_pair()
    data["shank"]["acc"][:] = np.nan
    expect_error(write_h5(tmp_path / "dead.h5", data), "sensor 'shank' acc has no finite sample",
                 use=True)
    # finite readings of 1e30 are corrupt packets, read as missing: the message said "all
    # NaN or Inf" of a file without either (a fuzz review)
    data = sensor_pair()
    data["thigh"]["gyr"] = data["thigh"]["gyr"] * 1e30 + 1e30
    expect_error(write_h5(tmp_path / "huge.h5", data), "sensor 'thigh' gyr has no finite "
                 "sample (all NaN, Inf or beyond any body-worn sensor's range)", use=True)


def test_overflow_in_unit_conversion_is_non_finite_not_a_crash(tmp_path):
    data = sensor_pair()
    data["thigh"]["acc"][5:150] = 1e308  # times 9.80665 overflows to Inf
    path = write_h5(tmp_path / "big.h5", data, units={("thigh", "acc"): "g"})
    expect_error(path, "sensor 'thigh' acc has a gap of 145 non-finite samples", use=True)


# ---------------------------------------------------------- too short, never moves


def test_single_sample_recording(tmp_path):
    path = write_h5(tmp_path / "one.h5", sensor_pair(n=1))
    expect_error(path, "only 1 sample(s); a recording needs at least 2, and an estimate a few "
                       "seconds of motion")


@pytest.mark.parametrize("what", ["axis", "position"])
def test_too_short_to_estimate_says_how_long_is_needed(what):
    from imucal import estimate_axis, estimate_position

    rec = random_recording(n=12)
    thigh, shank = rec.sensor("thigh"), rec.sensor("shank")
    with pytest.raises(InputError, match=r"needs at least \d+ \(about [\d.]+ s of motion\)"):
        if what == "axis":
            estimate_axis(thigh.gyr, shank.gyr, rate=rec.rate, seed=1, restarts=3)
        else:
            estimate_position(thigh.gyr, thigh.acc, shank.gyr, shank.acc, rate=rec.rate,
                              seed=1, restarts=3)


def test_sensor_that_never_changes_is_flagged_at_load(tmp_path):
    data = sensor_pair()
    data["shank"]["gyr"] = np.zeros((N, 3))  # a dead gyroscope
    rec = load_recording(write_h5(tmp_path / "dead.h5", data))
    assert rec.warnings == [
        f"sensor 'shank' gyr never changes (all {N} samples are [0, 0, 0] rad/s): a dead or "
        "disconnected sensor? estimates that use it have nothing to go on"
    ]


def test_sensor_that_never_moves_gives_no_confident_estimate():
    from imucal import estimate_axis

    rec = random_recording(n=1000)
    rng = np.random.default_rng(1)
    still = rng.normal(0, 0.002, (1000, 3))  # gyro noise of a sensor lying on a table
    r = estimate_axis(rec.sensor("thigh").gyr, still, rate=rec.rate, seed=1, restarts=5)
    assert not r.confident and not r.identifiable
    assert any("barely rotate" in w for w in r.blocking)


# --------------------------------------------------------------------------- output files


def test_check_writable(tmp_path):
    from imucal.atomic import check_writable

    assert check_writable(tmp_path / "ok.json") == tmp_path / "ok.json"
    assert os.listdir(tmp_path) == []  # the probe leaves nothing behind
    with pytest.raises(InputError, match="folder '.*missing' does not exist"):
        check_writable(tmp_path / "missing" / "x.json")
    with pytest.raises(InputError, match="is a folder; give a file name"):
        check_writable(tmp_path)


def test_check_writable_read_only_folder_by_permission_bits(tmp_path, monkeypatch):
    from imucal import atomic

    monkeypatch.setattr(atomic.os, "access", lambda *args: False)
    with pytest.raises(InputError, match=r"x.json: folder '.*' is not writable "
                                         r"\(Permission denied\)$"):
        atomic.check_writable(tmp_path / "x.json")
    # a read-only mount says so (the message gave no reason: a new-user trial)
    ro = type("StatVfs", (), {"f_flag": atomic.os.ST_RDONLY})()
    monkeypatch.setattr(atomic.os, "statvfs", lambda folder: ro)
    with pytest.raises(InputError, match=r"is not writable \(Read-only file system\)$"):
        atomic.check_writable(tmp_path / "x.json")


def test_check_writable_read_only_folder_found_by_trying(tmp_path, monkeypatch):
    # Root ignores permission bits, and read-only mounts or ACLs can hide from them: the
    # probe file is what finds out.
    from imucal import atomic

    def refuse(*args, **kwargs):
        raise PermissionError(13, "Permission denied")

    monkeypatch.setattr(atomic.tempfile, "NamedTemporaryFile", refuse)
    with pytest.raises(InputError, match=r"is not writable \(Permission denied\)"):
        atomic.check_writable(tmp_path / "x.json")


@pytest.mark.parametrize("failure", [RuntimeError("plot crashed"), KeyboardInterrupt()])
def test_write_atomic_keeps_the_old_file(tmp_path, failure):
    from imucal.atomic import write_atomic

    target = tmp_path / "knee.json"
    target.write_text("old result")

    def write(tmp):
        tmp.write_text("half a res")
        raise failure

    with pytest.raises(type(failure)):
        write_atomic(target, write)
    assert target.read_text() == "old result"
    assert os.listdir(tmp_path) == ["knee.json"]


def test_write_text_atomic_replaces_and_keeps_permissions_usual(tmp_path):
    from imucal.atomic import write_text_atomic

    target = tmp_path / "knee.json"
    write_text_atomic(target, "first\n")
    write_text_atomic(target, "second\n")
    assert target.read_text() == "second\n"
    umask = os.umask(0)
    os.umask(umask)
    assert target.stat().st_mode & 0o777 == 0o666 & ~umask
    assert os.listdir(tmp_path) == ["knee.json"]


# ---------------------------------------------------------------------- the command line


def cli(*args, stdin: bytes | None = None):
    """Run the command line in-process (fast); returns click's Result."""
    from typer.testing import CliRunner

    from imucal.cli import app

    return CliRunner().invoke(app, [str(a) for a in args], input=stdin)


def assert_one_line_error(result, path_text: str, phrase: str, code: int = 2):
    assert result.exit_code == code, (result.exit_code, result.stderr)
    assert result.stdout == ""
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1, lines
    assert lines[0].startswith("imucal: error: ")
    assert path_text in lines[0] and phrase in lines[0]
    assert "Traceback" not in result.stderr


BAD_FILES = {
    "missing.h5": (None, "no such file"),
    "empty.h5": (b"", "file is empty"),
    "text.h5": (b"time,a\n0,1\n", "not an HDF5 file"),
    "junk.csv": (bytes(range(256)) * 8, "not a CSV file"),
    "corrupt.h5": (b"\x89HDF\r\n\x1a\n" + b"\x00" * 64, "corrupted or truncated HDF5"),
    "header.csv": (HEADER.encode(), "has a header but no data rows"),
    "typo.csv": (csv_text(good_rows(), header=HEADER.replace("t_acc_z", "t_acc_zz")).encode(),
                 "did you mean 't_acc_zz'"),
    "cell.csv": (csv_text(good_rows()).replace("0.02,1,2,3,4,5,6", "0.02,1,2,x,4,5,6").encode(),
                 "row 4, column 't_gyr_z': 'x' is not a number"),
}


@pytest.mark.parametrize("command", ["info", "axis", "position"])
@pytest.mark.parametrize("name", list(BAD_FILES))
def test_cli_bad_file_gives_one_line_and_exit_2(tmp_path, command, name):
    content, phrase = BAD_FILES[name]
    path = tmp_path / name
    if content is not None:
        path.write_bytes(content)
    assert_one_line_error(cli(command, path), str(path), phrase)


@pytest.mark.parametrize(
    ("setup", "args", "phrase"),
    [
        ("norate", [], "no sample rate and no time stamps"),
        # (a bad --rate or --gyr-units is a usage error, said before any file is read:
        # test_runner.py::test_usage_errors_before_any_file_is_read)
        ("good", ["--sensors", "thigh,knee"], "sensors in this file: shank, thigh"),
        ("gap", [], "gap of 10 non-finite samples"),
        ("difflen", [], "sensors have different lengths"),
    ],
)
def test_cli_bad_recording_gives_one_line_and_exit_2(tmp_path, setup, args, phrase):
    data = sensor_pair()
    rate = None if setup == "norate" else RATE
    if setup == "gap":
        data["thigh"]["gyr"][100:110] = np.nan
    if setup == "difflen":
        data["shank"] = sensor_pair(n=N - 1)["shank"]
    path = write_h5(tmp_path / f"{setup}.h5", data, rate=rate)
    assert_one_line_error(cli("axis", path, *args), str(path), phrase)


def test_cli_empty_stdin(tmp_path):
    assert_one_line_error(cli("axis", "-", stdin=b""), "<stdin>", "standard input is empty")


@pytest.mark.parametrize(
    ("target", "phrase"),
    [("missing-folder/knee.json", "folder '{tmp}/missing-folder' does not exist"),
     ("plain.txt/knee.json", "'{tmp}/plain.txt' is a file, not a folder")],
)
def test_cli_unwritable_out_fails_before_loading(tmp_path, monkeypatch, target, phrase):
    import imucal.loaders

    def must_not_load(*args, **kwargs):
        raise AssertionError("loaded the recording before checking the output path")

    monkeypatch.setattr(imucal.loaders, "load_recording", must_not_load)
    (tmp_path / "plain.txt").write_text("a file, not a folder")
    rec = write_h5(tmp_path / "rec.h5", sensor_pair())
    for option in ("--out", "--plot"):
        out = tmp_path / target.replace(".json", ".png" if option == "--plot" else ".json")
        assert_one_line_error(cli("axis", rec, option, out), str(out),
                              phrase.format(tmp=tmp_path))


def test_cli_read_only_out_folder_fails_before_loading(tmp_path, monkeypatch):
    import imucal.atomic
    import imucal.loaders

    monkeypatch.setattr(imucal.loaders, "load_recording", lambda *a, **k: 1 / 0)
    monkeypatch.setattr(imucal.atomic.os, "access", lambda *args: False)
    out = tmp_path / "knee.json"
    result = cli("position", write_h5(tmp_path / "rec.h5", sensor_pair()), "--out", out)
    assert_one_line_error(result, str(out), "is not writable")


def test_cli_failed_run_keeps_the_old_output(tmp_path):
    out = tmp_path / "knee.json"
    out.write_text("old result\n")
    rec = write_h5(tmp_path / "rec.h5", sensor_pair())
    result = cli("axis", rec, "--out", out, "--start", "100")  # fails after loading
    assert result.exit_code == 2 and "lies outside the recording" in result.stderr
    assert out.read_text() == "old result\n"
    assert sorted(os.listdir(tmp_path)) == ["knee.json", "rec.h5"]


def test_cli_sensor_that_never_moves(tmp_path):
    from conftest import simulated

    rec, _ = simulated(3, duration=8.0)
    data = {name: {"gyr": s.gyr, "acc": s.acc} for name, s in rec.sensors.items()}
    data["shank"]["gyr"] = np.zeros_like(data["shank"]["gyr"])
    path = write_h5(tmp_path / "dead.h5", data)
    result = cli("axis", path, "--restarts", "5", "--seed", "1")
    assert result.exit_code == 1, result.stderr  # the data cannot answer
    assert result.stdout == ""
    assert "sensor 'shank' gyr never changes" in result.stderr  # at load, naming the sensor
    assert "barely rotate" in result.stderr  # the estimate's reason
    assert result.stderr.strip().splitlines()[-1].startswith(
        f"imucal: error: {path}: the data cannot identify the axis")
    assert "Traceback" not in result.stderr


def test_cli_in_a_real_process_no_traceback_unless_debug(tmp_path):
    path = tmp_path / "empty.h5"
    path.write_bytes(b"")
    command = [sys.executable, "-m", "imucal", "axis", str(path)]
    run = subprocess.run(command, capture_output=True, timeout=120)
    assert run.returncode == 2 and run.stdout == b""
    assert run.stderr.decode() == f"imucal: error: {path}: file is empty\n"
    run = subprocess.run(command + ["--debug"], capture_output=True, timeout=120)
    # the traceback added, the status and the error line kept: Python's own status 1
    # read as "not identifiable" for any error (a new-user trial)
    assert run.returncode == 2 and run.stdout == b""
    assert b"Traceback" in run.stderr and b"InputError" in run.stderr
    assert run.stderr.decode().endswith(f"imucal: error: {path}: file is empty\n")


def test_errors_page_states_the_tolerances_the_code_uses():
    from imucal import sensor_checks, timing

    page = (Path(__file__).resolve().parents[1] / "docs" / "errors.md").read_text()
    assert f"| {timing.TIME_JITTER_TOLERANCE * 100:g} % (beyond: refused" in page
    assert f"| {sensor_checks.MAX_INTERPOLATED_GAP_S:g} s (5 samples at 100 Hz" in page
    assert f"| {sensor_checks.MAX_INTERPOLATED_FRACTION * 100:g} % |" in page
    assert f"above {sensor_checks.MAX_LIMB_RATE:g} rad/s" in page


def test_rate_within_tolerance_wins_and_rebuilds_the_time_axis():
    # circling_40hz.csv has a 'time' column at 40 Hz; --rate 41 used to be reported as
    # "800 samples at 41 Hz (19.5 s, t = 0 to 19.975 s)": the rate and the axis disagreed.
    path = Path(__file__).parent.parent / "sample_data" / "circling_40hz.csv"
    rec = load_recording(path, rate=41)
    assert rec.rate == 41.0
    assert rec.time[0] == 0.0
    assert rec.time[-1] == pytest.approx(799 / 41)
    assert any("41 Hz ('sample_rate' or --rate) and the 'time' steps (40 Hz) differ by "
               "2.44%" in w for w in rec.warnings)
    same = load_recording(path, rate=40)  # agrees: the file's time column is kept as it is
    assert same.time[-1] == 19.975
    assert not any("rebuilt" in w for w in same.warnings)


def test_a_time_column_a_crystal_off_is_rebuilt_without_a_warning(tmp_path):
    # 0.05 % drift over 20 s at 100 Hz is a whole sample: rebuilt, but no warning (a
    # warning made the sample data's axis "use with care" instead of "good")
    src = load_recording(Path(__file__).parent.parent / "sample_data" / "circling.h5")
    drift = replace(src, time=src.time * 1.0005)
    out = tmp_path / "drift.h5"
    save_recording(drift, out)
    rec = load_recording(out)
    assert rec.rate == src.rate and rec.time[-1] == pytest.approx(src.time[-1])
    assert not any("rebuilt" in w for w in rec.warnings)


def test_a_drifting_time_column_says_both_rates(tmp_path):
    # every step within the jitter tolerance, but 40 % of them 8 % long: `imucal info`
    # said "1000 samples at 100 Hz (10.0 s, t = 0 to 10.3092 s)" without a word, and the
    # estimators spaced the samples 3 % off the time column's average
    src = load_recording(Path(__file__).parent.parent / "sample_data" / "circling.h5")
    n = 1000
    step = np.where(np.arange(n - 1) < 600, 0.01, 0.0108)
    time = np.concatenate([[0.0], np.cumsum(step)])
    sensors = {k: {"gyr": s.gyr[:n], "acc": s.acc[:n]} for k, s in src.sensors.items()}
    rec = make_recording(sensors, time=time, source="drift.csv")
    assert rec.rate == pytest.approx(100.0)
    assert rec.rate_from == "the median step of 'time'"
    assert ("the 'time' steps drift: their median gives 100 Hz, their span (10.3092 s for "
            "1000 samples) 96.9037 Hz, 3.10% apart; the estimators use 100 Hz. If the "
            "samples are evenly spaced and only their stamps rounded (a 64 Hz sensor "
            "stamped in whole ms), pass the true rate with --rate; otherwise resample the "
            "recording to a constant rate") in rec.warnings
    # it concerns every estimate on the file, whichever sensors
    assert any("steps drift" in w for w in rec.select(["thigh", "shank"]).warnings)
    steady = make_recording(sensors, time=np.arange(n) * 0.01, source="steady.csv")
    assert not any("drift" in w for w in steady.warnings)


@pytest.mark.parametrize("offset", [96, 200])
def test_hdf5_with_a_damaged_object_header(tmp_path, offset):
    # 16 bytes zeroed in an object header: h5py raises RuntimeError ("bad object header
    # version number", "incorrect metadata checksum"), not OSError, while the vendor
    # formats sniffed the file: exit 3 before (an independent review)
    good = tmp_path / "good.h5"
    save_recording(random_recording(), good)
    data = bytearray(good.read_bytes())
    data[offset:offset + 16] = bytes(16)
    path = tmp_path / "damaged.h5"
    path.write_bytes(bytes(data))
    expect_error(path, "HDF5 file")


@pytest.mark.parametrize("kind", ["zip", "gzip"])
def test_an_archive_is_named_as_one(tmp_path, kind):
    # "not a CSV file (it contains binary data)" left the user to guess (a new-user trial)
    import gzip
    import zipfile

    text = (Path(__file__).parent.parent / "sample_data" / "circling_40hz.csv").read_bytes()
    path = tmp_path / ("c.csv.gz" if kind == "gzip" else "c.zip")
    if kind == "gzip":
        path.write_bytes(gzip.compress(text))
    else:
        with zipfile.ZipFile(path, "w", zipfile.ZIP_DEFLATED) as z:
            z.writestr("c.csv", text)
    with pytest.raises(InputError, match=f"binary data: a {kind} archive, unpack it first"):
        load_recording(path)


@pytest.mark.parametrize("name", ["time (s)", "timestamp", "Time_s"])
def test_a_time_column_under_another_name_is_named_when_no_rate_is_given(tmp_path, name):
    # "no sample rate and no time stamps" said nothing of the 'time (s)' column beside
    # it (a new-user trial); with --rate the column is only a note
    head = f"{name},s_gyr_x,s_gyr_y,s_gyr_z,s_acc_x,s_acc_y,s_acc_z\n"
    path = tmp_path / "t.csv"
    path.write_text(head + "".join(f"{k / 100},1,1,1,1,1,9\n" for k in range(50)))
    with pytest.raises(InputError, match=rf"no sample rate and no time stamps: column "
                                         rf"'{re.escape(name)}' is not read as time"):
        load_recording(path)
    assert load_recording(path, rate=100).n_samples == 50


def test_resolve_refuses_a_name_that_is_not_text():
    # rec.resolve(["thigh"]) raised TypeError from a dict lookup (a new-user trial)
    rec = load_recording(Path(__file__).parent.parent / "sample_data" / "walking.h5")
    with pytest.raises(InputError, match="a sensor name is text, got list"):
        rec.resolve(["thigh"])


def test_rad_per_s_declared_deg_per_s_is_doubted():
    # circling read so was refused as "the sensors barely rotate (1.6 and 2.2 deg/s)" with
    # no word of units, while the opposite mistake is named (a new-user trial)
    from imucal import load_recording, make_recording

    rec = load_recording(Path(__file__).resolve().parents[1] / "sample_data" / "circling.h5")
    data = {n: {"gyr": s.gyr, "acc": s.acc} for n, s in rec.sensors.items()}
    wrong = make_recording(data, rate=rec.rate, units={n: {"gyr": "deg/s"} for n in data})
    said = [w for w in wrong.warnings if "is the gyroscope in rad/s?" in w]
    assert any(w.startswith("sensor 'shank' gyr peaks at 3.6 deg/s (declared deg/s) while "
                            "its acc spans 6.6 m/s^2") for w in said)
    right = {n: {"gyr": np.degrees(s.gyr), "acc": s.acc} for n, s in rec.sensors.items()}
    fine = make_recording(right, rate=rec.rate, units={n: {"gyr": "deg/s"} for n in data})
    assert not [w for w in fine.warnings if "rad/s?" in w]
