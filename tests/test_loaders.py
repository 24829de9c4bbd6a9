"""Tests of imucal.loaders.load_recording and imucal.writers.save_recording."""

from __future__ import annotations

import io
import os
import sys
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


def expect_error(path, phrase, **kwargs):
    with pytest.raises(InputError) as info:
        load_recording(path, **kwargs)
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
    expect_error(path, "'sample_rate' says 50 Hz but 'time' says 100 Hz", rate=50)


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


def test_other_columns_are_ignored_with_a_warning(tmp_path):
    path = tmp_path / "extra.csv"
    header = HEADER.rstrip("\n") + ",temperature\n"
    path.write_text(csv_text([row + [21.5] for row in good_rows()], header=header))
    rec = load_recording(path)
    assert list(rec.sensors) == ["t"]
    assert any("temperature" in w for w in rec.warnings)


def test_read_csv_from_stdin(monkeypatch):
    data = csv_text(good_rows()).encode()
    monkeypatch.setattr(sys, "stdin", SimpleNamespace(buffer=io.BytesIO(data)))
    rec = load_recording("-")
    assert rec.source == "<stdin>"
    assert rec.n_samples == 5
    np.testing.assert_array_equal(rec.sensors["t"].acc[-1], [4, 5, 6])


def test_empty_stdin(monkeypatch):
    monkeypatch.setattr(sys, "stdin", SimpleNamespace(buffer=io.BytesIO(b"")))
    expect_error("-", "standard input is empty")


def test_utf8_bom_and_windows_line_endings(tmp_path):
    path = tmp_path / "bom.csv"
    path.write_bytes(b"\xef\xbb\xbf" + csv_text(good_rows()).replace("\n", "\r\n").encode())
    assert load_recording(path).n_samples == 5


# ---------------------------------------------------------------------------------- errors


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


def test_csv_blank_line_inside_data(tmp_path):
    path = tmp_path / "gap.csv"
    lines = csv_text(good_rows()).splitlines(keepends=True)
    path.write_text("".join(lines[:3] + ["\n"] + lines[3:]))
    expect_error(path, "row 4 is blank")


def test_csv_row_with_extra_fields(tmp_path):
    path = tmp_path / "long.csv"
    path.write_text(csv_text(good_rows()) + "0.05,1,2,3,4,5,6,7\n")
    expect_error(path, "not a valid CSV file")


def test_csv_nan_text_is_reported_as_non_finite(tmp_path):
    rows = good_rows()
    rows[3][4] = "nan"
    path = tmp_path / "nan.csv"
    path.write_text(csv_text(rows))
    expect_error(path, "non-finite")


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
