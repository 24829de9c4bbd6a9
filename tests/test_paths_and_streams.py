"""Odd invocations: outputs that are not regular files (FIFOs, links), inputs that can be
read only once (pipes), link loops, empty names, closed standard streams, and files that
never end. Each case once ended in exit 3, a hang, lost data or a replaced device."""

from __future__ import annotations

import contextlib
import json
import os
import subprocess
import sys
import threading
from pathlib import Path

import pytest
from conftest import run_imucal as _run_imucal

from imucal import loaders
from imucal.errors import InputError
from imucal.sensor_map import read_sensor_map


def run_imucal(*args, **kwargs):
    return _run_imucal(*args, text=True, **kwargs)


SAMPLE = Path(__file__).resolve().parents[1] / "sample_data" / "circling.h5"
AXIS = ("axis", SAMPLE, "--sensors", "thigh,shank", "--seed", 1, "--restarts", 5, "-q")


@contextlib.contextmanager
def _feed(data: bytes):
    """A path that reads ``data`` once, as a shell's ``<(...)`` does (/dev/fd/N of a pipe
    whose writer closes at the end); the pipe is closed, and its writer ended, on exit."""
    read, write = os.pipe()

    def writer():
        with os.fdopen(write, "wb") as fh:
            try:
                fh.write(data)
            except BrokenPipeError:  # the reader stopped early (and closed below)
                pass
    thread = threading.Thread(target=writer, daemon=True)
    thread.start()
    try:
        yield f"/dev/fd/{read}"
    finally:
        os.close(read)
        thread.join(10)


def _reader(path: Path, box: list) -> threading.Thread:
    def read():
        with open(path, "rb") as fh:
            box.append(fh.read())
    thread = threading.Thread(target=read, daemon=True)
    thread.start()
    return thread


@pytest.mark.skipif(not Path("/dev/fd").exists(), reason="needs /dev/fd (Linux, macOS)")
@pytest.mark.parametrize("kind", ["h5", "csv"])
def test_a_pipe_as_rec_is_read_once_and_whole(tmp_path, kind):
    # every format's sniffer reopened the path: the first 8 KB were lost ("no sensor
    # columns found" for CSV, "not an HDF5 file" for HDF5)
    path = SAMPLE
    if kind == "csv":
        path = tmp_path / "c.csv"
        assert run_imucal("convert", SAMPLE, path).returncode == 0
    with _feed(path.read_bytes()) as piped_path:
        piped = run_imucal(*AXIS[:1], piped_path, *AXIS[2:])
    assert piped.returncode == 0, piped.stderr
    direct = run_imucal(*AXIS[:1], path, *AXIS[2:])
    assert json.loads(piped.stdout)["j1"] == json.loads(direct.stdout)["j1"]


@pytest.fixture(scope="module")
def knee_calibration(tmp_path_factory):
    """The sample circling trial's knee calibration file."""
    cal = tmp_path_factory.mktemp("knee") / "cal.json"
    assert run_imucal("calibrate", SAMPLE, "--joint", "knee=hinge:thigh,shank", "--seed", 1,
                      "--restarts", 5, "--out", cal, "-q").returncode == 0
    return cal


@pytest.mark.skipif(not Path("/dev/fd").exists(), reason="needs /dev/fd (Linux, macOS)")
def test_a_calibration_given_as_a_pipe_is_read_once(knee_calibration, tmp_path):
    # `angles -c <(...)` read the calibration twice (the command's check, then the run;
    # a study: the check, then each recording): "not a calibration file (it is empty)"
    # for the only recording, and for every one of a study (a new-user trial)
    cal = knee_calibration
    walk = SAMPLE.with_name("walking.h5")
    direct = run_imucal("angles", walk, "-c", cal, "-q")
    assert direct.returncode == 0, direct.stderr
    with _feed(cal.read_bytes()) as piped_path:
        piped = run_imucal("angles", walk, "-c", piped_path, "-q")
    assert piped.returncode == 0, piped.stderr
    assert piped.stdout == direct.stdout
    with _feed(cal.read_bytes()) as piped_path:
        study = run_imucal("angles", walk, SAMPLE, "-c", piped_path, "--tables",
                           tmp_path / "t", "-q", "--force")
    lines = [json.loads(line) for line in study.stdout.splitlines()]
    assert [o["error"] for o in lines] == [None, None], study.stderr
    assert (tmp_path / "t" / "walking.csv").read_text() == direct.stdout


