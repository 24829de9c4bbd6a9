"""`imucal calibrate` and `imucal angles` (issue 13), in-process: calibrate on the sample
calibration trial, measure the sample walking trial, studies, exit codes, usage errors."""

from __future__ import annotations

import io
import json
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from conftest import axis_error_deg, run_imucal

from imucal.simulate import simulate
from imucal.writers import save_recording

ROOT = Path(__file__).resolve().parents[1]
SAMPLE = ROOT / "sample_data"
FAST = ("--restarts", "20", "--seed", "1")


def cli(*args):
    """``imucal ARGS`` in this process, as the console script runs it."""
    return run_imucal(*args, text=True)


@pytest.fixture(scope="module")
def cal_file(tmp_path_factory):
    path = tmp_path_factory.mktemp("cal") / "cal.json"
    # the simulator's accelerometers are exact (the default widens circling centres)
    run = cli("calibrate", SAMPLE / "circling.h5", *FAST, "--acc-error", "0", "--out", path)
    assert run.returncode == 0, run.stderr
    assert run.stdout == ""
    return path, run


def test_calibrate_writes_every_joint_with_a_summary(cal_file):
    path, run = cal_file
    doc = json.loads(path.read_text())
    truth = json.loads((SAMPLE / "circling.truth.json").read_text())
    assert doc["format"] == "imucal-calibration" and doc["command"] == "calibrate"
    assert list(doc["joints"]) == ["knee", "ankle"]
    knee, ankle = doc["joints"]["knee"], doc["joints"]["ankle"]
    assert knee["verdict"] == "good" and ankle["verdict"] == "good"
    assert max(axis_error_deg(np.array(knee["j1"]), np.array(knee["j2"]),
                              truth["j1"], truth["j2"])) < 0.5
    for k in ("o1", "o2"):  # the ankle centre, within 5 mm
        assert np.linalg.norm(np.subtract(ankle[k], truth[k])) < 0.005
    assert doc["settings"]["seed"] == 1 and doc["settings"]["restarts"] == 20
    assert "knee (hinge, thigh -> shank): good" in run.stderr
    assert "ankle (spheroidal, shank -> foot): good" in run.stderr
    # the knee centre with its 1-sigma, as the ankle's (it had none: a new-user trial)
    line = next(x for x in run.stderr.splitlines() if "knee (hinge" in x)
    q = knee["position"]["quality"]
    assert line.endswith(f"(1-sigma {q['o1_uncertainty_mm']:.1f}/"
                         f"{q['o2_uncertainty_mm']:.1f} mm)")


def test_a_drawn_seed_is_recorded(tmp_path):
    run = cli("calibrate", SAMPLE / "circling.h5", "--restarts", "5", "--joint",
              "knee=hinge:thigh,shank", "-q")
    assert run.returncode == 0 and run.stderr == ""
    doc = json.loads(run.stdout)
    assert list(doc["joints"]) == ["knee"]
    assert isinstance(doc["settings"]["seed"], int)
    assert doc["joints"]["knee"]["axis"]["settings"]["seed"] == doc["settings"]["seed"]


def _sample_offset_and_rmse(flexion):
    truth = np.array(json.loads((SAMPLE / "walking.truth.json").read_text())
                     ["knee_flexion_deg"])
    err = np.asarray(flexion) - truth
    return float(err.mean()), float(np.sqrt(np.mean((err - err.mean()) ** 2))), err


def test_angles_of_the_sample_walk_as_csv_on_stdout(cal_file):
    path, _ = cal_file
    run = cli("angles", SAMPLE / "walking.h5", "--calibration", path)
    assert run.returncode == 0, run.stderr
    table = pd.read_csv(io.StringIO(run.stdout))
    assert list(table.columns) == ["time", "knee_flexion_deg", "knee_flexion_sigma_deg"]
    assert len(table) == 3000 and table["time"].iloc[1] == pytest.approx(0.01)
    offset, rmse, err = _sample_offset_and_rmse(table["knee_flexion_deg"])
    assert rmse < 1.0, rmse
    assert abs(err[-1000:].mean() - err[:1000].mean()) < 1.0  # no drift
    # walking swings the knee through 60 deg; the band is a fraction of a degree
    assert 50 < np.ptp(table["knee_flexion_deg"]) < 70
    assert 0 < table["knee_flexion_sigma_deg"].median() < 1.0
    # The zero is the calibration trial's most extended posture (no still period in it);
    # circling never straightens the knee, so walking reads lower by circling's 1st
    # percentile of flexion, whichever sign the calibration first guessed.
    _, circ = simulate(seed=7, rate=100.0, duration=20.0, snr=100.0, motion="circling")
    assert offset == pytest.approx(-np.percentile(circ["knee_flexion_deg"], 1), abs=2.0)
    assert "regular flexion cycles of 1." in run.stderr and "fit check: fits" in run.stderr


def test_options_of_studies_without_tables_say_the_recording_runs_here(cal_file, tmp_path):
    # -q hid the --scheduler warning, and --jobs was ignored without a word: a batch user
    # had no sign that neither the cluster nor the processes were used (a new-user trial)
    path, _ = cal_file
    for option, value in (("--scheduler", "tcp://127.0.0.1:1"), ("--jobs", "2")):
        out = tmp_path / f"{option[2:]}.csv"
        run = cli("angles", SAMPLE / "walking.h5", "-c", path, option, value, "-q", "--out",
                  out)
        assert run.returncode == 0 and out.exists()
        assert _without_level(run.stderr) == (f"imucal: warning: {option} {value} is for "
                                              "studies (--tables); this recording runs here\n")
    run = cli("angles", SAMPLE / "walking.h5", "-c", path, "-q", "--out", out)
    assert run.returncode == 0 and _without_level(run.stderr) == ""  # --jobs left: nothing


def _without_level(stderr: str) -> str:
    """``stderr`` without the warning every angle of the circling sample calibration
    gets: its zero is no straight knee (it has no still period)."""
    return "".join(line for line in stderr.splitlines(keepends=True)
                   if "0 deg is the calibration trial's most extended posture" not in line)


