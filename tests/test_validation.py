"""Validate what is used (issue 10, item 3): only the sensors an estimate uses, inside its
window, can stop it; gap messages name the first gap and its time."""

from __future__ import annotations

import json
from pathlib import Path

import h5py
import numpy as np
import pytest
from conftest import run_imucal

import imucal
from imucal.errors import InputError
from imucal.simulate import simulate
from imucal.writers import save_recording

SAMPLE = Path(__file__).resolve().parents[1] / "sample_data" / "circling.h5"

RESTARTS = "5"


def imucal_cli(*args):
    return run_imucal(*args, text=True)


@pytest.fixture(scope="module")
def clean(tmp_path_factory):
    """20 s of simulated circling at 100 Hz: thigh, shank, foot."""
    recording, _ = simulate(seed=5, rate=100.0, duration=20.0, motion="circling")
    path = tmp_path_factory.mktemp("clean") / "clean.h5"
    save_recording(recording, path)
    return path


def damaged(clean, folder, name, holes, scale=None):
    """A copy of ``clean`` with NaN runs ``holes`` = [(sensor, kind, t_start, seconds)]."""
    path = folder / name
    path.write_bytes(clean.read_bytes())
    with h5py.File(path, "r+") as h5:
        rate = float(h5.attrs["sample_rate"])
        for sensor, kind, t, seconds in holes:
            data = h5[f"{sensor}/{kind}"][()]
            i = int(round(t * rate))
            data[i:i + int(round(seconds * rate))] = np.nan
            h5[f"{sensor}/{kind}"][...] = data
        for (sensor, kind), factor in (scale or {}).items():
            h5[f"{sensor}/{kind}"][...] = h5[f"{sensor}/{kind}"][()] * factor
    return path


def axis(path, *args):
    return imucal_cli("axis", path, "--seed", 1, "--restarts", RESTARTS, *args)


def test_a_gap_in_another_sensor_does_not_matter(clean, tmp_path):
    path = damaged(clean, tmp_path, "foot_gap.h5", [("foot", "gyr", 8.0, 0.5)])
    run = axis(path, "--sensors", "thigh,shank")
    assert run.returncode == 0, run.stderr
    assert "sensor 'foot'" not in run.stderr  # not even a warning: it is not used
    doc = json.loads(run.stdout)
    assert not any("'foot'" in w for w in doc["quality"]["warnings"])
    # ... and the same recording with the same seed gives the same answer as without the gap
    reference = json.loads(axis(clean, "--sensors", "thigh,shank").stdout)
    assert doc["j1"] == reference["j1"] and doc["j2"] == reference["j2"]
    # the sensor with the gap is refused where it is used
    run = imucal_cli("position", path, "--seed", 1, "--restarts", RESTARTS)
    assert run.returncode == 2
    assert "sensor 'foot' gyr has a gap of 50 non-finite samples" in run.stderr
    assert "from t=8 s" in run.stderr


def test_a_window_that_ends_before_the_gap_works(clean, tmp_path):
    path = damaged(clean, tmp_path, "late_gap.h5", [("shank", "gyr", 15.0, 0.5)])
    run = axis(path, "--end", 14)
    assert run.returncode == 0, run.stderr
    doc = json.loads(run.stdout)
    assert doc["input"]["window_s"] == [0.0, 14.0]
    assert doc["input"]["samples_total"] == 2000  # the recording, gap and all
    # and one that starts after it
    run = axis(path, "--start", 15.5)
    assert run.returncode == 0, run.stderr
    assert json.loads(run.stdout)["input"]["window_s"] == [15.5, 20.0]


def test_a_window_containing_a_long_gap_fails_naming_it(clean, tmp_path):
    path = damaged(clean, tmp_path, "gap.h5", [("shank", "gyr", 15.0, 0.5)])
    run = axis(path, "--end", 16)
    assert run.returncode == 2
    assert run.stdout == ""
    line, = run.stderr.splitlines()
    assert line.startswith(f"imucal: error: {path}: sensor 'shank' gyr has a gap of 50 "
                           "non-finite samples (NaN or Inf, 0.5 s) from t=15 s")
    # a window that starts inside the gap cannot use it either
    assert axis(path, "--start", 15.2).returncode == 2


def test_two_gaps_name_the_first(clean, tmp_path):
    # the later gap is in the first sensor and longer: still the earlier one is named
    path = damaged(clean, tmp_path, "two.h5", [("thigh", "acc", 16.0, 1.0),
                                               ("shank", "gyr", 12.0, 0.2),
                                               ("foot", "gyr", 3.0, 0.5)])
    run = imucal_cli("position", path, "--sensors", "thigh,shank", "--joint", "hinge",
                     "--seed", 1, "--restarts", RESTARTS)
    assert run.returncode == 2
    assert "sensor 'shank' gyr has a gap of 20 non-finite samples (NaN or Inf, 0.2 s) from " \
           "t=12 s" in run.stderr
    # two long gaps in one signal: the first, and how many there are
    path = damaged(clean, tmp_path, "twice.h5", [("shank", "gyr", 12.0, 0.2),
                                                 ("shank", "gyr", 5.0, 0.1)])
    with pytest.raises(InputError, match=r"gap of 10 non-finite samples \(NaN or Inf, 0.1 s\) "
                                         r"from t=5 s in the recording \(the first of 2 such"):
        imucal.load_recording(path).select(["thigh", "shank"])


