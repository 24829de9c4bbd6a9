"""Study-wide sensor maps (``--map FILE``, ``load_recording(names=...)``) and the commands
end to end on vendor exports: ``imucal axis``/``position`` on an Xsens and a DOT export
folder of a simulated recording give the truth as tightly as imucal's own HDF5, with and
without a map, alone and as a study with ``--jobs``.
"""

from __future__ import annotations

import json

import h5py
import numpy as np
import pytest
import vendor_writers as vw
from conftest import axis_error_deg, run_imucal, simulated

from imucal import load_recording
from imucal.errors import InputError
from imucal.sensor_map import apply_sensor_map, read_sensor_map
from imucal.writers import save_recording


def short():
    return simulated(3, rate=100.0, duration=5.0)[0]


def run_cli(*args):
    return run_imucal(*args, text=True)


# ------------------------------------------------------------------------- map files


def test_map_file_json_and_text(tmp_path):
    j = tmp_path / "map.json"
    j.write_text('{"00B4D7D3": "left_thigh", "Opal 1234": "left_shank"}')
    assert read_sensor_map(j) == {"00B4D7D3": "left_thigh", "Opal 1234": "left_shank"}
    t = tmp_path / "map.txt"
    t.write_text("# study 7\n\n00B4D7D3 = left_thigh\n  Opal 1234 =left_shank  # lower leg\n")
    assert read_sensor_map(t) == {"00B4D7D3": "left_thigh", "Opal 1234": "left_shank"}


@pytest.mark.parametrize("text, message", [
    ("00B4D7D3 left_thigh\n", r"line 1: expected KEY = NAME"),
    ("a = x\nA = y\n", r"line 2: 'A' is mapped twice, to 'x' \(line 1\) and to 'y'"),
    ('{"a": "x", "a": "y"}', r"'a' is mapped twice"),
    ('{"a": 3}', r"the name for 'a' must be text"),
    ('{"a": "x",}', r"invalid JSON at line 1"),
    ("a =\n", r"line 1: no name given for 'a'"),
    ("= x\n", r"line 1: the device name or serial is empty"),
    ("a = x,y\n", r"contains a comma"),
    # a NUL cut the name short in HDF5 and left convert's CSV unreadable as text
    ('{"a": "th\\u0000igh"}', r"the name 'th\\x00igh' contains a control character"),
    ('{"a": "th\\nigh"}', r"contains a control character \(a tab, a line break, NUL\)"),
    ("# nothing\n", r"the sensor map is empty"),
    ("[1, 2]", r"a sensor map in JSON is one object, .* not a list"),  # was "KEY = NAME"
])
def test_bad_map_files(tmp_path, text, message):
    path = tmp_path / "m.txt"
    path.write_text(text)
    with pytest.raises(InputError, match=rf"^{path}: .*{message}"):
        read_sensor_map(path)


def test_map_file_missing_folder_or_binary(tmp_path):
    with pytest.raises(InputError, match="no such file"):
        read_sensor_map(tmp_path / "none.json")
    with pytest.raises(InputError, match="this is a folder"):
        read_sensor_map(tmp_path)
    rec = tmp_path / "rec.h5"
    save_recording(short(), rec)
    with pytest.raises(InputError, match="binary data; is it a recording"):
        read_sensor_map(rec)


# ----------------------------------------------------------------------- applying it


def test_names_by_device_id_serial_and_label(tmp_path):
    rec = short()
    xsens = load_recording(vw.xsens(rec, tmp_path / "x"),
                           names={"00b4-2d4f": "left_thigh", "00B42D50": "left_shank"})
    assert list(xsens.sensors) == ["left_thigh", "left_shank", "00B42D51"]  # foot unmapped
    np.testing.assert_allclose(xsens.sensors["left_thigh"].gyr, rec.sensors["thigh"].gyr,
                               atol=1e-8)
    assert xsens.resolve("thigh") == "left_thigh"  # segment names reach the new names
    assert xsens.sensor_info["left_thigh"]["serial"] == "00B42D4F"
    assert xsens.sensor_info["left_thigh"]["name_in_file"] == "00B42D4F"
    assert xsens.provenance["serials"]["left_shank"] == "00B42D50"
    assert xsens.provenance["sensor_map"]["renamed"] == {"00B42D4F": "left_thigh",
                                                         "00B42D50": "left_shank"}
    # DOT: by device tag, or by serial (the MAC address) as the file gives it
    dot = load_recording(vw.dot(rec, tmp_path / "d"),
                         names={"THIGH": "knee_prox", "D4:22:CD:00:12:02": "knee_dist"})
    assert set(dot.sensors) == {"knee_prox", "knee_dist", "Foot"}
    # APDM: by label or case ID
    apdm = load_recording(vw.apdm(rec, tmp_path / "o.h5"),
                          names={"right_thigh": "T", "1235": "S", "Right Foot": "F"})
    assert list(apdm.sensors) == ["T", "S", "F"]