def test_a_recordings_own_clock_offset_on_the_command_line(cal_file):
    path, _ = cal_file
    # the sample walk's clocks are in sync: given as such it reads as before, and says so
    run = cli("angles", SAMPLE / "walking.h5", "-c", path, "--time-offset", "0")
    assert run.returncode == 0, run.stderr
    assert "clock offset +0.0 ms given for this recording" in run.stderr
    table = pd.read_csv(io.StringIO(run.stdout))
    assert _sample_offset_and_rmse(table["knee_flexion_deg"])[1] < 1.0
    # not searched: a usage error that says why, before any file is read
    run = cli("angles", SAMPLE / "no_such.h5", "-c", path, "--time-offset", "auto")
    assert run.returncode == 2 and run.stdout == ""
    assert "'--time-offset'" in run.stderr and "not searched here" in run.stderr


def test_angles_to_h5_with_a_figure(cal_file, tmp_path):
    path, _ = cal_file
    out, png = tmp_path / "knee.h5", tmp_path / "knee.png"
    run = cli("angles", SAMPLE / "walking.h5", "-c", path, "--out", out, "--plot", png,
              "--end", "10", "-q")
    assert run.returncode == 0, run.stderr
    assert run.stdout == "" and _without_level(run.stderr) == ""
    import h5py

    with h5py.File(out) as f:
        assert f["knee_flexion_deg"].shape == (1000,)
        doc = json.loads(f.attrs["imucal"])
        # the datasets said nothing of their units (CSV's column names and the JSON do)
        assert list(f) == ["time", "knee_flexion_deg", "knee_flexion_sigma_deg"]
        assert f["time"].attrs["units"] == "s"
        flexion, sigma = f["knee_flexion_deg"].attrs, f["knee_flexion_sigma_deg"].attrs
        assert flexion["units"] == "deg" and sigma["units"] == "deg"
        assert flexion["joint"] == "knee" and list(flexion["sensors"]) == ["thigh", "shank"]
        handed = "right" if doc["joints"]["knee"]["flexion_sign"] > 0 else "left"
        assert flexion["frame"] == (
            "rotation of sensor 'shank' relative to sensor 'thigh' about the calibration's "
            "hinge axis (j1 in the 'thigh' sensor frame, j2 in the 'shank' sensor frame); "
            f"flexion is the {handed}-handed rotation about it")
        assert sigma["description"] == "1-sigma of knee_flexion_deg per sample"
    assert doc["command"] == "angles" and doc["fits"] is True
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"



@pytest.mark.skipif(not Path("/dev/full").exists(), reason="needs /dev/full (Linux)")
def test_no_angles_figure_is_left_when_the_table_cannot_be_written(cal_file, tmp_path):
    import subprocess
    import sys

    path, _ = cal_file
    png = tmp_path / "knee.png"
    with open("/dev/full", "w") as full:  # the CSV goes to stdout, which cannot take it
        run = subprocess.run([sys.executable, "-m", "imucal", "angles", SAMPLE / "walking.h5",
                              "-c", path, "--plot", png, "--end", "10", "-q"],
                             stdout=full, stderr=subprocess.PIPE, text=True, timeout=300)
    assert run.returncode == 2, run.stderr
    assert "standard output: cannot write (No space left on device)" in run.stderr
    assert list(tmp_path.iterdir()) == []

def test_another_mounting_exits_1_with_the_evidence_unless_force(cal_file, tmp_path):
    path, _ = cal_file
    rec = tmp_path / "restrapped.h5"
    recording, _ = simulate(seed=8, mounting_seed=9, rate=100.0, duration=10.0,
                            motion="gait", gyr_noise=0.01, acc_noise=0.05)
    save_recording(recording, rec)
    out = tmp_path / "knee.csv"
    run = cli("angles", rec, "-c", path, "--out", out)
    assert run.returncode == 1
    assert "does not fit" in run.stderr and "hinge residual" in run.stderr
    assert "nothing written" in run.stderr and not out.exists()
    run = cli("angles", rec, "-c", path, "--out", out, "--force")
    assert run.returncode == 0 and "does not fit" in run.stderr
    assert list(pd.read_csv(out).columns)[1] == "knee_flexion_deg"
    # with --force the warnings are all there is: each names its recording (in a loop
    # over trials, "imucal: warning: knee: ..." did not say which)
    warned = [x for x in run.stderr.splitlines() if x.startswith("imucal: warning:")]
    assert warned and all(x.startswith(f"imucal: warning: {rec}: ") for x in warned)
    assert any(x.startswith(f"imucal: warning: {rec}: knee: the calibration does not fit")
               for x in warned)


@pytest.mark.parametrize(("content", "phrase"), [
    (None, "calibration file not found"),
    ("{", "not a calibration file (not readable as JSON"),
    # cut off mid-file: json's "(char 44)" was cut at 80 characters, "(char 4"
    ('{"format": "imucal-calibration", "joints": {', "(not readable as JSON: Expecting "
     "property name enclosed in double quotes at line 1, column 45)"),
    ('{"command": "axis"}', "an imucal 'axis' result"),
    # a RecursionError and a ValueError of json: exit 3 before (fuzz audit)
    ("[" * 100_000, "not a calibration file (not readable as JSON: maximum recursion"),
    ('{"format_version": ' + "9" * 5000 + "}", "not readable as JSON: Exceeds the limit"),
    # a calibrate study's output handed over whole: a bare JSON error before
    ('{"file": "a.h5", "exit_code": 0, "error": null, "warnings": [], "result": {}}\n' * 2,
     "it is a study's JSON Lines, one line per recording: pick one recording's, e.g. jq -c "
     "'select(.file == \"CAL.h5\") | .result' FILE > cal.json"),
    # one line of it, and a recording given as the calibration: "no format" and a codec's
    # complaint about byte 0x89 (a new-user trial)
    ('{"file": "a.h5", "exit_code": 0, "error": null, "warnings": [], "result": '
     '{"format": "imucal-calibration"}}\n',
     "it is one line of a calibrate study's JSON Lines: its result is the calibration, e.g. "
     "jq -c .result LINE > cal.json"),
    # (an axis study's line, or a failed one, holds no calibration: an independent review)
    ('{"file": "a.h5", "exit_code": 2, "error": "a.h5: no such file", "warnings": [], '
     '"result": null}\n', "it is one line of an imucal study's JSON Lines, and its result is "
     "no calibration"),
    (b"\x89HDF\r\n\x1a\n" + bytes(64), "not a calibration file (an HDF5 file: a recording? "
     "make the calibration from it with imucal calibrate)"),
])
def test_a_missing_or_broken_calibration_exits_2_naming_it(tmp_path, content, phrase):
    cal = tmp_path / "cal.json"
    if isinstance(content, bytes):
        cal.write_bytes(content)
    elif content is not None:
        cal.write_text(content)
    run = cli("angles", SAMPLE / "walking.h5", "-c", cal, "--out", tmp_path / "a.csv")
    assert run.returncode == 2
    lines = run.stderr.strip().splitlines()
    assert len(lines) == 1 and str(cal) in lines[0] and phrase in lines[0]
    assert lines[0].count("(") == lines[0].count(")")
    assert run.stdout == "" and sorted(p.name for p in tmp_path.iterdir()) == (
        [] if content is None else ["cal.json"])