def test_short_gaps_in_the_window_are_interpolated_with_a_warning(clean, tmp_path):
    path = damaged(clean, tmp_path, "short.h5", [("shank", "gyr", 6.0, 0.03),
                                                 ("shank", "gyr", 17.0, 0.5)])
    run = axis(path, "--start", 2, "--end", 10)
    assert run.returncode == 0, run.stderr
    assert "sensor 'shank' gyr: 3 non-finite sample(s) (NaN or Inf) in 1 gap(s), the first " \
           "at t=6 s" in run.stderr
    assert "t=17" not in run.stderr  # outside the window: not this estimate's business
    warnings = json.loads(run.stdout)["quality"]["warnings"]
    assert any(w.startswith("input: sensor 'shank' gyr: 3 non-finite") for w in warnings)


def test_a_corrupt_reading_is_treated_as_missing_and_named(clean, tmp_path):
    # one 1e30 sample (a corrupt packet) stopped every estimate with "no restart produced
    # a finite result", naming neither the sample nor the cause
    path = tmp_path / "spike.h5"
    path.write_bytes(clean.read_bytes())
    with h5py.File(path, "r+") as h5:
        gyr = h5["thigh/gyr"][()]
        gyr[1000, 1] = 1e30
        # beyond any sensor's range between ordinary readings (one of 1e3 rad/s made a
        # good axis "not identifiable"): missing too
        gyr[1200:1202, 2] = [1e3, -400.0]
        # large, but as a stretch of mrad/s read as rad/s gives it (the unit checks' case,
        # no spike): kept
        gyr[1500:1510] *= 1000.0
        h5["thigh/gyr"][...] = gyr
    rec = imucal.load_recording(path)
    assert np.isnan(rec.sensors["thigh"].gyr[1000]).all()
    assert np.isnan(rec.sensors["thigh"].gyr[1200:1202]).all()
    assert np.isfinite(rec.sensors["thigh"].gyr[1500:1510]).all()
    run = axis(path, "--end", 11)
    assert run.returncode == 0, run.stderr
    assert ("sensor 'thigh' gyr: 3 reading(s) beyond any body-worn sensor's range (70 rad/s), "
            "the first 1e+30 at t=10 s (sample 1000): not a physical reading") in run.stderr


def test_a_sensor_that_starts_late_does_not_shorten_the_others(clean, tmp_path):
    path = damaged(clean, tmp_path, "late.h5", [("foot", "acc", 0.0, 2.0)])
    run = axis(path)
    assert run.returncode == 0, run.stderr
    assert json.loads(run.stdout)["input"]["window_s"] == [0.0, 20.0]
    assert "dropped" not in run.stderr
    run = imucal_cli("position", path, "--seed", 1, "--restarts", RESTARTS)
    assert run.returncode == 0, run.stderr
    assert "dropped 200 sample(s) at the start and 0 at the end of the recording, where " \
           "sensor 'foot' acc has non-finite values" in run.stderr
    assert json.loads(run.stdout)["input"]["window_s"] == [2.0, 20.0]


def test_unit_doubts_about_other_sensors_stay_out_of_the_result(clean, tmp_path):
    path = damaged(clean, tmp_path, "deg.h5", [], scale={("foot", "gyr"): 180 / np.pi * 10})
    run = axis(path)
    assert run.returncode == 0, run.stderr
    assert "sensor 'foot'" not in run.stderr
    assert not any(w.startswith("input:") for w in json.loads(run.stdout)["quality"]["warnings"])
    info = imucal_cli("info", path)
    assert info.returncode == 0 and "sensor 'foot' gyr peaks at" in info.stdout


def test_info_reports_gaps_per_sensor(clean, tmp_path):
    path = damaged(clean, tmp_path, "info.h5", [("shank", "gyr", 15.0, 0.5),
                                                ("foot", "acc", 0.0, 20.0)])
    run = imucal_cli("info", path)
    assert run.returncode == 0, run.stderr
    assert "2000 samples" in run.stdout  # nothing dropped to describe the file
    assert "warning: sensor 'shank' gyr: 50 non-finite sample(s) (NaN or Inf) in 1 gap(s), " \
           "the first at t=15 s" in run.stdout
    assert "warning: sensor 'foot' acc has no finite sample" in run.stdout
    doc = json.loads(imucal_cli("info", path, "--json").stdout)
    assert doc["sensors"]["foot"]["motion"] == "no data"
    assert doc["sensors"]["shank"]["gyr_rms_deg_s"] > 0