def test_own_layout_and_gaps_follow_the_new_names(tmp_path):
    path = tmp_path / "own.h5"
    save_recording(short(), path)
    loaded = load_recording(path, names={"Thigh": "oberschenkel"})
    assert list(loaded.sensors) == ["oberschenkel", "shank", "foot"]
    dropped = load_recording(vw.dot(short(), tmp_path / "d", drops={"shank": [40]}),
                             names={"shank": "s", "thigh": "t"})
    assert {g.sensor for g in dropped.gaps} == {"s"}
    # the loader's warnings too: they said 'Shank' beside a table of 's'
    assert len(dropped.warnings) == 3 and all(
        w.startswith("sensor 's' ('Shank' in the file)") for w in dropped.warnings)
    used = dropped.select(["t", "s"])  # the one dropped sample is bridged
    assert np.isfinite(used.sensors["s"].gyr).all()


def test_alternative_keys_for_a_study(tmp_path):
    """Keys mapped to one name are alternatives: one map serves every participant."""
    study = {"00B42D4F": "left_thigh", "00B4D7D3": "left_thigh",   # participants 1, 2
             "00B42D50": "left_shank", "00B4D7D4": "left_shank"}
    loaded = load_recording(vw.xsens(short(), tmp_path / "x"), names=study)
    assert list(loaded.sensors)[:2] == ["left_thigh", "left_shank"]


def test_unknown_key_names_the_map_and_the_sensors_present(tmp_path):
    folder = vw.dot(short(), tmp_path / "d")
    m = tmp_path / "study.json"
    m.write_text('{"Thigh": "left_thigh", "Shnak": "left_shank"}')
    with pytest.raises(InputError) as err:
        load_recording(folder, names=m)
    text = str(err.value)
    assert text.startswith(f"{m}: no sensor 'Shnak' (mapped to 'left_shank') in {folder}")
    assert "sensors there: 'Foot' (serial D4:22:CD:00:12:03), 'Shank' (serial" in text
    assert "\n" not in text
    with pytest.raises(InputError, match=r"sensor map \(names=\): no sensor 'hip'"):
        load_recording(folder, names={"hip": "left_hip"})


def test_conflicting_maps_refused(tmp_path):
    rec = load_recording(vw.xsens(short(), tmp_path / "x"))
    with pytest.raises(InputError, match="are all mapped to 'a' and are all in"):
        apply_sensor_map(rec, {"00B42D4F": "a", "00B42D50": "a"})
    with pytest.raises(InputError, match="'00b42d4f' is mapped twice, to 'a'"):
        apply_sensor_map(rec, {"00B42D4F": "a", "00b42d4f ": "b"})
    apdm = load_recording(vw.apdm(short(), tmp_path / "o.h5"))
    with pytest.raises(InputError, match="sensor 'Right Thigh' of .* is mapped twice: by "
                                         "'right thigh' to 'a' and by '1234' to 'b'"):
        apply_sensor_map(apdm, {"right thigh": "a", "1234": "b"})
    with pytest.raises(InputError, match="the name '00B42D51' is already a sensor"):
        apply_sensor_map(rec, {"00B42D4F": "00B42D51"})
    swapped = apply_sensor_map(rec, {"00B42D4F": "00B42D50", "00B42D50": "00B42D4F"})
    np.testing.assert_array_equal(swapped.sensors["00B42D50"].gyr, rec.sensors["00B42D4F"].gyr)


# ------------------------------------------------------------------- command line