@pytest.mark.parametrize(("args", "phrase"), [
    (["calibrate", "missing.h5", "--joint", "knee"], "'--joint'"),
    (["calibrate", "missing.h5", "--joint", "knee=saddle:thigh,shank"], "unknown joint type"),
    (["calibrate", "missing.h5", "--joint", "k=hinge:a,b", "--joint", "k=hinge:c,d"],
     "given twice"),
    (["calibrate", "missing.h5", "--time-offset", "soon"], "'--time-offset'"),
    (["calibrate", "missing.h5", "--start", "5", "--end", "2"], "'--end'"),
    (["angles", "missing.h5", "-c", "missing.json", "--reference", "soon"], "'--reference'"),
    (["angles", "missing.h5", "-c", "missing.json", "--flexion-sign", "up"],
     "'--flexion-sign'"),
    (["angles", "missing.h5", "-c", "missing.json", "--out", "a.json"], "table format"),
])
def test_usage_errors_exit_2_before_any_file_is_read(args, phrase):
    run = cli(*args)
    assert run.returncode == 2 and run.stdout == ""
    lines = run.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("imucal: error: ") and phrase in lines[0]
    assert "no such file" not in run.stderr and "not found" not in run.stderr


def test_calibrate_study_gives_json_lines_like_axis(tmp_path):
    missing = tmp_path / "missing.h5"
    run = cli("calibrate", SAMPLE / "circling.h5", missing, "--restarts", "5", "--seed", "1",
              "--joint", "knee=hinge:thigh,shank")
    assert run.returncode == 2
    lines = [json.loads(line) for line in run.stdout.splitlines()]
    assert [o["file"] for o in lines] == [str(SAMPLE / "circling.h5"), str(missing)]
    assert all(list(o) == ["file", "exit_code", "error", "warnings", "result"] for o in lines)
    assert [o["exit_code"] for o in lines] == [0, 2]
    # the default accelerometer error widens a circling knee centre
    assert lines[0]["result"]["joints"]["knee"]["verdict"] == "use with care"
    assert lines[0]["result"]["settings"]["acc_error_m_s2"] == 0.05
    assert lines[1]["result"] is None and "no such file" in lines[1]["error"]
    assert f"imucal: error: {missing}: no such file" in run.stderr


def test_a_joint_that_is_not_identifiable_is_written_marked_and_exits_1(tmp_path):
    rec, out = tmp_path / "still.h5", tmp_path / "cal.json"
    save_recording(simulate(seed=3, rate=100.0, duration=5.0, motion="static")[0], rec)
    run = cli("calibrate", rec, "--restarts", "5", "--seed", "1", "--out", out)
    assert run.returncode == 1
    assert "knee (not identifiable)" in run.stderr and "barely rotate" in run.stderr
    doc = json.loads(out.read_text())
    assert doc["joints"]["knee"]["verdict"] == "not identifiable"
    # angles refuse a knee the calibration could not identify, unless told
    run = cli("angles", rec, "-c", out)
    assert run.returncode == 1 and "not identifiable in the calibration" in run.stderr
    assert run.stdout == ""
    assert cli("calibrate", rec, "--restarts", "5", "--seed", "1", "--out", out,
               "--force", "-q").returncode == 0


def test_a_still_window_of_the_real_recording_names_file_and_joint(real_recording, tmp_path):
    # 0-2 s of the shared recording: the person stands still, the joint centres never
    # accelerate across the knee axes; calibrate marks the joints and still writes the
    # file (each joint with its own reason), angles refuse with file and joint (exit 1)
    from conftest import REAL_DATA

    out = tmp_path / "cal.json"
    run = cli("calibrate", REAL_DATA, "--restarts", "5", "--seed", "1", "--end", "2",
              "--joint", "lk=hinge:left_thigh,left_shank", "--out", out)
    assert run.returncode == 1, run.stderr
    assert "joint lk (not identifiable): axis: the sensors barely rotate" in run.stderr
    assert json.loads(out.read_text())["joints"]["lk"]["verdict"] == "not identifiable"
    good = tmp_path / "good.json"
    assert cli("calibrate", REAL_DATA, "--restarts", "5", "--seed", "1", "--end", "55",
               "--joint", "lk=hinge:left_thigh,left_shank", "--out", good, "--force",
               "-q").returncode == 0
    run = cli("angles", REAL_DATA, "-c", good, "--end", "2", "-o", tmp_path / "a.csv")
    assert run.returncode == 1
    assert f"{REAL_DATA}: joint 'lk': the joint centre's acceleration never lies" in run.stderr
    assert not (tmp_path / "a.csv").exists()