def test_a_study_validates_each_file_for_what_it_uses(clean, tmp_path):
    other = damaged(clean, tmp_path, "other.h5", [("foot", "gyr", 8.0, 0.5)])
    used = damaged(clean, tmp_path, "used.h5", [("shank", "gyr", 8.0, 0.5)])
    run = imucal_cli("axis", clean, other, used, "--seed", 1, "--restarts", RESTARTS)
    lines = [json.loads(line) for line in run.stdout.splitlines()]
    assert [line["exit_code"] for line in lines] == [0, 0, 2]
    assert lines[1]["warnings"] == []
    assert "sensor 'shank' gyr has a gap of 50" in lines[2]["error"]
    assert "from t=8 s" in lines[2]["error"]
    assert run.returncode == 2


def test_library_users_get_the_same_checks(clean, tmp_path):
    path = damaged(clean, tmp_path, "lib.h5", [("shank", "gyr", 15.0, 0.5),
                                               ("foot", "gyr", 1.0, 0.5)])
    rec = imucal.load_recording(path)
    assert rec.n_samples == 2000 and len(rec.gaps) == 2
    thigh = rec.sensor("thigh")  # a clean sensor is there as it is
    with pytest.raises(InputError, match="sensor 'shank' gyr has a gap of 50 .* from t=15 s"):
        rec.sensor("shank")
    knee = rec.select(["thigh", "shank"], end=14)
    assert knee.n_samples == 1400 and list(knee.sensors) == ["thigh", "shank"]
    np.testing.assert_array_equal(knee.sensor("thigh").gyr, thigh.gyr[:1400])
    result = imucal.estimate_axis(knee.sensor("thigh").gyr, knee.sensor("shank").gyr,
                                  rate=knee.rate, seed=1, restarts=5)
    assert result.identifiable
    # with context, the finite samples around the window stay for the low-pass filter
    wide = rec.select(["thigh", "shank"], start=2, end=14, context=True)
    assert wide.n_samples == 1500 and wide.window == (200, 1400)


@pytest.mark.parametrize("suffix", [".h5", ".csv"])
def test_saving_a_recording_keeps_its_gaps(tmp_path, suffix):
    gyr = np.outer(np.arange(50.0), [1.0, 2.0, 3.0])
    gyr[10:12] = np.nan
    gyr[20, 1] = np.inf
    rec = imucal.make_recording({"a": {"gyr": gyr, "acc": np.ones((50, 3))}}, rate=100.0)
    save_recording(rec, tmp_path / f"gaps{suffix}")
    back = imucal.load_recording(tmp_path / f"gaps{suffix}")
    assert [(g.start, g.length) for g in back.gaps] == [(10, 2), (20, 1)]
    np.testing.assert_array_equal(back.sensors["a"].gyr, gyr)


def test_a_window_of_one_sample_says_so():
    # 99.99 s of a 100 s recording: "fewer than 2 samples are finite", though all were
    from imucal import make_recording

    z = np.zeros((1000, 3))
    rec = make_recording({"a": {"gyr": z, "acc": z}, "b": {"gyr": z, "acc": z}}, rate=100.0,
                         source="r.h5")
    with pytest.raises(InputError, match=r"r.h5: the window t=9.99 to 10 s holds 1 "
                                         r"sample\(s\); at least 2 are needed"):
        rec.select(["a", "b"], 9.99, None)
    # a start within the last sample period rounds to the end: an empty window, whose
    # description read the sample after the last (IndexError, exit 3; a docs review)
    for start, end in ((9.996, None), (9.997, 10.0), (5.0, 5.004)):
        with pytest.raises(InputError, match=r"holds 0 sample\(s\); at least 2 are needed"):
            rec.select(["a", "b"], start, end)
        with pytest.raises(InputError, match=r"holds 0 sample\(s\)"):
            rec.window_slice(start, end)


@pytest.mark.parametrize("command", ["axis", "position", "calibrate"])
def test_a_window_in_the_last_sample_period_is_refused_by_every_command(command):
    # calibrate failed each joint with it (exit 1) and named the whole recording's window
    run = run_imucal(command, SAMPLE, "--start", "19.995", "--restarts", 5)
    assert run.returncode == 2
    assert run.stderr.decode().strip() == (f"imucal: error: {SAMPLE}: the window t=20 to 20 s "
                                           "holds 0 sample(s); at least 2 are needed")


def test_a_cut_off_too_low_to_design_a_filter_is_named():
    # --cutoff 1e-9: numpy's LinAlgError from the filter's initial state, exit 3
    rec, _ = simulate(seed=1, duration=6.0)
    th, sh = rec.sensor("thigh"), rec.sensor("shank")
    with pytest.raises(InputError, match=r"cut-off 1e-09 Hz is too low to filter at 100 Hz "
                                         r"\(at least 0.0001 Hz; 0: no filter\)"):
        imucal.estimate_axis(th.gyr, sh.gyr, rate=100.0, cutoff=1e-9, restarts=2, seed=1)


def test_a_time_offset_that_leaves_no_samples_says_so():
    rec, _ = simulate(seed=1, duration=6.0)
    th, sh = rec.sensor("thigh"), rec.sensor("shank")
    with pytest.raises(InputError, match=r"only 0 samples left after window and the time "
                                         r"offset \(3 s: 3.01 s left out at each end\)"):
        imucal.estimate_axis(th.gyr, sh.gyr, rate=100.0, time_offset=3.0, restarts=2, seed=1)