@pytest.fixture(scope="module")
def study(tmp_path_factory):
    """One simulated recording written as imucal HDF5, an Xsens folder and a DOT folder;
    the own file's CLI results; and a study map covering both exports."""
    from imucal.simulate import simulate

    rec, truth = simulate(seed=7, rate=100, duration=20, snr=100, motion="circling")
    root = tmp_path_factory.mktemp("study")
    own = root / "own.h5"
    save_recording(rec, own)
    paths = {"xsens": vw.xsens(rec, root / "xsens"), "dot": vw.dot(rec, root / "dot")}
    m = root / "study.txt"
    m.write_text("# Xsens (participant 1)        \n"
                 "00B42D4F = left_thigh\n00B42D50 = left_shank\n00B42D51 = left_foot\n"
                 "# DOT (participant 2): device tags\n"
                 "Thigh = left_thigh\nShank = left_shank\nFoot = left_foot\n")
    ref = {c: cli_json(c, own, "--sensors", s)
           for c, s in (("axis", "thigh,shank"), ("position", "shank,foot"))}
    return rec, truth, paths, m, ref


AXIS = ("--seed", 1, "--restarts", 12, "-q")


def cli_json(command, path, *args):
    run = run_cli(command, path, *AXIS, *args)
    assert run.returncode == 0, run.stderr
    return json.loads(run.stdout)


def check_axis(doc, truth, ref):
    e1, e2 = axis_error_deg(doc["j1"], doc["j2"], ref["j1"], ref["j2"])
    assert max(e1, e2) < 0.01, (e1, e2)  # as from imucal's own HDF5
    t1, t2 = axis_error_deg(doc["j1"], doc["j2"], truth["j1"], truth["j2"])
    r1, r2 = axis_error_deg(ref["j1"], ref["j2"], truth["j1"], truth["j2"])
    assert max(t1, t2) < max(r1, r2) + 0.01 and max(t1, t2) < 0.5, (t1, t2, r1, r2)


def check_position(doc, truth, ref):
    for v in ("o1", "o2"):
        assert np.linalg.norm(np.subtract(doc[v], ref[v])) < 1e-4, v  # 0.1 mm
        err = np.linalg.norm(np.subtract(doc[v], truth[v]))
        assert err < np.linalg.norm(np.subtract(ref[v], truth[v])) + 1e-4 and err < 0.002


@pytest.mark.parametrize("fmt", ["xsens", "dot"])
def test_axis_and_position_on_vendor_folder(study, fmt):
    rec, truth, paths, _, ref = study
    first, second, third = {"xsens": vw.SERIALS, "dot": {"thigh": "thigh",
                                                         "shank": "lower leg",
                                                         "foot": "FOOT"}}[fmt].values()
    check_axis(cli_json("axis", paths[fmt], "--sensors", f"{first},{second}"),
               truth, ref["axis"])
    check_position(cli_json("position", paths[fmt], "--sensors", f"{second},{third}"),
                   truth, ref["position"])


@pytest.mark.parametrize("fmt", ["xsens", "dot"])
def test_axis_and_position_with_map(study, fmt):
    rec, truth, paths, m, ref = study
    doc = cli_json("axis", paths[fmt], "--map", m, "--sensors", "left_thigh,left_shank")
    check_axis(doc, truth, ref["axis"])
    assert doc["input"]["sensors"] == ["left_thigh", "left_shank"]
    in_file = {"xsens": "00B42D4F", "dot": "Thigh"}[fmt]
    assert doc["input"]["sensor_map"] == {
        "file": str(m), "sensors": {"left_thigh": in_file,
                                    "left_shank": {"xsens": "00B42D50", "dot": "Shank"}[fmt]}}
    # the default --sensors shank,foot finds the mapped names by segment
    check_position(cli_json("position", paths[fmt], "--map", m), truth, ref["position"])