def test_a_sided_name_finds_an_unsided_sensor_and_results_name_the_file_s_sensor():
    # "left_thigh" finds a one-leg file's "thigh" (a calibration made with sided names
    # applies to such a file); the result names what was used, as the file does (it
    # named what was asked for, and found no units for it); one sensor twice is refused
    from imucal.errors import InputError
    from imucal.sensor_names import match_sensor

    assert match_sensor("left_thigh", ["thigh", "shank", "foot"]) == "thigh"
    run = cli("axis", SAMPLE / "circling.h5", *FAST, "--sensors", "right_thigh,left_shank")
    assert run.returncode == 0, run.stderr
    doc = json.loads(run.stdout)
    assert doc["input"]["sensors"] == ["thigh", "shank"]
    assert doc["input"]["units_in_file"]["thigh"] == {"gyr": "rad/s", "acc": "m/s^2"}
    run = cli("axis", SAMPLE / "circling.h5", *FAST, "--sensors", "thigh,left_thigh")
    assert run.returncode == 2
    assert "--sensors thigh,left_thigh both find sensor 'thigh'" in run.stderr
    with pytest.raises(InputError) as err:  # (it read "... are all a thigh")
        match_sensor("thigh", ["left_thigh", "right_thigh", "pelvis"])
    assert ("sensor 'thigh' is ambiguous: 'left_thigh' and 'right_thigh' each name a thigh; "
            "name one of them") in str(err.value)


def test_simulate_mounting_seed(tmp_path):
    rec = tmp_path / "walk.h5"
    run = cli("simulate", rec, "--seed", "8", "--mounting-seed", "7", "--motion", "gait",
              "--duration", "2", "-q")
    assert run.returncode == 0, run.stderr
    truth = json.loads(rec.with_name("walk.truth.json").read_text())
    sample = json.loads((SAMPLE / "circling.truth.json").read_text())
    assert truth["settings"]["mounting_seed"] == 7
    np.testing.assert_allclose(truth["j1"], sample["j1"], atol=1e-12)
    np.testing.assert_allclose(truth["o2"], sample["o2"], atol=1e-12)


def test_library_exports():
    import imucal
    from imucal import angles, calibration

    assert imucal.calibrate is calibration.calibrate
    assert imucal.load_calibration is calibration.load_calibration
    assert imucal.joint_angles is angles.joint_angles
    assert {"Calibration", "JointAngles", "calibrate", "joint_angles"} <= set(imucal.__all__)
    # docs/formats.md wrote imucal.writers.save_recording, an AttributeError after
    # `import imucal` (a submodule is no attribute until imported)
    from imucal import writers

    assert imucal.save_recording is writers.save_recording
    assert "save_recording" in imucal.__all__


def test_forced_angles_of_a_knee_marked_not_identifiable_say_so_in_the_summary(tmp_path):
    # the fit check line listed only numbers within their limits ("DOES NOT FIT (hinge
    # residual 0.112, limit 0.815; ...)"), never the reason: the calibration's verdict
    cal = tmp_path / "cal.json"
    assert cli("calibrate", SAMPLE / "circling.h5", "--restarts", "5", "--seed", "1",
               "--out", cal, "-q", "--force").returncode == 0
    doc = json.loads(cal.read_text())
    doc["joints"]["knee"]["verdict"] = "not identifiable"
    cal.write_text(json.dumps(doc))
    run = cli("angles", SAMPLE / "walking.h5", "-c", cal, "--force")
    assert run.returncode == 0 and run.stdout.startswith("time,")
    line = next(x for x in run.stderr.splitlines() if "fit check:" in x)
    assert line.strip().startswith(
        "fit check: DOES NOT FIT (not identifiable in the calibration; hinge residual")


def test_fit_check_numbers_stay_readable_and_apart(cal_file, tmp_path):
    # a limit equal to the residual to three decimals read "0.102 > 0.102", and a
    # hand-edited residual of 1e300 printed a 301-digit limit
    from imucal.angles import _beyond

    assert _beyond(0.10213, 0.10207, 3) == "0.10213 > 0.10207"
    assert _beyond(5.2, 4.1, 2, " deg") == "5.20 deg > 4.10 deg"
    assert _beyond(3e300, 2e300, 3) == "3e+300 > 2e+300"
    path, _ = cal_file
    doc = json.loads(path.read_text())
    doc["joints"]["knee"]["angle"]["hinge_residual"] = 1e300
    cal = tmp_path / "huge.json"
    cal.write_text(json.dumps(doc))
    run = cli("angles", SAMPLE / "walking.h5", "-c", cal, "--end", "10")
    line = next(x for x in run.stderr.splitlines() if "fit check:" in x)
    assert "limit 2e+300" in line and len(line) < 300


def test_calibrate_pins_the_knee_axis_signs_and_records_them(tmp_path):
    # `calibrate` had no --sign / --j2-sign: a lab that knows its mounting could pin the
    # relative sign for `imucal axis` but not for the calibration `angles` reads
    out = tmp_path / "cal.json"
    run = cli("calibrate", SAMPLE / "circling.h5", *FAST, "--sign", "+x", "--j2-sign", "-x",
              "--joint", "knee=hinge:thigh,shank", "-o", out, "-q", "--force")
    assert run.returncode == 0, run.stderr
    doc = json.loads(out.read_text())
    knee = doc["joints"]["knee"]
    assert knee["j1"][0] > 0 and knee["j2"][0] < 0  # as pinned
    assert doc["settings"]["sign"] == "+x" and doc["settings"]["j2_sign"] == "-x"
    assert knee["axis"]["settings"]["j2_sign"] == "-x"
    free = cli("calibrate", SAMPLE / "circling.h5", *FAST, "--joint",
               "knee=hinge:thigh,shank", "-q", "--force")
    auto = json.loads(free.stdout)["joints"]["knee"]
    # the data's own relative sign puts both x components on one side; the pin did not
    assert np.sign(auto["j1"][0]) == np.sign(auto["j2"][0])
    run = cli("calibrate", SAMPLE / "circling.h5", "--j2-sign", "q")
    assert run.returncode == 2 and "Invalid value for '--j2-sign'" in run.stderr


