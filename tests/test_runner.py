"""The headless runner (imucal.runner) and the usage errors the command line reports
before any file is read."""

from __future__ import annotations

import dataclasses
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from conftest import axis_error_deg, run_imucal, simulated

from imucal.errors import InputError
from imucal.runner import COMMANDS, Command, Job, Outcome, parse_sensors, run
from imucal.settings import AxisSettings, PositionSettings
from imucal.writers import save_recording


def imucal(*args, cwd=None):
    return subprocess.run([sys.executable, "-m", "imucal", *map(str, args)],
                          capture_output=True, timeout=120, cwd=cwd)


@pytest.fixture(scope="module")
def rec_file(tmp_path_factory):
    recording, truth = simulated(3, duration=8.0)
    path = tmp_path_factory.mktemp("runner") / "rec.h5"
    save_recording(recording, path)
    return path, truth


def test_run_returns_the_document_and_the_result(rec_file):
    path, truth = rec_file
    outcome = run(Job("axis", ("thigh", "shank"), AxisSettings(restarts=8, seed=1)), str(path))
    assert (outcome.exit_code, outcome.error, outcome.warnings) == (0, None, [])
    doc = outcome.document
    assert doc["command"] == "axis" and doc["input"]["sensors"] == ["thigh", "shank"]
    assert doc["j1"] == list(outcome.result.j1)
    assert max(axis_error_deg(outcome.result.j1, outcome.result.j2, truth["j1"],
                              truth["j2"])) < 1.0
    assert outcome.headline == (f"imucal axis: {path}: thigh -> shank, 800 samples at 100 Hz "
                                "(8.0 s)")


def test_run_turns_failures_into_outcomes(rec_file, tmp_path):
    path, _ = rec_file
    job = Job("position", ("shank", "foot"), PositionSettings(restarts=4, seed=1))
    missing = run(job, str(tmp_path / "missing.h5"))
    assert missing.exit_code == 2 and missing.error.endswith("missing.h5: no such file")
    assert missing.document is None and missing.headline is None
    no_sensor = run(Job("axis", ("thigh", "knee"), AxisSettings(restarts=4)), str(path))
    assert no_sensor.exit_code == 2 and "no sensor 'knee'" in no_sensor.error


def test_not_identifiable_unless_forced(tmp_path):
    recording, _ = simulated(4, duration=8.0, motion="static")
    path = tmp_path / "still.h5"
    save_recording(recording, path)
    job = Job("axis", ("thigh", "shank"), AxisSettings(restarts=4, seed=1))
    refused = run(job, str(path))
    assert refused.exit_code == 1 and "cannot identify the axis" in refused.error
    # no further warnings: without motion they said nothing, and read first they sent a
    # user checking the synchronisation (a new-user trial)
    assert refused.document is None and refused.notes == []
    forced = run(Job("axis", ("thigh", "shank"), AxisSettings(restarts=4, seed=1), force=True),
                 str(path))
    assert forced.exit_code == 0
    assert forced.document["quality"]["verdict"] == "not identifiable"


def test_a_refusal_names_a_contradicted_given_clock_offset():
    # circling with its shank read 500 ms early: the first reason blamed the joint ("a
    # spheroidal joint such as the ankle?"); the offset given stood in a warning only
    job = Job("axis", ("thigh", "shank"), AxisSettings(seed=1, time_offset=-0.5))
    outcome = run(job, str(Path(__file__).parents[1] / "sample_data" / "circling.h5"))
    assert outcome.exit_code == 1
    # ... and then came second, in a parenthesis at the line's end (a new-user trial)
    assert ("the data cannot identify the axis: the clock offset given (-500.0 ms) is not "
            "the data's") in outcome.error
    assert "; with it, restarts disagree" in outcome.error


def test_job_and_sensor_checks():
    assert parse_sensors(" shank , foot") == ("shank", "foot")
    for bad in ("thigh", "thigh,thigh", "a,b,c", ",b"):
        with pytest.raises(Exception, match="two different sensor names"):
            parse_sensors(bad)
    with pytest.raises(Exception, match="--end must be after --start"):
        Job("axis", ("a", "b"), AxisSettings(), start=5.0, end=5.0)
    with pytest.raises(Exception, match="unknown command"):
        Job("knee", ("a", "b"), AxisSettings())
    # a library caller's mix-up ran into "internal error ... report it" (exit 3)
    with pytest.raises(InputError, match="a position job takes PositionSettings, got "
                                         "AxisSettings"):
        Job("position", ("shank", "foot"), AxisSettings())
    with pytest.raises(InputError, match=r"an axis job takes two sensors, got \('thigh',\)"):
        Job("axis", ("thigh",), AxisSettings())
    from imucal.settings import AnglesSettings, CalibrateSettings

    with pytest.raises(InputError, match="an angles job takes AnglesSettings, got "
                                         "CalibrateSettings"):
        Job("angles", (), CalibrateSettings())
    with pytest.raises(InputError, match=r"an angles job takes no sensors \(its joints are in "
                                         r"the calibration\), got \('thigh', 'shank'\)"):
        Job("angles", ("thigh", "shank"), AnglesSettings("cal.json"))
    assert set(COMMANDS) == {"axis", "position", "calibrate", "angles"}