def test_study_with_map_and_jobs(study, tmp_path):
    """Several recordings with --jobs: the map travels to every recording's run, and each
    line equals the single-file result."""
    rec, truth, paths, m, ref = study
    out = tmp_path / "knees.jsonl"
    run = run_cli("axis", paths["xsens"], paths["dot"], *AXIS, "--map", m,
                  "--sensors", "left_thigh,left_shank", "--jobs", 2, "--out", out)
    assert run.returncode == 0, run.stderr
    lines = [json.loads(line) for line in out.read_text().splitlines()]
    assert [line["exit_code"] for line in lines] == [0, 0]
    for line in lines:
        check_axis(line["result"], truth, ref["axis"])
    single = cli_json("axis", paths["dot"], "--map", m, "--sensors", "left_thigh,left_shank")
    assert lines[1]["result"]["j1"] == single["j1"]


def test_cli_map_errors(study, tmp_path):
    rec, truth, paths, m, ref = study
    bad = tmp_path / "typo.json"
    bad.write_text('{"00B42D4F": "left_thigh", "00B42D5O": "left_shank"}')
    run = run_cli("axis", paths["xsens"], "--map", bad, "--sensors", "left_thigh,left_shank")
    assert run.returncode == 2
    assert run.stderr.startswith(f"imucal: error: {bad}: no sensor '00B42D5O' (mapped to "
                                 f"'left_shank') in {paths['xsens']}; sensors there: "
                                 "'00B42D4F', '00B42D50', '00B42D51'")
    # in a study, a broken map file is one error before any recording is read
    broken = tmp_path / "broken.txt"
    broken.write_text("00B42D4F left_thigh\n")
    run = run_cli("position", paths["xsens"], paths["dot"], "--map", broken, "--jobs", 2)
    assert run.returncode == 2 and run.stdout == ""
    assert f"{broken}: line 1: expected KEY = NAME" in run.stderr
    # --out may not overwrite the map
    run = run_cli("axis", paths["xsens"], "--map", m, "--out", m, "--sensors",
                  "left_thigh,left_shank")
    assert run.returncode == 2 and "would overwrite" in run.stderr
    assert "left_thigh" in m.read_text()


def test_info_and_convert_with_map(study, tmp_path):
    rec, truth, paths, m, ref = study
    run = run_cli("info", paths["dot"], "--map", m, "--json")
    assert run.returncode == 0, run.stderr
    doc = json.loads(run.stdout)
    assert set(doc["sensors"]) == {"left_thigh", "left_shank", "left_foot"}
    assert doc["provenance"]["sensor_map"]["renamed"]["Thigh"] == "left_thigh"
    assert doc["sensor_info"]["left_thigh"]["serial"] == "D4:22:CD:00:12:01"
    out = tmp_path / "conv.h5"
    run = run_cli("convert", paths["xsens"], out, "--map", m, "-q")
    assert run.returncode == 0, run.stderr
    with h5py.File(out) as h5:
        assert {"left_thigh", "left_shank", "left_foot"} <= set(h5)
        assert json.loads(h5.attrs["sensor_map"])["file"] == str(m)
        assert json.loads(h5.attrs["serials"])["left_thigh"] == "00B42D4F"
    check_axis(cli_json("axis", out, "--sensors", "left_thigh,left_shank"), truth, ref["axis"])


def test_a_sensor_mapped_twice_names_the_files(tmp_path):
    # "'00B42D4F' (00B42D4F), '00B42D50' (00B42D50) are all mapped to 'thigh'": which
    # files to look at was left to the reader
    folder = vw.xsens(short(), tmp_path / "x")
    thigh, shank = (f"MT_012005D6_031-000_{d}.txt" for d in ("00B42D4F", "00B42D50"))
    clash = tmp_path / "clash.txt"
    clash.write_text("00B42D4F = thigh\n00B42D50 = thigh\n")
    run = run_cli("info", folder, "--map", clash)
    assert run.returncode == 2 and run.stdout == ""
    assert run.stderr.splitlines() == [
        f"imucal: error: {clash}: '00B42D4F' (sensor '00B42D4F' in {thigh}), '00B42D50' "
        f"(sensor '00B42D50' in {shank}) are all mapped to 'thigh' and are all in {folder}; "
        "map each sensor to its own name"]
    taken = tmp_path / "taken.txt"
    taken.write_text("00B42D4F = 00B42D50\n")
    run = run_cli("info", folder, "--map", taken)
    assert run.returncode == 2
    assert run.stderr.splitlines() == [
        f"imucal: error: {taken}: the name '00B42D50' is already a sensor of {folder} (in "
        f"{shank}) that the map leaves as it is; map that sensor too, or choose another name"]