def test_angles_study_writes_one_table_per_recording_and_json_lines(cal_file, tmp_path):
    # a session's walks against one calibration: before, one command per walk
    path, _ = cal_file
    other = tmp_path / "walk_b.h5"
    other.write_bytes((SAMPLE / "walking.h5").read_bytes())
    restrapped = tmp_path / "restrapped.h5"
    recording, _ = simulate(seed=8, mounting_seed=9, rate=100.0, duration=10.0,
                            motion="gait", gyr_noise=0.01, acc_noise=0.05)
    save_recording(recording, restrapped)
    missing = tmp_path / "missing.h5"
    files = [SAMPLE / "walking.h5", other, restrapped, missing]
    tables = tmp_path / "knee"
    runs = [cli("angles", *files, "-c", path, "--tables", tables, "--jobs", jobs)
            for jobs in ("2", "1")]
    assert runs[0].stdout == runs[1].stdout and runs[0].returncode == 2
    lines = [json.loads(line) for line in runs[0].stdout.splitlines()]
    assert [o["file"] for o in lines] == [str(f) for f in files]
    assert [o["exit_code"] for o in lines] == [0, 0, 1, 2]
    assert all(list(o) == ["file", "exit_code", "error", "warnings", "result"] for o in lines)
    single = cli("angles", SAMPLE / "walking.h5", "-c", path, "-q")
    for o, name in zip(lines[:2], ("walking", "walk_b"), strict=True):
        assert o["result"]["command"] == "angles" and o["result"]["fits"] is True
        assert o["result"]["table"] == str(tables / f"{name}.csv")
        assert Path(o["result"]["table"]).read_text() == single.stdout
    # the walk of another mounting: no table, its reason in the line
    assert lines[2]["result"] is None and "does not fit" in lines[2]["error"]
    assert "no such file" in lines[3]["error"]
    assert sorted(p.name for p in tables.iterdir()) == ["walk_b.csv", "walking.csv"]
    forced = cli("angles", restrapped, "-c", path, "--tables", tables, "--force", "-q")
    assert forced.returncode == 0 and json.loads(forced.stdout)["result"]["fits"] is False
    assert (tables / "restrapped.csv").exists()


@pytest.mark.parametrize(("extra", "phrase"), [
    ([], "several RECs need --tables DIR"),
    (["--tables", "out", "--plot", "a.png"], "draws one recording"),
])
def test_angles_study_usage_errors(cal_file, extra, phrase):
    path, _ = cal_file
    run = cli("angles", SAMPLE / "walking.h5", SAMPLE / "circling.h5", "-c", path, *extra)
    assert run.returncode == 2 and run.stdout == "" and phrase in run.stderr


def test_angles_study_refuses_two_recordings_writing_one_table(cal_file, tmp_path):
    # one name in one folder: no folder tells them apart
    path, _ = cal_file
    twin = tmp_path / "walking.csv"
    assert cli("convert", SAMPLE / "walking.h5", twin).returncode == 0
    (tmp_path / "walking.h5").write_bytes((SAMPLE / "walking.h5").read_bytes())
    run = cli("angles", tmp_path / "walking.h5", twin, "-c", path, "--tables",
              tmp_path / "t")
    assert run.returncode == 2
    assert f"would both write {tmp_path / 't' / 'walking.csv'}" in run.stderr
    assert not (tmp_path / "t").exists()


def test_angles_study_names_tables_of_one_name_by_their_folders(cal_file, tmp_path,
                                                                 monkeypatch):
    # a lab's layout, one folder per subject: "would both write knee/walk.csv" (F7 of a
    # gait-lab trial); names that differ keep their own, folders are added only where
    # needed
    path, _ = cal_file
    for subject in ("s1", "s2"):
        (tmp_path / subject).mkdir()
        (tmp_path / subject / "walk.h5").write_bytes((SAMPLE / "walking.h5").read_bytes())
    (tmp_path / "s2" / "stairs.h5").write_bytes((SAMPLE / "walking.h5").read_bytes())
    monkeypatch.chdir(tmp_path)
    run = cli("angles", "s1/walk.h5", "s2/walk.h5", "s2/stairs.h5", "-c", path, "--tables",
              "knee", "-q")
    assert run.returncode == 0, run.stderr
    lines = [json.loads(line) for line in run.stdout.splitlines()]
    assert [o["result"]["table"] for o in lines] == ["knee/s1/walk.csv", "knee/s2/walk.csv",
                                                      "knee/stairs.csv"]
    assert (tmp_path / "knee" / "s1" / "walk.csv").read_bytes() == \
        (tmp_path / "knee" / "stairs.csv").read_bytes()


def test_a_calibrate_study_writes_each_recordings_calibration_file(tmp_path, monkeypatch):
    # a calibrate study's lines fed `angles` only through a jq step per subject (F7 of a
    # gait-lab trial): --calibrations writes each file as --out would
    for subject in ("s1", "s2"):
        (tmp_path / subject).mkdir()
        (tmp_path / subject / "cal.h5").write_bytes((SAMPLE / "circling.h5").read_bytes())
    monkeypatch.chdir(tmp_path)
    knee = ("--joint", "knee=hinge:thigh,shank", "--restarts", "5", "--seed", "1", "-q")
    run = cli("calibrate", "s1/cal.h5", "s2/cal.h5", "s3/cal.h5", *knee, "--calibrations",
              "cal")
    assert run.returncode == 2  # s3 does not exist: its line says so, and no file
    lines = [json.loads(line) for line in run.stdout.splitlines()]
    assert [o["exit_code"] for o in lines] == [0, 0, 2]
    assert [(o["result"] or {}).get("calibration_file") for o in lines] == [
        "cal/s1/cal.json", "cal/s2/cal.json", None]
    assert sorted(str(p.relative_to("cal")) for p in Path("cal").rglob("*.json")) == [
        "s1/cal.json", "s2/cal.json"]
    assert cli("calibrate", "s1/cal.h5", *knee, "--out", "one.json").returncode == 0
    assert Path("cal/s1/cal.json").read_bytes() == Path("one.json").read_bytes()
    written = json.loads(Path("cal/s2/cal.json").read_text())
    assert {**written, "calibration_file": "cal/s2/cal.json"} == lines[1]["result"]
    run = cli("angles", SAMPLE / "walking.h5", "-c", "cal/s2/cal.json", "--force", "-q")
    assert run.returncode == 0 and run.stdout.startswith("time,knee_flexion_deg")
    # one REC is a study too; a folder that is a file is refused before anything runs
    Path("taken").write_text("")
    run = cli("calibrate", "s1/cal.h5", *knee, "--calibrations", "taken")
    assert run.returncode == 2 and "taken: the calibrations folder is a file" in run.stderr
    run = cli("calibrate", "s1/cal.h5", *knee, "--calibrations", "one")
    assert run.returncode == 0 and Path("one/cal.json").exists()
    assert json.loads(run.stdout)["result"]["calibration_file"] == "one/cal.json"
    # a name's folder that is a file: found before anything runs (after fitting, a review)
    Path("two").mkdir()
    Path("two/s1").write_text("")
    run = cli("calibrate", "s1/cal.h5", "s2/cal.h5", *knee, "--calibrations", "two")
    assert run.returncode == 2 and run.stdout == ""
    assert "two/s1/cal.json: --calibrations cannot make its folder: two/s1 is a file" in \
        run.stderr


