"""The command line end to end, as a user runs it (real files; in-process but for one
real interpreter, see :func:`conftest.run_imucal`)."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from conftest import axis_error_deg, run_imucal

ROOT = Path(__file__).resolve().parents[1]


def imucal(*args, stdin: bytes | None = None, cwd=None):
    # in-process (conftest.run_imucal); the real process is covered by
    # test_loaders.py::test_cli_in_a_real_process_no_traceback_unless_debug and
    # test_the_console_script_runs below
    return run_imucal(*args, stdin=stdin, cwd=cwd)


@pytest.fixture(scope="module")
def recordings(tmp_path_factory):
    folder = tmp_path_factory.mktemp("rec")
    h5 = folder / "sim.h5"
    csv = folder / "sim40.csv"
    assert imucal("simulate", h5, "--seed", 11).returncode == 0
    assert imucal("simulate", csv, "--seed", 12, "--rate", 40).returncode == 0
    return h5, csv


def test_simulate_writes_recording_and_truth(recordings):
    h5, csv = recordings
    truth = json.loads(h5.with_name("sim.truth.json").read_text())
    assert set(truth) >= {"j1", "j2", "o1", "o2", "knee", "ankle", "settings"}
    assert truth["settings"]["seed"] == 11
    assert csv.with_name("sim40.truth.json").exists()


def test_axis_json_on_stdout_matches_truth(recordings):
    h5, _ = recordings
    run = imucal("axis", h5, "--seed", 3)
    assert run.returncode == 0, run.stderr
    doc = json.loads(run.stdout)  # stdout holds exactly one JSON document
    truth = json.loads(h5.with_name("sim.truth.json").read_text())
    assert max(axis_error_deg(np.array(doc["j1"]), np.array(doc["j2"]),
                              truth["j1"], truth["j2"])) < 0.5
    assert doc["command"] == "axis" and doc["imucal_version"]
    assert doc["input"]["sensors"] == ["thigh", "shank"]
    assert doc["input"]["sample_rate_hz"] == 100.0
    assert doc["settings"]["seed"] == 3 and doc["settings"]["restarts"] == 100
    conv = doc["convergence"]
    assert conv["fraction"] >= 0.95 and conv["iterations_median"] <= 10
    assert len(doc["restarts"]) == 100
    first = doc["restarts"][0]
    assert set(first) == {"initial", "final", "refined", "iterations", "converged",
                          "reached_estimate", "final_cost", "refined_cost"}
    assert doc["quality"]["warnings"] == [] and doc["quality"]["verdict"] == "good"
    assert b"restarts reached the estimate" in run.stderr


def test_position_from_csv_with_out_and_plot(recordings, tmp_path):
    _, csv = recordings
    out, png = tmp_path / "ankle.json", tmp_path / "ankle.png"
    run = imucal("position", csv, "--seed", 1, "--out", out, "--plot", png)
    assert run.returncode == 0, run.stderr
    assert run.stdout == b""
    doc = json.loads(out.read_text())
    truth = json.loads(csv.with_name("sim40.truth.json").read_text())
    for k in ("o1", "o2"):
        tol = max(0.02 * np.linalg.norm(truth[k]), 0.005)
        assert np.linalg.norm(np.subtract(doc[k], truth[k])) < tol
    assert "joint centre to the first" in doc["convention"]
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert [p.name for p in tmp_path.iterdir() if p.name.startswith(".")] == []


def test_axis_plot_and_hinge_position(recordings, tmp_path):
    h5, _ = recordings
    png = tmp_path / "knee.png"
    assert imucal("axis", h5, "--seed", 1, "--restarts", 10, "--plot", png).returncode == 0
    assert png.stat().st_size > 10_000
    run = imucal("position", h5, "--sensors", "thigh,shank", "--joint", "hinge", "--seed", 1,
                 "--restarts", 20)
    assert run.returncode == 0, run.stderr
    doc = json.loads(run.stdout)
    assert doc["joint"] == "hinge" and "axis_line" in doc


def test_same_seed_gives_identical_bytes(recordings):
    h5, _ = recordings
    a = imucal("position", h5, "--seed", 5, "--restarts", 20)
    b = imucal("position", h5, "--seed", 5, "--restarts", 20)
    assert a.returncode == 0 and a.stdout == b.stdout


def test_csv_from_stdin(recordings):
    _, csv = recordings
    run = imucal("axis", "-", "--restarts", 10, "--seed", 1, stdin=csv.read_bytes())
    assert run.returncode == 0, run.stderr
    doc = json.loads(run.stdout)
    assert doc["input"]["path"] == "<stdin>"
    assert doc["input"]["sample_rate_hz"] == pytest.approx(40.0)


def test_the_console_script_runs(recordings):
    # the one test here that starts a fresh interpreter: python -m imucal, data piped in
    _, csv = recordings
    run = subprocess.run([sys.executable, "-m", "imucal", "axis", "-", "--restarts", "10",
                          "--seed", "1"], input=csv.read_bytes(), capture_output=True,
                         timeout=120)
    assert run.returncode == 0, run.stderr
    assert json.loads(run.stdout) == json.loads(imucal("axis", "-", "--restarts", 10,
                                                       "--seed", 1,
                                                       stdin=csv.read_bytes()).stdout)


def test_window_is_on_the_recording_time_axis(recordings):
    h5, _ = recordings
    run = imucal("axis", h5, "--start", 2, "--end", 12, "--restarts", 5, "--seed", 1)
    doc = json.loads(run.stdout)
    assert doc["input"]["window_s"] == [2.0, 12.0]
    assert doc["input"]["samples_used"] == 1000


@pytest.mark.parametrize(
    ("args", "phrase"),
    [
        (["axis", "missing.h5"], b"missing.h5"),
        (["axis", "{h5}", "--sensors", "thigh,knee"], b"no sensor 'knee'"),
        (["axis", "{h5}", "--sensors", "thigh"], b"two different sensor names"),
        (["position", "{h5}", "--joint", "saddle"],
         b"Invalid value for '--joint': joint must be one of"),
        (["axis", "{h5}", "--out", "/nonexistent-folder/x.json"], b"does not exist"),
        (["axis", "{h5}", "--start", "100"], b"lies outside the recording"),
    ],
)
def test_bad_input_exits_2_with_one_line(recordings, args, phrase):
    h5, _ = recordings
    run = imucal(*[a.format(h5=h5) for a in args])
    assert run.returncode == 2
    assert run.stdout == b""
    assert phrase in run.stderr
    assert b"Traceback" not in run.stderr
    assert len(run.stderr.strip().splitlines()) == 1


def test_info_lists_sensors(recordings):
    h5, _ = recordings
    run = imucal("info", h5, "--json")
    assert run.returncode == 0
    doc = json.loads(run.stdout)
    assert set(doc["sensors"]) == {"thigh", "shank", "foot"}
    assert doc["sample_rate_hz"] == 100.0 and doc["duration_s"] == pytest.approx(20.0)
    assert all(s["motion"] == "moves" for s in doc["sensors"].values())
    text = imucal("info", h5).stdout.decode()
    assert "thigh" in text and "100 Hz" in text


def test_help_shows_examples():
    run = imucal("axis", "--help")
    assert run.returncode == 0
    assert b"Examples" in run.stdout and b"--restarts" in run.stdout


def test_help_texts_say_what_each_command_does():
    # a new-user trial: axis/position/calibrate's --scheduler ended "angles without
    # --tables runs here.", --jobs showed "[default: (1); x>=0]", simulate's and convert's
    # -q spoke of estimate warnings and JSON, and the command list cut convert's summary
    # at "e.g."
    def help_of(*command):
        run = imucal(*command, "--help")
        assert run.returncode == 0
        return " ".join(run.stdout.decode().split())

    for command in ("axis", "position", "calibrate"):
        text = help_of(command)
        assert "runs here" not in text and "(1)" not in text
        assert "[default: 1; x>=0]" in text
    assert "[default: 1; x>=0]" in help_of("angles")
    for command in ("simulate", "convert"):
        text = help_of(command)
        quiet = text[text.index("-q, --quiet"):text.index("--debug")]
        assert "JSON" not in quiet and "estimate" not in quiet and "angles" not in quiet
    commands = help_of()
    convert = commands[commands.index("convert Write"):]
    assert not convert.rstrip().endswith("e.g.")


def test_csv_at_40_hz_meets_paper_targets(recordings):
    _, csv = recordings
    truth = json.loads(csv.with_name("sim40.truth.json").read_text())
    axis = json.loads(imucal("axis", csv, "--seed", 2).stdout)
    assert max(axis_error_deg(np.array(axis["j1"]), np.array(axis["j2"]),
                              truth["j1"], truth["j2"])) < 0.5
    pos = json.loads(imucal("position", csv, "--seed", 2).stdout)
    for k in ("o1", "o2"):
        assert np.linalg.norm(np.subtract(pos[k], truth[k])) < max(
            0.02 * np.linalg.norm(truth[k]), 0.005)
    for doc in (axis, pos):
        assert doc["input"]["sample_rate_hz"] == pytest.approx(40.0)
        assert doc["convergence"]["fraction"] >= 0.95
        assert doc["convergence"]["iterations_median"] <= 10


def test_outputs_never_overwrite_the_input_or_each_other(tmp_path):
    rec = tmp_path / "rec.h5"
    rec.write_bytes((ROOT / "sample_data" / "circling.h5").read_bytes())
    before = rec.read_bytes()
    run = imucal("axis", rec, "--out", rec)
    assert run.returncode == 2 and b"names an input recording" in run.stderr
    run = imucal("axis", rec, "--out", tmp_path / "x.png", "--plot", tmp_path / "x.png")
    assert run.returncode == 2 and b"name the same file" in run.stderr
    run = imucal("axis", rec, ROOT / "sample_data" / "circling.h5", "--out", rec)
    assert run.returncode == 2 and b"names an input recording" in run.stderr
    # convert has no --out: its output is the argument OUT
    run = imucal("convert", rec, rec)
    assert run.returncode == 2 and b": OUT names an input recording" in run.stderr
    assert rec.read_bytes() == before


@pytest.mark.parametrize("rate", ["1e300", "1e-300", "0.5", "20000"])
def test_implausible_rates_are_refused(rate):
    run = imucal("axis", ROOT / "sample_data" / "circling_40hz.csv", "--rate", rate)
    assert run.returncode == 2 and b"body-worn IMUs" in run.stderr
    assert b"Traceback" not in run.stderr


@pytest.mark.parametrize("files", [1, 3])
def test_a_reader_that_stops_early_ends_the_command_quietly(files):
    # `imucal axis A B C --jobs 2 | head -c 10` printed "imucal: error: : Broken pipe"
    # (no file name) and exited 2; now as `angles` does: no message, the status a shell
    # gives a process stopped by SIGPIPE
    sample = str(ROOT / "sample_data" / "circling.h5")
    proc = subprocess.Popen([sys.executable, "-m", "imucal", "axis", *[sample] * files,
                             "--restarts", "5", "-q", "--jobs", "2"],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    proc.stdout.close()  # the reader is gone before the first line
    err = proc.stderr.read()
    assert proc.wait(timeout=120) == 141
    assert err == b""


@pytest.mark.parametrize("unbuffered", ["", "1"])
def test_a_reader_that_stops_in_the_middle_of_the_output_is_no_success(unbuffered):
    # `imucal angles walk.h5 -c cal.json | head -1` exited 0: a reader that leaves during
    # one large write made Python's stream return the bytes written so far, not fail, so
    # the output was cut short without a word. With --trace the JSON is about 80 kB, more
    # than a pipe holds: the reader takes 10 bytes while the write is under way.
    sample = str(ROOT / "sample_data" / "circling.h5")
    # (with PYTHONUNBUFFERED the text stream writes to the raw file, whose short write
    # it drops just the same)
    env = {k: v for k, v in os.environ.items() if k != "PYTHONUNBUFFERED"}
    if unbuffered:
        env["PYTHONUNBUFFERED"] = unbuffered
    proc = subprocess.Popen([sys.executable, "-m", "imucal", "axis", sample, "--trace",
                             "--seed", "1", "-q"], bufsize=0, env=env,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    assert proc.stdout.read(10).startswith(b"{")  # the JSON has begun
    proc.stdout.close()
    err = proc.stderr.read()
    assert proc.wait(timeout=120) == 141
    assert err == b""


def test_short_writes_are_retried_until_all_is_written():
    from imucal.atomic import write_fully

    got = []

    def short(view):  # a stream that takes at most 3 bytes per call
        got.append(bytes(view[:3]))
        return len(got[-1])

    write_fully(short, b"0123456789")
    assert b"".join(got) == b"0123456789" and len(got) == 4
    with pytest.raises(OSError, match="accepted no more bytes"):
        write_fully(lambda view: 0, b"x")


def test_the_summary_names_the_window_fitted():
    # the header described the whole file only: "2000 samples at 100 Hz (20.0 s)" for a
    # fit of 0-10 s
    sample = ROOT / "sample_data" / "circling.h5"
    run = run_imucal("axis", sample, "--restarts", "5", "--seed", "1", "--end", "10",
                     text=True)
    assert run.returncode == 0
    assert run.stderr.splitlines()[0].endswith("2000 samples at 100 Hz (20.0 s), window 0 to 10 s")
    whole = run_imucal("axis", sample, "--restarts", "5", "--seed", "1", text=True)
    assert whole.stderr.splitlines()[0].endswith("(20.0 s)")
    cal = run_imucal("calibrate", sample, "--restarts", "5", "--seed", "1", "--start", "2",
                     text=True)
    assert cal.stderr.splitlines()[0].endswith("(20.0 s), window 2 to 20 s")


def test_info_says_where_the_rate_came_from_and_the_columns_units(tmp_path):
    # the table's "rms rate" / "peak rate" (angular rates, units only in the cells as
    # "d/s") read as sample rates, and nothing said where the sample rate came from
    sample = ROOT / "sample_data" / "circling_40hz.csv"
    text = sample.read_bytes()
    piped = imucal("info", "-", stdin=text).stdout.decode().splitlines()
    assert piped[0].startswith("<stdin>: 800 samples at 40 Hz (20.0 s, t = 0 to 19.975 s)")
    assert piped[1] == "sample rate from the median step of 'time'"
    assert piped[2].split() == ["sensor", "file", "units", "gyro", "rms", "deg/s", "gyro",
                                "peak", "deg/s", "|acc|-g", "rms", "m/s^2", "motion"]
    assert "d/s " not in "\n".join(piped[3:])
    given = imucal("info", sample, "--rate", "40").stdout.decode().splitlines()
    assert given[1] == "sample rate from --rate, checked against 'time'"
    no_time = tmp_path / "no_time.csv"
    no_time.write_text("\n".join(line.split(",", 1)[1] for line in
                                 text.decode().splitlines()) + "\n")
    run = imucal("info", no_time, "--rate", "40", "--json")
    assert json.loads(run.stdout)["sample_rate_from"] == "--rate"
    h5 = imucal("info", ROOT / "sample_data" / "circling.h5").stdout.decode().splitlines()
    assert h5[1] == "sample rate from the 'sample_rate' attribute, checked against 'time'"


def test_info_keeps_its_columns_in_line_for_long_sensor_names(tmp_path):
    # names longer than the name column (an Xsens file copied with its serial) pushed the
    # rest of their row to the right of the header
    text = (ROOT / "sample_data" / "circling_40hz.csv").read_text()
    long = tmp_path / "long.csv"
    long.write_text(text.replace("thigh_", "thigh_sensor_00B42D4F_copy_"))
    lines = imucal("info", long).stdout.decode().splitlines()
    header, rows = lines[2], lines[3:6]
    units_at = header.index("file units")
    assert [r.index("rad/s") for r in rows] == [units_at] * 3, lines


def _simulate_signalled(folder, seconds: int, signum, preexec_fn=None):
    """``imucal simulate FOLDER/long.csv --duration SECONDS`` in its own process, sent
    ``signum`` once its output file has started (past start-up: the handlers are
    installed): (returncode, stderr)."""
    import time

    proc = subprocess.Popen([sys.executable, "-m", "imucal", "simulate",
                             str(folder / "long.csv"), "--duration", str(seconds),
                             "--seed", "1", "-q"],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                            preexec_fn=preexec_fn)
    try:
        deadline = time.monotonic() + 60
        while not list(folder.iterdir()):  # the temporary file is being written
            assert proc.poll() is None and time.monotonic() < deadline, "no file started"
            time.sleep(0.01)
        proc.send_signal(signum)
        _, err = proc.communicate(timeout=120)
    finally:
        if proc.poll() is None:
            proc.kill()
    return proc.returncode, err


def test_sigterm_ends_a_command_with_its_status_and_no_half_written_file(tmp_path):
    # SIGTERM (what `kill` and job schedulers send) ended imucal on the spot, leaving the
    # output's temporary copy beside the target; now it cleans up as Ctrl-C does.
    import signal

    code, err = _simulate_signalled(tmp_path, 3000, signal.SIGTERM)  # CSV: seconds to hit
    assert (code, err) == (143, b"imucal: terminated (SIGTERM)\n"), err.decode()
    # no temporary copy left (a signal handled just after the rename leaves the
    # recording complete, without its truth file)
    assert [p.name for p in tmp_path.iterdir() if p.name.startswith(".")] == []


def test_a_signal_the_command_was_started_with_ignored_stays_ignored(tmp_path):
    # nohup (and a script's background jobs) start a command with SIGHUP (SIGINT)
    # ignored; imucal used to take them over, so closing the terminal ended a nohup run
    import signal

    def ignore_hangups():
        signal.signal(signal.SIGHUP, signal.SIG_IGN)

    code, err = _simulate_signalled(tmp_path, 600, signal.SIGHUP, ignore_hangups)
    assert (code, err) == (0, b""), err.decode()
    out = tmp_path / "long.csv"
    assert out.exists() and out.with_name("long.truth.json").exists()


def test_held_holds_nothing_for_a_python_caller():
    # a study started from Python held the ending signals while multiprocessing's shared
    # fork server started, which then kept them blocked for the caller's own processes
    import signal

    from imucal import signals

    before = signal.pthread_sigmask(signal.SIG_BLOCK, set())
    with signals.held():
        assert signal.pthread_sigmask(signal.SIG_BLOCK, set()) == before
    signals.raise_on_signals()
    try:
        with signals.held():
            inside = signal.pthread_sigmask(signal.SIG_BLOCK, set())
        assert set(signals.ENDING) <= inside
    finally:
        signals.uninstall()
    assert signal.pthread_sigmask(signal.SIG_BLOCK, set()) == before


def test_a_signal_while_the_temporary_file_is_created_leaves_no_file(tmp_path, monkeypatch):
    import signal
    import tempfile

    from imucal import signals
    from imucal.atomic import write_text_atomic

    create = tempfile.mkstemp

    def signalled(*args, **kwargs):
        os.kill(os.getpid(), signal.SIGTERM)  # held until the file's name is kept
        return create(*args, **kwargs)

    monkeypatch.setattr(tempfile, "mkstemp", signalled)
    signals.raise_on_signals()
    try:
        with pytest.raises(signals.Terminated):
            write_text_atomic(tmp_path / "out.json", "{}")
    finally:
        signals.uninstall()
    assert list(tmp_path.iterdir()) == []


def test_an_interruption_turned_into_another_error_still_ends_the_command(monkeypatch):
    # a signal inside a module being imported surfaces as "initialization failed" (an
    # ImportError) or a RuntimeError: that was an internal error (exit 3) for the
    # recording, and the study went on with its handlers already spent
    import signal
    import time

    from imucal import runner, signals
    from imucal.settings import AxisSettings

    def hit(job, file, outcome):
        try:
            os.kill(os.getpid(), signal.SIGTERM)
            time.sleep(0.1)
        except KeyboardInterrupt:
            raise ImportError("initialization failed") from None

    monkeypatch.setattr(runner, "_run", hit)
    signals.raise_on_signals()
    try:
        with pytest.raises(signals.Terminated):
            runner.run(runner.Job("axis", ("thigh", "shank"), AxisSettings(seed=1)), "x.h5")
    finally:
        signals.uninstall()


def test_the_first_ending_signal_raises_and_later_ones_are_ignored():
    import signal
    import time

    from imucal import signals

    saved = {s: signal.getsignal(s) for s in signals.ENDING}
    try:
        signals.raise_on_signals()
        with pytest.raises(signals.Terminated) as caught:
            os.kill(os.getpid(), signal.SIGTERM)
            time.sleep(0.1)  # the handler runs between bytecodes
        assert (caught.value.exit_code, str(caught.value)) == (143, "SIGTERM")
        assert signals.unreported() is caught.value
        os.kill(os.getpid(), signal.SIGINT)  # during the clean-up: no KeyboardInterrupt
        time.sleep(0.1)
        assert signals.report(caught.value) == 143
        assert signals.unreported() is None
        signals.uninstall()
        signals.raise_on_signals()
        # Ctrl-C as a subclass: CPython kills itself with SIGINT at exit after a plain
        # KeyboardInterrupt left code run by eval(), even a caught one (status -2)
        with pytest.raises(signals.Interrupted) as caught:
            os.kill(os.getpid(), signal.SIGINT)
            time.sleep(0.1)
        assert type(caught.value) is not KeyboardInterrupt
        assert signals.report(caught.value) == 130
    finally:
        signals.uninstall()
        for s, handler in saved.items():
            signal.signal(s, handler)


def test_standard_output_stand_ins_get_the_text_as_the_text_stream_would(monkeypatch):
    # the byte path (for whole writes to a pipe) only where bytes are what the text
    # stream would write: a notebook's StringIO, a UTF-16 stream (one byte-order mark,
    # not one per write) and a subclass of the text stream get the text itself
    import io

    from imucal.atomic import write_stdout

    text = io.StringIO()
    monkeypatch.setattr(sys, "stdout", text)
    write_stdout("a\n")
    write_stdout("b\n")
    assert text.getvalue() == "a\nb\n"
    raw = io.BytesIO()
    wide = io.TextIOWrapper(io.BufferedWriter(raw), encoding="utf-16")
    monkeypatch.setattr(sys, "stdout", wide)
    write_stdout("a\n")
    write_stdout("b\n")
    assert raw.getvalue().decode("utf-16") == "a\nb\n"
    assert raw.getvalue().count(b"\xff\xfe") == 1

    class Tee(io.TextIOWrapper):
        pass

    raw = io.BytesIO()
    monkeypatch.setattr(sys, "stdout", Tee(io.BufferedWriter(raw), encoding="utf-8"))
    write_stdout("c\n")
    assert raw.getvalue() == b"c\n"


def test_simulate_refuses_a_name_whose_truth_another_recording_shares(tmp_path):
    # rec.csv then rec.h5 both wrote rec.truth.json: rec.csv was left beside the truth
    # of another seed and rate
    assert imucal("simulate", tmp_path / "rec.csv", "--duration", "3", "--rate", "40",
                  "-q").returncode == 0
    truth = (tmp_path / "rec.truth.json").read_bytes()
    run = imucal("simulate", tmp_path / "rec.h5", "--duration", "3", "-q")
    assert run.returncode == 2
    assert "rec.csv lies beside it and would share rec.truth.json" in run.stderr.decode()
    assert not (tmp_path / "rec.h5").exists()
    assert (tmp_path / "rec.truth.json").read_bytes() == truth
    # the same name in another case is another file (a review)
    assert imucal("simulate", tmp_path / "c.H5", "--duration", "3", "-q").returncode == 0
    run = imucal("simulate", tmp_path / "c.h5", "--duration", "3", "-q")
    assert run.returncode == 2 and "c.H5 lies beside it" in run.stderr.decode()
    # the same file again is no sibling
    assert imucal("simulate", tmp_path / "c.H5", "--duration", "3", "-q").returncode == 0


def test_calibrate_says_each_joints_clock_offset(tmp_path):
    # the summary printed a knee's axes, centre and angle zero but not the clock offset the
    # angles will read its shank at (only a warning named it, where the centre's search
    # overruled the axis's); the axis and position commands print theirs
    from imucal.simulate import simulate
    from imucal.writers import save_recording

    rec, _ = simulate(seed=5, motion="circling", duration=20.0, clock_offset={"shank": 0.020})
    save_recording(rec, tmp_path / "late.h5")
    run = run_imucal("calibrate", tmp_path / "late.h5", "--restarts", "10", "--seed", "1",
                     "--out", tmp_path / "cal.json", text=True)
    assert run.returncode == 0, run.stderr
    lines = [line.strip() for line in run.stderr.splitlines()]
    knee = next(line for line in lines if line.startswith("clock offset of shank: "))
    foot = next(line for line in lines if line.startswith("clock offset of foot: "))
    doc = json.loads((tmp_path / "cal.json").read_text())
    for line, block in ((knee, doc["joints"]["knee"]["axis"]["time_offset"]),
                        (foot, doc["joints"]["ankle"]["position"]["time_offset"])):
        assert block["applied"] and line.endswith(" ms, applied)")
        found = float(line.split(": ")[1].split(" ms")[0])
        assert found == round(1000 * block["estimated_s"], 1)
        assert abs(abs(found) - 20.0) < 3.0  # the foot reads -20 ms against the shank


def test_the_summary_says_what_the_check_of_a_given_offset_read():
    # with --time-offset the summary said nothing of the clocks; the JSON held the check
    sample = ROOT / "sample_data" / "circling.h5"
    run = run_imucal("axis", sample, "--sensors", "thigh,shank", "--restarts", "5", "--seed",
                     "1", "--time-offset", "0.03", text=True)
    assert run.returncode == 0, run.stderr
    block = json.loads(run.stdout)["time_offset"]
    line = next(line.strip() for line in run.stderr.splitlines()
                if line.strip().startswith("clock offset of shank: "))
    assert block["contradicted"] and line == (
        f"clock offset of shank: +30.0 ms given (the data read "
        f"{1000 * block['estimated_s']:+.1f} ms, 1-sigma {1000 * block['sigma_s']:.1f} ms: "
        "contradicted)")


def test_an_offset_a_short_window_could_not_estimate_is_not_read_as_zero():
    # it printed "+0.0 ms (1-sigma - ms, not applied)" where nothing was estimated (a
    # new-user trial)
    sample = ROOT / "sample_data" / "circling.h5"
    run = run_imucal("axis", sample, "--sensors", "thigh,shank", "--restarts", "5", "--seed",
                     "1", "--start", "0", "--end", "0.3", "--force", text=True)
    block = json.loads(run.stdout)["time_offset"]
    assert block["sigma_s"] is None and block["estimated_s"] == 0.0
    assert "clock offset of shank: not estimated (too few usable samples for the search)" in [
        line.strip() for line in run.stderr.splitlines()]


def test_a_given_offsets_check_at_the_search_end_reads_as_a_bound():
    # the summary printed "the data read +100.0 ms, 1-sigma 2.1 ms" where the warning said
    # "beyond the search's end" (an independent review)
    from imucal.cli import _offset_text

    block = {"mode": "given", "time_offset_s": 0.0, "estimated_s": 0.1, "sigma_s": 0.0021,
             "at_edge": True, "contradicted": True}
    assert _offset_text(block) == ("+0.0 ms given (the data read at least +100.0 ms, the end "
                                   "of the search: contradicted)")


@pytest.mark.parametrize("command", ["axis", "calibrate"])
def test_jobs_0_means_one_process_per_core(command, monkeypatch, tmp_path):
    # 'jobs or 1' made --jobs 0 one process for axis, position and calibrate, where
    # --help says "0: one per CPU core" and angles' study did so (an independent review)
    import imucal.study

    seen = []
    monkeypatch.setattr(imucal.study, "run_study",
                        lambda job, files, **kw: seen.append(kw["jobs"]) or 0)
    run = run_imucal(command, "a.h5", "b.h5", "--jobs", "0", cwd=tmp_path)
    assert run.returncode == 0 and seen == [0]
    run = run_imucal(command, "a.h5", "b.h5", cwd=tmp_path)
    assert run.returncode == 0 and seen == [0, 1]


def test_info_gives_a_short_recordings_duration(tmp_path):
    # a 2-sample CSV read "(0.0 s, ...)" where --json gave 0.02 s (a new-user trial)
    path = tmp_path / "two.csv"
    path.write_text("time,t_gyr_x,t_gyr_y,t_gyr_z,t_acc_x,t_acc_y,t_acc_z\n"
                    "0,0,0,0,0,0,9.8\n0.01,0,0,0,0,0,9.8\n")
    run = run_imucal("info", path, text=True)
    assert run.returncode == 0
    assert run.stdout.splitlines()[0].endswith("2 samples at 100 Hz (0.02 s, t = 0 to 0.01 s)")