@pytest.mark.parametrize("copy, expect", [
    # a second take of one device in the same folder
    ("MT_012005D6_031-001_00B42D4F.txt", "MT_012005D6_031-000_00B42D4F.txt and "
     "MT_012005D6_031-001_00B42D4F.txt are both"),
    # the same export as .txt and .csv: one base name
    ("MT_012005D6_031-000_00B42D4F.csv", "MT_012005D6_031-000_00B42D4F.csv and "
     "MT_012005D6_031-000_00B42D4F.txt are both"),
])
def test_two_files_of_one_sensor_are_named(tmp_path, copy, expect):
    # was "two sensors are called '00B42D4F'; rename one", naming no file
    folder = vw.xsens(short(), tmp_path / "x")
    text = (folder / "MT_012005D6_031-000_00B42D4F.txt").read_text()
    (folder / copy).write_text(text.replace("\t", ",") if copy.endswith(".csv") else text)
    run = run_cli("info", folder)
    assert run.returncode == 2 and run.stdout == ""
    assert run.stderr.splitlines() == [
        f"imucal: error: {folder}: {expect} read as sensor '00B42D4F'; a recording is one "
        "file per sensor: move the other take (or copy) out of the folder"]


def test_two_ximu3_devices_of_one_name_name_their_folders(tmp_path):
    # every x-IMU3 device file is called Inertial.csv: the folders tell them apart
    folder = vw.ximu3(short(), tmp_path / "s")
    (folder / "Foot 65577B4B (USB)").rename(folder / "Shank 65577B4C (USB)")
    with pytest.raises(InputError) as err:
        load_recording(folder)
    assert str(err.value) == (
        f"{folder}: Shank 65577B4A (USB)/Inertial.csv and Shank 65577B4C (USB)/Inertial.csv "
        "are both read as sensor 'Shank', devices 65577B4A, 65577B4C; give each device its "
        "own name (its file or folder name, or the name set on it)")


def test_loader_warnings_follow_a_new_name_with_an_apostrophe(tmp_path):
    # the names were matched as "sensor '[^']*'", which stops inside "Bob's shank"
    tags = {"thigh": "Thigh", "shank": "Bob's shank", "foot": "Foot"}
    dropped = load_recording(vw.dot(short(), tmp_path / "d", names=tags, drops={"shank": [40]}),
                             names={"Bob's shank": "s"})
    assert dropped.warnings and all(
        w.startswith("sensor 's' ('Bob's shank' in the file)") for w in dropped.warnings)


def test_a_renamed_sensor_s_notes_stay_out_of_another_pair_s_warnings(tmp_path):
    # the notes kept the file's names, so select's filter (by the new names) let the
    # foot's dropped packets into the knee's warnings
    dropped = load_recording(vw.dot(short(), tmp_path / "d", drops={"foot": [40]}),
                             names={"thigh": "t", "shank": "s", "foot": "f"})
    assert any(w.startswith("sensor 'f' ('Foot' in the file)") for w in dropped.warnings)
    knee = dropped.select(["t", "s"])
    assert not any("Foot" in w or "'f'" in w for w in knee.warnings), knee.warnings
    ankle = dropped.select(["s", "f"])
    assert any(w.startswith("sensor 'f' ('Foot' in the file)") for w in ankle.warnings)


def test_calibrate_with_map_names_the_devices_in_its_embedded_results(study, tmp_path):
    # calibrate built its own input block, without sensor_map (json.md promises it with
    # --map, and `imucal axis --map` has it)
    rec, truth, paths, m, ref = study
    out = tmp_path / "cal.json"
    run = run_imucal("calibrate", paths["dot"], "--map", m, "--restarts", "20", "--seed",
                     "1", "--joint", "left_knee=hinge:left_thigh,left_shank", "-o", out,
                     "--force", "-q")
    assert run.returncode == 0, run.stderr
    knee = json.loads(out.read_text())["joints"]["left_knee"]
    expected = {"file": str(m), "sensors": {"left_thigh": "Thigh", "left_shank": "Shank"}}
    assert knee["axis"]["input"]["sensor_map"] == expected
    assert knee["position"]["input"]["sensor_map"] == expected