def test_angles_study_writes_its_lines_beside_its_tables(cal_file, tmp_path):
    # --out inside the --tables folder that the study makes: "folder 'tabs' does not
    # exist" (a new-user trial); a failing study's checks still make nothing
    path, _ = cal_file
    tables = tmp_path / "tabs"
    run = cli("angles", SAMPLE / "walking.h5", "-c", path, "--tables", tables, "--out",
              tables / "lines.jsonl", "-q")
    assert run.returncode == 0, run.stderr
    assert sorted(p.name for p in tables.iterdir()) == ["lines.jsonl", "walking.csv"]
    assert json.loads((tables / "lines.jsonl").read_text())["exit_code"] == 0
    other = tmp_path / "other"
    run = cli("angles", SAMPLE / "walking.h5", "-c", tmp_path / "none.json", "--tables",
              other, "--out", other / "lines.jsonl")
    assert run.returncode == 2 and not other.exists()


def test_a_utf16_calibration_file_is_read(cal_file, tmp_path):
    # Windows PowerShell's `>` writes UTF-16 (jq .result line > cal.json): it was "not
    # readable as JSON: 'utf-8' codec can't decode byte 0xff"
    path, _ = cal_file
    utf16 = tmp_path / "cal16.json"
    utf16.write_bytes(path.read_text().encode("utf-16"))
    runs = [cli("angles", SAMPLE / "walking.h5", "-c", c, "-q") for c in (path, utf16)]
    assert [r.returncode for r in runs] == [0, 0] and runs[0].stdout == runs[1].stdout


def test_angles_study_reads_a_broken_calibration_once(tmp_path):
    cal = tmp_path / "cal.json"
    cal.write_text("{")
    run = cli("angles", SAMPLE / "walking.h5", SAMPLE / "circling.h5", "-c", cal, "--tables",
              tmp_path / "t")
    assert run.returncode == 2 and run.stdout == ""
    lines = run.stderr.strip().splitlines()
    assert len(lines) == 1 and "not a calibration file" in lines[0]


def test_angles_study_never_writes_over_its_inputs(cal_file, tmp_path):
    # a new-user trial: --tables naming the recordings' own folder replaced each CSV
    # recording by its angle table, and --out cal.json the calibration; both exit 0
    path, _ = cal_file
    folder = tmp_path / "walks"
    folder.mkdir()
    rec = folder / "walk.csv"
    run = cli("convert", SAMPLE / "walking.h5", rec)
    assert run.returncode == 0, run.stderr
    before = rec.read_bytes()
    run = cli("angles", rec, SAMPLE / "walking.h5", "-c", path, "--tables", folder)
    assert run.returncode == 2 and "--tables names an input recording" in run.stderr
    assert rec.read_bytes() == before and run.stdout == ""
    calibration = path.read_bytes()
    run = cli("angles", rec, "-c", path, "--tables", tmp_path / "t", "--out", path)
    assert run.returncode == 2 and path.read_bytes() == calibration
    assert not (tmp_path / "t").exists()  # a usage error leaves no folder
    (tmp_path / "t").mkdir()
    run = cli("angles", rec, "-c", path, "--tables", tmp_path / "t", "--out",
              tmp_path / "t" / "walk.csv")
    assert run.returncode == 2 and "name the same file" in run.stderr
    assert list((tmp_path / "t").iterdir()) == []


def test_angles_study_from_python_and_a_folder_named_with_a_slash(cal_file, tmp_path):
    import os

    from imucal.runner import Job
    from imucal.settings import AnglesSettings
    from imucal.study import run_study

    path, _ = cal_file
    job = Job("angles", (), AnglesSettings(str(path), tables=str(tmp_path / "py" / "knee")))
    out = tmp_path / "lines.jsonl"
    status = run_study(job, [str(SAMPLE / "walking.h5")], out=out, quiet=True)
    line = json.loads(out.read_text())
    assert status == 0 and line["result"]["table"] == str(tmp_path / "py" / "knee" /
                                                          "walking.csv")
    run = cli("angles", SAMPLE / "walking.h5", "-c", path, "--tables",
              str(tmp_path / "cli") + os.sep, "-q")
    assert run.returncode == 0 and (tmp_path / "cli" / "walking.csv").exists()
    stdin = cli("angles", "-", "-c", path, "--tables", tmp_path / "s")
    assert stdin.returncode == 2 and "standard input" in stdin.stderr