def test_a_stream_without_an_end_is_refused_at_the_cap(monkeypatch):
    # read in chunks: one read of the whole allowance reserved 4 GiB before reading
    # anything (a small pipe failed under a 3 GB memory limit)
    monkeypatch.setattr(loaders, "MAX_STREAM_BYTES", 10_000)
    monkeypatch.setattr(loaders, "STREAM_CHUNK", 1000)
    with _feed(b"time,a_gyr_x\n" + b"0,0\n" * 100_000) as path:
        with pytest.raises(InputError, match="more than 10000 bytes without an end"):
            loaders.load_recording(path)
    with _feed(SAMPLE.read_bytes()[:9000]) as path:  # under the cap: read whole
        with pytest.raises(InputError, match="truncated HDF5"):
            loaders.load_recording(path)


@pytest.mark.skipif(not hasattr(os, "mkfifo"), reason="needs FIFOs")
def test_out_to_a_fifo_writes_through_it(tmp_path):
    # --out renamed its temporary file over the target: a FIFO (or /dev/null, /dev/stdout
    # when run as root) became a plain file, and a reader got nothing
    fifo = tmp_path / "out.fifo"
    os.mkfifo(fifo)
    box: list = []
    thread = _reader(fifo, box)
    run = run_imucal(*AXIS, "--out", fifo)
    thread.join(10)
    assert run.returncode == 0, run.stderr
    assert fifo.is_fifo()
    assert json.loads(box[0])["command"] == "axis"


def test_out_through_a_link_replaces_the_file_and_keeps_the_link(tmp_path):
    target = tmp_path / "target.json"
    target.write_text("old")
    link = tmp_path / "link.json"
    link.symlink_to(target)
    run = run_imucal(*AXIS, "--out", link)
    assert run.returncode == 0, run.stderr
    assert link.is_symlink()
    assert json.loads(target.read_text())["command"] == "axis"


def test_out_dash_is_stdout(tmp_path):
    run = run_imucal(*AXIS, "--out", "-", cwd=tmp_path)
    assert run.returncode == 0, run.stderr
    assert json.loads(run.stdout)["command"] == "axis"
    assert not (tmp_path / "-").exists()


@pytest.mark.parametrize("args", [
    (*AXIS, "--out", "res/"), (*AXIS, "--plot", "figs/"), (*AXIS, "--out", ""),
    (*AXIS, "--out", "res/."),
    ("simulate", "sims/", "--duration", 2), ("convert", SAMPLE, "conv/"),
])
def test_an_output_named_as_a_folder_or_empty_is_refused(tmp_path, args):
    # "--out res/" wrote a file named "res" (pathlib drops the slash), "--out ''" became
    # "." ("is a folder")
    run = run_imucal(*args, cwd=tmp_path)
    assert run.returncode == 2
    lines = run.stderr.strip().splitlines()
    assert len(lines) == 1, run.stderr
    assert ("names a folder; give a file name" in lines[0]) or ("an empty file name" in
                                                                  lines[0]), lines[0]
    assert list(tmp_path.iterdir()) == []


def test_out_name_at_the_file_system_limit(tmp_path):
    # the hidden temporary name (".NAME.random.probe") went past 255 bytes: "folder is
    # not writable"
    out = tmp_path / ("N" * 250 + ".json")
    run = run_imucal(*AXIS, "--out", out)
    assert run.returncode == 0, run.stderr
    assert json.loads(out.read_text())["command"] == "axis"