def test_no_module_imports_the_command_line():
    code = ("import sys, imucal.runner, imucal.study, imucal.cluster, imucal.report, "
            "imucal.plots; print('imucal.cli' in sys.modules)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, timeout=60)
    assert out.stdout.strip() == b"False"


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["axis", "--sign", "bogus"], "Invalid value for '--sign': sign must be one of"),
        (["axis", "--j2-sign", "q"], "Invalid value for '--j2-sign': j2_sign must be one of"),
        (["axis", "--time-offset", "soon"],
         "Invalid value for '--time-offset': time offset must be auto or a number"),
        (["position", "--joint", "knee"], "Invalid value for '--joint': joint must be one of"),
        # a spheroidal joint has no axis to sign: the options were ignored silently
        (["position", "--sign", "+x"],
         "Invalid value for '--sign': sign applies to the axis of joint hinge only"),
        (["position", "--j2-sign", "-z"],
         "Invalid value for '--j2-sign': j2_sign applies to the axis of joint hinge only"),
        (["position", "--acc-error", "-0.1"],
         "Invalid value for '--acc-error': acc_error must be in [0, 5], got -0.1"),
        (["axis", "--offset-search", "0"],
         "Invalid value for '--offset-search': offset_search must be in (0, 10], got 0"),
        (["calibrate", "--offset-search", "20"],
         "Invalid value for '--offset-search': offset_search must be in (0, 10], got 20"),
        (["calibrate", "--acc-error", "50"],
         "Invalid value for '--acc-error': acc_error must be in [0, 5], got 50"),
        # the axis (eq. 1) uses no accelerometer error: accepted and ignored before
        (["axis", "--acc-error", "50"], "No such option: --acc-error"),
        (["axis", "--sensors", "thigh"], "Invalid value for '--sensors': needs two different"),
        (["axis", "--start", "8", "--end", "2"],
         "Invalid value for '--end': must be after --start (8 s), got 2 s"),
        # an unset "$MAP": typer made '' the folder '.', "--map needs a file, this is a
        # folder"
        (["axis", "--map", ""], "Invalid value for '--map': '': empty file name"),
        (["angles", "-c", ""], "Invalid value for '--calibration' / '-c': '': empty file name"),
        # typer's own bound read NaN as "Input should be greater than or equal to 0"
        (["axis", "--cutoff", "nan"],
         "Invalid value for '--cutoff': cutoff must be a finite number, got nan"),
        (["position", "--cutoff", "-1"],
         "Invalid value for '--cutoff': cutoff must be in [0, inf), got -1"),
        # the loading options and the window's numbers were checked as each file loaded,
        # blamed on the file, once per recording of a study (an independent review)
        (["axis", "--rate", "0"],
         "Invalid value for '--rate': sample rate must be a positive number of Hz, got 0"),
        (["calibrate", "--rate", "nan"],
         "Invalid value for '--rate': sample rate must be a positive number of Hz, got nan"),
        (["axis", "--gyr-units", "dps"],
         "Invalid value for '--gyr-units': unknown units 'dps' (did you mean 'deg/s'?)"),
        (["position", "--gyr-units", "furlong"],
         "Invalid value for '--gyr-units': unknown units 'furlong'"),
        (["angles", "-c", "cal.json", "--acc-units", "g2"],
         "Invalid value for '--acc-units': unknown units 'g2' (did you mean 'g'?)"),
        (["axis", "--start", "nan"],
         "Invalid value for '--start': must be a finite number of seconds"),
        (["calibrate", "--end", "inf"],
         "Invalid value for '--end': must be a finite number of seconds"),
    ],
)
def test_usage_errors_before_any_file_is_read(tmp_path, args, message):
    # The files do not exist: a usage error must not get as far as opening them, and
    # a study reports it once, not once per recording.
    for files in (["gone.h5"], ["gone.h5", "gone2.h5"]):
        run_ = imucal(args[0], *files, *args[1:], cwd=tmp_path)
        err = run_.stderr.decode()
        assert run_.returncode == 2 and run_.stdout == b""
        assert err.startswith(f"imucal: error: {message}") and err.count("\n") == 1
        assert "gone" not in err and f"imucal {args[0]} --help" in err