def test_a_library_run_never_writes_a_table_over_its_recording_or_calibration(cal_file,
                                                                              tmp_path):
    # a review: runner.run with AnglesSettings(tables=...) wrote walk.csv's table over it
    from imucal.runner import Job, run
    from imucal.settings import AnglesSettings

    path, _ = cal_file
    rec = tmp_path / "walk.csv"
    assert cli("convert", SAMPLE / "walking.h5", rec).returncode == 0
    before = rec.read_bytes()
    outcome = run(Job("angles", (), AnglesSettings(str(path), tables=str(tmp_path))), str(rec))
    assert outcome.exit_code == 2 and "--tables names an input recording" in outcome.error
    assert rec.read_bytes() == before
    (tmp_path / "c").mkdir()
    named = tmp_path / "c" / "walking.csv"  # a calibration where walking.h5's table goes
    named.write_bytes(path.read_bytes())
    outcome = run(Job("angles", (), AnglesSettings(str(named), tables=str(tmp_path / "c"))),
                  str(SAMPLE / "walking.h5"))
    assert outcome.exit_code == 2 and "would overwrite the calibration" in outcome.error
    study = cli("angles", SAMPLE / "walking.h5", "-c", named, "--tables", tmp_path / "c")
    assert study.returncode == 2 and "would overwrite the calibration" in study.stderr
    assert named.read_bytes() == path.read_bytes()
    # a run that writes no table leaves no folder
    outcome = run(Job("angles", (), AnglesSettings(str(path), tables=str(tmp_path / "none"))),
                  str(tmp_path / "missing.h5"))
    assert outcome.exit_code == 2 and not (tmp_path / "none").exists()


def test_a_calibration_file_that_cannot_be_read_is_named(monkeypatch, tmp_path):
    # an open or read that failed left the study-lines hint nothing to read: an internal
    # error (UnboundLocalError) instead of the file's name and problem (/proc/self/mem)
    import imucal.calibration as calibration_module
    from imucal.errors import InputError

    path = tmp_path / "cal.json"
    path.write_text("{}")

    def unreadable(*args, **kwargs):
        raise OSError(5, "Input/output error")

    monkeypatch.setattr(calibration_module, "open", unreadable, raising=False)
    with pytest.raises(InputError, match=r"cal.json: not a calibration file \(not readable "
                                         r"as JSON: \[Errno 5\] Input/output error\)$"):
        calibration_module.load_calibration(path)


def test_a_missing_calibration_is_said_before_the_recording_is_read(tmp_path, monkeypatch):
    # the whole recording (an hour, say) was read before "calibration file not found";
    # a study checked it once up front (an independent review)
    import imucal.loaders

    def no_loading(*args, **kwargs):
        raise AssertionError("the recording was read")

    monkeypatch.setattr(imucal.loaders, "load_recording", no_loading)
    run = run_imucal("angles", "walk.h5", "-c", "missing.json", cwd=tmp_path, text=True)
    assert run.returncode == 2
    assert run.stderr == "imucal: error: missing.json: calibration file not found\n"


def test_calibrate_takes_the_knees_zero_from_a_standing_trial(tmp_path, monkeypatch):
    # a study of subjects' calibration trials, each with its own standing trial
    # ({folder}); one subject's missing stand is that subject's error line alone
    for subject in ("s1", "s2"):
        (tmp_path / subject).mkdir()
        (tmp_path / subject / "cal.h5").write_bytes((SAMPLE / "circling.h5").read_bytes())
    save_recording(simulate(seed=9, mounting_seed=7, duration=5.0, motion="static")[0],
                   tmp_path / "s1" / "static.h5")
    monkeypatch.chdir(tmp_path)
    knee = ("--joint", "knee=hinge:thigh,shank", "--restarts", "5", "--seed", "1", "-q")
    run = cli("calibrate", "s1/cal.h5", "s2/cal.h5", *knee, "--standing",
              "{folder}/static.h5")
    assert run.returncode == 2
    one, two = (json.loads(line) for line in run.stdout.splitlines())
    angle = one["result"]["joints"]["knee"]["angle"]
    assert (one["exit_code"], angle["zero_trial"], angle["zero_time_s"]) == (0, "s1/static.h5",
                                                                              0.0)
    assert two["error"] == "s2/static.h5: no such file (the standing trial)"
    # one subject's stand for every subject: walks 93-121 deg off, "fits" (a gait-lab
    # trial)
    run = cli("calibrate", "s1/cal.h5", "s2/cal.h5", *knee, "--standing", "s1/static.h5")
    assert run.returncode == 2 and run.stdout == ""
    assert "s1/static.h5 would be every REC's standing trial, and they lie in 2 folders" \
        in run.stderr
    run = cli("calibrate", "s1/cal.h5", *knee, "--standing", "s1/static.h5", "--out",
              "cal.json")
    assert run.returncode == 0, run.stderr
    assert json.loads(Path("cal.json").read_text())["joints"]["knee"] == \
        one["result"]["joints"]["knee"]
    run = cli("angles", SAMPLE / "walking.h5", "-c", "cal.json")
    assert run.returncode == 0 and "not a straight knee" not in run.stderr
    table = pd.read_csv(io.StringIO(run.stdout))
    truth = json.loads((SAMPLE / "walking.truth.json").read_text())["knee_flexion_deg"]
    # read from the standing posture (12.67 deg flexed in this static trial)
    assert np.mean(table["knee_flexion_deg"] - truth) == pytest.approx(-12.67, abs=0.15)
    # from Python, {folder} as on the command line (it read a file named '{folder}', a
    # review)
    import imucal
    from imucal.settings import CalibrateSettings

    cal = imucal.calibrate(imucal.load_recording("s1/cal.h5"), settings=CalibrateSettings(
        joints=("knee=hinge:thigh,shank",), restarts=5, seed=1,
        standing="{folder}/static.h5"))
    assert cal.joints["knee"].angle == one["result"]["joints"]["knee"]["angle"]
    # standard input has no name for a calibration file (it wrote '-.json', a review)
    run = run_imucal("calibrate", "-", *knee, "--calibrations", "c",
                     stdin=(tmp_path / "s1" / "cal.h5").read_bytes(), text=True)
    assert run.returncode == 2 and "--calibrations: each file is named after its " \
        "recording's, and - (standard input) has none" in run.stderr