def test_link_loops_and_empty_names_are_named(tmp_path):
    loop = tmp_path / "loop.h5"
    loop.symlink_to(loop)
    for args in ((*AXIS[:1], loop, *AXIS[2:]), (*AXIS, "--map", loop),
                 ("axis", loop, SAMPLE, "--out", tmp_path / "s.jsonl", "-q")):
        run = run_imucal(*args)
        assert run.returncode == 2, run.stderr  # was 3: RuntimeError from Path.resolve
        assert "symbolic link loop" in run.stderr
    run = run_imucal("axis", "")  # an unset "$f" read the current folder
    assert run.returncode == 2
    assert "'': empty file name" in run.stderr
    run = run_imucal("axis", f"{SAMPLE}/")
    assert run.returncode == 2
    assert "is a file, not a folder" in run.stderr


def test_map_files_that_are_not_maps(tmp_path):
    big = tmp_path / "bigint.json"
    big.write_text('{"thigh": ' + "9" * 5000 + "}")
    deep = tmp_path / "deep.json"
    deep.write_text('{"a": ' + "[" * 100_000 + "]" * 100_000 + "}")
    for path in (big, deep):
        with pytest.raises(InputError, match="invalid JSON"):  # was ValueError, RecursionError
            read_sensor_map(path)
    # a stream has no size to check first: /dev/zero was read until memory ran out
    with _feed(b"a = b\n" * 400_000) as path:
        with pytest.raises(InputError, match="too large for a sensor map"):
            read_sensor_map(path)
    with pytest.raises(InputError, match="not standard input"):
        read_sensor_map("-")


def test_calibration_from_stdin_is_named():
    run = run_imucal("angles", SAMPLE, "-c", "-")
    assert run.returncode == 2
    assert "not standard input" in run.stderr


def test_stdin_on_a_terminal_is_refused(monkeypatch):
    class Terminal:
        def isatty(self):
            return True

        def read(self, *args):  # a real terminal waits here for typed input
            return b""

    monkeypatch.setattr(sys, "stdin", type("Stdin", (), {"buffer": Terminal()})())
    with pytest.raises(InputError, match="standard input is a terminal"):
        loaders.load_recording("-")


def test_usage_errors_and_figure_names_are_one_clear_line():
    run = run_imucal("calibrate", SAMPLE, "--joint", "kn\nee=hinge:thigh,shank")
    assert run.returncode == 2
    assert len(run.stderr.strip().splitlines()) == 1
    run = run_imucal(*AXIS, "--plot", ".png")
    assert run.returncode == 2
    assert "give the figure a name before its extension" in run.stderr


def _process(*args, **popen):
    popen.setdefault("stdout", subprocess.PIPE)
    popen.setdefault("stderr", subprocess.PIPE)
    return subprocess.run([sys.executable, "-m", "imucal", *map(str, args)], timeout=120,
                          **popen)


@pytest.mark.skipif(os.name != "posix", reason="closes descriptors in the child")
def test_closed_standard_streams():
    # stdout closed (>&-): exit 3 from writing to None (and a traceback for --help);
    # now one line and exit 2
    for args in (AXIS, ("--help",), (*AXIS, "--out", "/dev/stdout")):
        run = _process(*args, stdout=None, preexec_fn=lambda: os.close(1))
        assert run.returncode == 2, run.stderr
        assert run.stderr.decode().count("\n") == 1
        # (through /dev/stdout the output went to /dev/null, held for the closed 1)
        assert "closed" in run.stderr.decode()
    # stderr closed (2>&-): the summary and warnings went to stdout, into the JSON
    run = subprocess.run([sys.executable, "-m", "imucal", *map(str, AXIS[:-1])],
                         stdout=subprocess.PIPE, preexec_fn=lambda: os.close(2), timeout=120)
    assert run.returncode == 0
    assert json.loads(run.stdout)["command"] == "axis"