def test_position_figure_uses_a_given_axis(monkeypatch):
    from imucal import estimate_position, plots

    recording, _ = simulated(3, duration=8.0)
    s, f = recording.sensor("shank"), recording.sensor("foot")
    # A deliberately wrong axis: the figure must move the points onto this line, not
    # onto one it estimates itself.
    j1, j2 = np.array([0.0, 0.6, 0.8]), np.array([0.8, 0.0, 0.6])
    result = estimate_position(s.gyr, s.acc, f.gyr, f.acc, rate=recording.rate, restarts=4,
                               seed=1, joint="hinge", axis=(j1, j2))
    assert result.axis is None  # nothing estimated that the figure could fall back on
    lines = []
    project = plots.closest_point_on_axis
    monkeypatch.setattr(plots, "closest_point_on_axis",
                        lambda x, line: lines.append(np.array(line)) or project(x, line))
    plots.position_figure(result, "shank - foot")
    assert len(lines) >= 2
    assert all(np.allclose(line, np.concatenate([j1, j2])) for line in lines)


@pytest.mark.parametrize("cls", [Job, Outcome, Command])
def test_every_runner_field_is_documented(cls):
    documented = set()
    for line in cls.__doc__.splitlines():
        head = line.strip().split(" : ")[0]
        if " : " in line and re.fullmatch(r"[a-z_0-9]+(, [a-z_0-9]+)*", head):
            documented.update(head.split(", "))
    missing = {f.name for f in dataclasses.fields(cls)} - documented
    assert not missing, f"{cls.__name__}: undocumented {sorted(missing)}"


def test_still_periods_are_on_the_recordings_clock(real_recording, tmp_path):
    # The same 20 s (standing at 0-5 s) with its clock starting at 0 and at 100 s: the
    # gravity check's still periods move with the clock, and --start/--end are read on it.
    from imucal.recording import make_recording

    n = 2000
    sensors = {k: {"gyr": real_recording.sensor(k).gyr[:n], "acc": real_recording.sensor(k).acc[:n]}
               for k in ("left_thigh", "left_shank")}
    periods = {}
    for t0 in (0.0, 100.0):
        path = tmp_path / f"at{t0:g}.h5"
        save_recording(make_recording(sensors, time=t0 + np.arange(n) / 100.0), path)
        job = Job("axis", ("left_thigh", "left_shank"),
                  AxisSettings(restarts=8, seed=1, time_offset=0.0), start=t0 + 2, end=t0 + 20,
                  force=True)
        outcome = run(job, str(path))
        assert outcome.exit_code in (0, 1), outcome.error
        periods[t0] = [(p["start_s"], p["end_s"])
                       for p in outcome.document["quality"]["gravity"]["periods"]]
        assert outcome.document["input"]["window_s"] == pytest.approx([t0 + 2, t0 + 20])
    assert periods[0.0] and periods[0.0][0][0] == pytest.approx(2.0)  # standing, cut at 2 s
    assert np.allclose(np.array(periods[100.0]) - 100.0, periods[0.0])


def test_out_of_memory_in_a_single_file_command_is_no_bug_report(monkeypatch):
    # the study's lines said "out of memory" (runner.error_of); `imucal info`, `angles`
    # and `convert` said "internal error ... report it"; both now share the exit code
    import imucal.loaders

    def exhausted(*args, **kwargs):
        raise MemoryError("Unable to allocate 3.07 EiB for an array")

    monkeypatch.setattr(imucal.loaders, "load_recording", exhausted)
    run_ = run_imucal("info", "sample_data/circling.h5", cwd=Path(__file__).resolve().parents[1])
    assert run_.returncode == 3
    assert run_.stderr.decode().strip() == "imucal: error: out of memory"


@pytest.mark.parametrize("command", ["axis", "position", "calibrate"])
def test_the_command_line_defaults_are_the_settings_defaults(command):
    # cli.py spells its defaults as literals (importing the settings would load numpy
    # for `--help`); nothing tied them to the settings until this test
    import typer

    from imucal.cli import app
    from imucal.selection import MAX_SAMPLES
    from imucal.settings import AxisSettings, CalibrateSettings, PositionSettings

    settings = {"axis": AxisSettings, "position": PositionSettings,
                "calibrate": CalibrateSettings}[command]()
    click_command = typer.main.get_command(app).commands[command]
    defaults = {p.name: p.default for p in click_command.params}
    compared = 0
    for name in ("restarts", "offset_search", "acc_error", "time_offset", "sign", "j2_sign",
                 "select", "joint"):
        if name in defaults and hasattr(settings, name):
            assert defaults[name] == getattr(settings, name), name
            compared += 1
    assert compared >= 3
    if "max_samples" in defaults:  # None on the command line: the settings' cap
        assert defaults["max_samples"] is None and settings.max_samples == MAX_SAMPLES
        assert f"default {MAX_SAMPLES}" in next(
            p.help for p in click_command.params if p.name == "max_samples")