def test_a_study_replaces_its_own_outputs_but_no_other_file(cal_file, tmp_path,
                                                            monkeypatch):
    # --tables session1 replaced the vendor's session1/walk.csv beside walk.h5 with the
    # walk's angle table, exit 0 (a new-user trial); an earlier run's table or
    # calibration file is replaced as before
    path, _ = cal_file
    monkeypatch.chdir(tmp_path)
    Path("walk.h5").write_bytes((SAMPLE / "walking.h5").read_bytes())
    assert cli("convert", "walk.h5", "walk.csv", "-q").returncode == 0
    recording = Path("walk.csv").read_bytes()
    run = cli("angles", "walk.h5", "-c", path, "--tables", ".", "-q")
    assert run.returncode == 2 and run.stdout == ""
    assert run.stderr == ("imucal: error: walk.csv: a file is there that is no angle table "
                          "of imucal (a recording?); --tables would overwrite it: give "
                          "another folder\n")
    assert Path("walk.csv").read_bytes() == recording
    for _ in range(2):
        assert cli("angles", "walk.h5", "-c", path, "--tables", "knee", "-q").returncode == 0
    knee = ("--joint", "knee=hinge:thigh,shank", "--restarts", "5", "--seed", "1", "-q")
    Path("cal.h5").write_bytes((SAMPLE / "circling.h5").read_bytes())
    for _ in range(2):
        assert cli("calibrate", "cal.h5", *knee, "--calibrations", "c").returncode == 0
    Path("c/cal.json").write_text('{"format": "imucal-axis"}')
    run = cli("calibrate", "cal.h5", *knee, "--calibrations", "c")
    assert run.returncode == 2 and "c/cal.json: a file is there that is no calibration " \
        "file of imucal" in run.stderr
    assert Path("c/cal.json").read_text() == '{"format": "imucal-axis"}'


def test_a_calibrate_study_keeps_another_recordings_calibration_file(tmp_path,
                                                                     monkeypatch):
    # one subject per run into one folder: each s*/cal.h5 is cal/cal.json, and subject
    # 2's silently replaced subject 1's (a review); a standing trial's loading warnings
    # reach the run, and --standing - serves one REC read from a file
    for subject in ("s1", "s2"):
        (tmp_path / subject).mkdir()
        (tmp_path / subject / "cal.h5").write_bytes((SAMPLE / "circling.h5").read_bytes())
    monkeypatch.chdir(tmp_path)
    knee = ("--joint", "knee=hinge:thigh,shank", "--restarts", "5", "--seed", "1", "-q")
    assert cli("calibrate", "s1/cal.h5", *knee, "--calibrations", "cal").returncode == 0
    assert cli("calibrate", "./s1/cal.h5", *knee, "--calibrations", "cal").returncode == 0
    run = cli("calibrate", "s2/cal.h5", *knee, "--calibrations", "cal")
    assert run.returncode == 2 and run.stdout == ""
    assert "cal/cal.json: holds the calibration of ./s1/cal.h5; --calibrations would " \
        "replace it with s2/cal.h5's" in run.stderr
    assert json.loads(Path("cal/cal.json").read_text())["input"]["path"] == "./s1/cal.h5"
    # the same recording from another folder is the same (refused as "holds the
    # calibration of s1/cal.h5", a review), and so is a file with a BOM or compact JSON
    monkeypatch.chdir(tmp_path / "s1")
    assert cli("calibrate", "cal.h5", *knee, "--calibrations", "../cal").returncode == 0
    monkeypatch.chdir(tmp_path)
    doc = json.loads(Path("cal/cal.json").read_text())
    Path("cal/cal.json").write_bytes(b"\xef\xbb\xbf" + json.dumps(doc).encode())
    assert cli("calibrate", "s1/cal.h5", *knee, "--calibrations", "cal").returncode == 0
    for recs in (("s1/cal.h5", "s2/cal.h5"), ("-",)):
        run = cli("calibrate", *recs, *knee, "--standing", "-")
        assert run.returncode == 2 and "'--standing': - (standard input) is one standing " \
            "trial for one REC read from a file" in run.stderr
    # a standing trial with a 3-sample gap in the shank's gyroscope
    import h5py

    save_recording(simulate(seed=9, mounting_seed=7, duration=5.0, motion="static")[0],
                   "stand.h5")
    with h5py.File("stand.h5", "r+") as h5:
        gyr = h5["shank"]["gyr"][...]
        gyr[100:103] = np.nan
        h5["shank"]["gyr"][...] = gyr
    run = cli("calibrate", "s1/cal.h5", *knee[:-1], "--standing", "stand.h5", "--out",
              "z.json")
    assert run.returncode == 0, run.stderr
    assert "imucal: warning: stand.h5 (the standing trial): sensor 'shank' gyr: 3 " \
        "non-finite sample(s)" in run.stderr


def test_a_quiet_study_leaves_the_warnings_to_its_lines(cal_file, tmp_path):
    # 150 recordings of a study printed one calibration's warning 150 times with -q,
    # though each line carries it (a new-user trial)
    path, _ = cal_file
    loud = cli("angles", SAMPLE / "walking.h5", "-c", path, "--tables", tmp_path / "a")
    quiet = cli("angles", SAMPLE / "walking.h5", "-c", path, "--tables", tmp_path / "b",
                "-q")
    assert loud.returncode == quiet.returncode == 0
    warnings = json.loads(quiet.stdout)["warnings"]
    assert warnings and warnings == json.loads(loud.stdout)["warnings"]
    assert quiet.stderr == ""
    assert all(f"imucal: warning: {w}" in loud.stderr for w in warnings)


def test_an_output_keeps_the_permissions_of_the_file_it_replaces(tmp_path):
    # a result set to 0600 by hand came back 0644, readable by all (a new-user trial)
    import os
    import stat

    out = tmp_path / "cal.json"
    out.write_text("{}")
    out.chmod(0o600)
    run = cli("calibrate", SAMPLE / "circling.h5", "--joint", "knee=hinge:thigh,shank",
              "--restarts", "5", "--seed", "1", "-q", "--out", out)
    assert run.returncode == 0 and json.loads(out.read_text())["command"] == "calibrate"
    assert stat.S_IMODE(os.stat(out).st_mode) == 0o600