@pytest.mark.skipif(not Path("/dev/fd/1").exists(), reason="needs /dev/fd")
def test_out_to_a_descriptor_keeps_the_shells_order(tmp_path):
    # --out /dev/fd/1 (or /dev/stdout) reopened the file: what the shell wrote next went
    # over the start of the JSON; it now writes through the descriptor itself
    log = tmp_path / "log.txt"
    command = " ".join(f"'{a}'" for a in (sys.executable, "-m", "imucal", *AXIS))
    script = f"{{ echo H; {command} --out /dev/fd/1; echo T; }} > '{log}'"
    assert subprocess.run(["sh", "-c", script], timeout=120).returncode == 0
    text = log.read_text()
    assert text.startswith("H\n{") and text.endswith("}\nT\n")
    assert json.loads(text[2:-2])["command"] == "axis"


@pytest.mark.skipif(os.name != "posix", reason="removes the working folder")
def test_a_deleted_working_folder_is_named(tmp_path):
    gone = tmp_path / "gone"
    gone.mkdir()

    def enter_and_remove():
        os.chdir(gone)
        os.rmdir(gone)
    run = _process(*AXIS, "--out", "x.json", preexec_fn=enter_and_remove)
    assert run.returncode == 2
    assert "the current folder no longer exists" in run.stderr.decode()


@pytest.mark.skipif(not Path("/dev/fd").exists(), reason="needs /dev/fd (Linux, macOS)")
def test_a_study_of_pipes_runs_in_this_process():
    # worker processes have no such descriptor: each pipe read "no such file"
    data = SAMPLE.read_bytes()
    with _feed(data) as a, _feed(data) as b:
        run = run_imucal("axis", a, b, *AXIS[2:-1], "--jobs", 2)
    assert run.returncode == 0, run.stderr
    lines = [json.loads(line) for line in run.stdout.splitlines()]
    assert [line["exit_code"] for line in lines] == [0, 0]
    assert "run in this process" in run.stderr


@pytest.mark.skipif(not Path("/dev/fd").exists(), reason="needs /dev/fd (Linux, macOS)")
@pytest.mark.parametrize("jobs", [1, 2])
def test_a_study_reads_a_piped_map_once(jobs):
    # each recording read the map again: from a pipe every one but the first found it
    # empty (--jobs 1) or missing (--jobs 2)
    text = b"thigh = upper\nshank = lower\nfoot = end\n"
    with _feed(text) as path:
        run = run_imucal("axis", SAMPLE, SAMPLE, "--sensors", "upper,lower", "--seed", 1,
                         "--restarts", 5, "--map", path, "--jobs", jobs, "-q")
    assert run.returncode == 0, run.stderr
    lines = [json.loads(line) for line in run.stdout.splitlines()]
    assert [line["exit_code"] for line in lines] == [0, 0]
    with _feed(text) as path:
        single = run_imucal("axis", SAMPLE, "--sensors", "upper,lower", "--seed", 1,
                            "--restarts", 5, "--map", path, "-q")
    assert lines[0]["result"]["j1"] == json.loads(single.stdout)["j1"]


@pytest.mark.skipif(not Path("/dev/fd").exists(), reason="needs /dev/fd (Linux, macOS)")
def test_a_calibration_through_a_pipe(tmp_path):
    # refused before ("not a regular file"), while REC and --map accept pipes
    from imucal.calibration import load_calibration

    cal = tmp_path / "cal.json"
    assert run_imucal("calibrate", SAMPLE, "--seed", 1, "--restarts", 5, "-q",
                      "--out", cal).returncode == 0
    with _feed(cal.read_bytes()) as path:
        assert set(load_calibration(path).joints) == set(load_calibration(cal).joints)
    with _feed(b"") as path, pytest.raises(InputError, match="it is empty"):
        load_calibration(path)


def test_a_file_named_with_a_newline_keeps_every_message_one_line(tmp_path):
    # the headline and the summary quoted the name as it is: its second half began a
    # line of its own, which a script reading stderr line by line took for a message
    odd = tmp_path / "left\nknee.h5"
    odd.write_bytes(SAMPLE.read_bytes())
    single = run_imucal("axis", odd, "--sensors", "thigh,shank", "--seed", 1,
                        "--restarts", 5, "--out", tmp_path / "out\nput.json")
    assert single.returncode == 0, single.stderr
    lines = single.stderr.splitlines()
    assert lines[0].startswith("imucal axis: ") and "left\\nknee.h5: thigh -> shank" in lines[0]
    assert not any(line.startswith("knee.h5") for line in lines)
    study = run_imucal("axis", odd, tmp_path / "missing\nfile.h5", "--sensors", "thigh,shank",
                       "--seed", 1, "--restarts", 5)
    assert study.returncode == 2
    assert [json.loads(line)["exit_code"] for line in study.stdout.splitlines()] == [0, 2]
    assert not any(line.startswith(("knee.h5", "file.h5")) for line in study.stderr.splitlines())


@pytest.mark.skipif(not Path("/dev/full").exists(), reason="needs /dev/full (Linux)")
@pytest.mark.parametrize("args", [AXIS, ("axis", SAMPLE, SAMPLE, *AXIS[2:]),
                                  ("info", SAMPLE, "--json")])
def test_a_full_standard_output_is_named(args):
    # "imucal: error: No space left on device": the one line named no file
    with open("/dev/full", "w") as full:
        run = subprocess.run([sys.executable, "-m", "imucal", *map(str, args)], stdout=full,
                             stderr=subprocess.PIPE, timeout=120)
    assert run.returncode == 2
    assert run.stderr.decode() == ("imucal: error: standard output: cannot write (No space "
                                   "left on device)\n")


@pytest.mark.skipif(not Path("/dev/full").exists(), reason="needs /dev/full (Linux)")
@pytest.mark.parametrize(("args", "documents", "code"), [
    (AXIS[:-1], 1, 0), (("axis", SAMPLE, SAMPLE, *AXIS[2:-1]), 2, 0),
    (("axis", "missing.h5"), 0, 2)])
def test_a_full_standard_error_keeps_the_result_and_the_status(args, documents, code):
    # the first message's ENOSPC left the command and main's error line failed again:
    # exit 1 ("not identifiable") with nothing written (a new-user trial)
    with open("/dev/full", "w") as full:
        run = _process(*args, stderr=full)
    assert run.returncode == code
    text = run.stdout.decode()
    docs = ([json.loads(text)] if documents == 1 else
            [json.loads(line)["result"] for line in text.splitlines()])
    assert [d["command"] for d in docs] == ["axis"] * documents


@pytest.mark.skipif(not Path("/dev/full").exists(), reason="needs /dev/full (Linux)")
def test_a_study_with_a_full_standard_error_keeps_its_lines(knee_calibration, tmp_path):
    # the study's messages (an angles warning, an error line) bypassed errors.say: no
    # line and exit 2 with 2>/dev/full, also with -q (a review)
    cal = knee_calibration
    walk = SAMPLE.with_name("walking.h5")
    with open("/dev/full", "w") as full:
        run = _process("angles", walk, tmp_path / "none.h5", "-c", cal, "--tables",
                       tmp_path / "t", stderr=full)
    lines = [json.loads(line) for line in run.stdout.splitlines()]
    assert run.returncode == 2 and [o["exit_code"] for o in lines] == [0, 2]


def test_every_line_break_python_knows_is_escaped_in_a_message():
    # only \n and \r were: a name with \v, \x1c or \u2028 still split str.splitlines()
    from imucal.errors import as_line

    name = "a\nb\rc\vd\x0ce\x1cf\x1dg\x1eh\x85i\u2028j\u2029k.h5"
    assert len(as_line(f"imucal axis: {name}: thigh -> shank").splitlines()) == 1
    assert as_line("a\nb\u2028c") == "a\\nb\\u2028c"
