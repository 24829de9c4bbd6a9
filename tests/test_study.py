"""Whole studies: several RECs, --jobs, JSON Lines, exit status, progress bar (imucal.study)."""

from __future__ import annotations

import json
import os
import pty
import subprocess
import sys
from pathlib import Path

import pytest

from imucal import study as study_module
from imucal.runner import Job
from imucal.settings import AxisSettings
from imucal.simulate import simulate
from imucal.writers import save_recording

# Few restarts: these tests check the plumbing, test_cli.py checks the estimates.
FAST = ("--restarts", "10", "--seed", "1")


def imucal(*args, **kwargs):
    return subprocess.run([sys.executable, "-m", "imucal", *map(str, args)],
                          capture_output=True, timeout=120, **kwargs)


def lines(text: bytes) -> list[dict]:
    return [json.loads(line) for line in text.decode().splitlines()]


@pytest.fixture(scope="module")
def study(tmp_path_factory):
    """Three short recordings (10 s, as `imucal simulate --duration 10`), a static one and
    a file that is not a recording."""
    folder = tmp_path_factory.mktemp("study")
    files = {}
    for name, seed, motion in (("a", 1, "circling"), ("b", 2, "walking"), ("c", 3, "circling"),
                               ("still", 4, "static")):
        recording, _ = simulate(seed=seed, rate=100.0, duration=10.0, snr=100.0, motion=motion)
        files[name] = folder / f"{name}.h5"
        save_recording(recording, files[name])
    files["bad"] = folder / "bad.h5"
    files["bad"].write_text("not a recording\n")
    return files


@pytest.fixture(scope="module")
def runs(study):
    """The same study with --jobs 1 and --jobs 2, a bad file in the middle."""
    order = [study[k] for k in ("a", "bad", "b", "c")]
    return {jobs: imucal("axis", *order, *FAST, "--jobs", jobs) for jobs in (1, 2)}


def test_lines_in_input_order_with_file_names(runs, study):
    run = runs[2]
    out = lines(run.stdout)
    assert [o["file"] for o in out] == [str(study[k]) for k in ("a", "bad", "b", "c")]
    assert all(list(o) == ["file", "exit_code", "error", "warnings", "result"] for o in out)
    # One compact object per line, each result the document `imucal axis REC` prints.
    assert all(line.startswith(b'{"file":') for line in run.stdout.splitlines())
    for o in (out[0], out[2], out[3]):
        assert o["exit_code"] == 0 and o["error"] is None
        assert o["result"]["command"] == "axis" and o["result"]["input"]["path"] == o["file"]
        assert len(o["result"]["j1"]) == 3


def test_bad_file_gets_an_error_line_and_exit_2(runs, study):
    run = runs[2]
    assert run.returncode == 2
    bad = lines(run.stdout)[1]
    assert bad["exit_code"] == 2 and bad["result"] is None
    assert bad["error"].startswith(str(study["bad"])) and "HDF5" in bad["error"]
    err = run.stderr.decode()
    assert f"imucal: error: {study['bad']}" in err
    assert "4 recordings" in err and "1 failed" in err


def test_jobs_2_gives_the_same_lines_as_jobs_1(runs):
    assert runs[1].returncode == runs[2].returncode == 2
    assert lines(runs[1].stdout) == lines(runs[2].stdout)


def test_result_equals_the_single_file_document(runs, study):
    single = imucal("axis", study["a"], *FAST)
    assert single.returncode == 0, single.stderr
    assert lines(runs[2].stdout)[0]["result"] == json.loads(single.stdout)


def test_no_progress_bar_when_stderr_is_not_a_terminal(runs):
    for run in runs.values():
        assert b"\r" not in run.stderr and b"[#" not in run.stderr and b"[." not in run.stderr


def test_progress_bar_when_stderr_is_a_terminal(study):
    leader, follower = pty.openpty()
    try:
        run = subprocess.run(
            [sys.executable, "-m", "imucal", "axis", study["a"], study["c"], *FAST],
            stdout=subprocess.PIPE, stderr=follower, timeout=120,
        )
        os.close(follower)
        follower = None
        shown = b""
        while True:
            try:
                chunk = os.read(leader, 65536)
            except OSError:  # Linux: EIO once the terminal's other end is closed
                break
            if not chunk:
                break
            shown += chunk
    finally:
        if follower is not None:
            os.close(follower)
        os.close(leader)
    assert run.returncode == 0
    assert b"2/2 recordings" in shown and b"\r" in shown
    assert len(lines(run.stdout)) == 2  # the bar never reaches stdout


def test_not_identifiable_is_exit_1_unless_force(study):
    run = imucal("axis", study["a"], study["still"], *FAST, "--jobs", 2)
    assert run.returncode == 1
    ok, still = lines(run.stdout)
    assert ok["exit_code"] == 0
    assert still["exit_code"] == 1 and still["result"] is None
    assert "cannot identify" in still["error"] and "barely rotate" in still["error"]
    # not "1 failed": the data could not tell, nothing broke (a new-user trial)
    assert run.stderr.decode().splitlines()[-1].endswith(
        f": 1 not identifiable ({study['still']}), exit status 1")
    both = imucal("axis", study["still"], study["bad"], *FAST)
    assert both.stderr.decode().splitlines()[-1].endswith(
        f": 1 not identifiable ({study['still']}), 1 failed ({study['bad']}), exit status 2")
    forced = imucal("axis", study["a"], study["still"], *FAST, "--force")
    assert forced.returncode == 0
    still = lines(forced.stdout)[1]
    assert still["exit_code"] == 0 and still["result"]["quality"]["verdict"] == "not identifiable"


def test_most_severe_code_wins(study):
    run = imucal("axis", study["still"], study["bad"], *FAST, "-q")
    assert run.returncode == 2
    assert [o["exit_code"] for o in lines(run.stdout)] == [1, 2]
    assert b"recordings in" not in run.stderr  # -q: no summary, errors still shown
    assert b"imucal: error:" in run.stderr


def test_position_study_to_out_file(study, tmp_path):
    out = tmp_path / "ankles.jsonl"
    run = imucal("position", study["a"], study["b"], *FAST, "--jobs", 2, "--out", out)
    assert run.returncode == 0, run.stderr
    assert run.stdout == b""
    got = lines(out.read_bytes())
    assert [o["file"] for o in got] == [str(study["a"]), str(study["b"])]
    assert all(len(o["result"]["o1"]) == 3 for o in got)
    assert [p.name for p in tmp_path.iterdir()] == ["ankles.jsonl"]  # no temporary left


@pytest.mark.parametrize("args, phrase", [
    (("--plot", "x.png"), b"--plot draws one recording"),
    (("-",), b"only REC"),
])
def test_study_refuses_plot_and_stdin(study, tmp_path, args, phrase):
    run = imucal("axis", study["a"], study["b"], *args, cwd=tmp_path)
    assert run.returncode == 2 and run.stdout == b""
    assert phrase in run.stderr
    assert list(tmp_path.iterdir()) == []


def test_plot_with_one_rec_and_jobs_names_jobs_not_several_recs(study, tmp_path):
    run = imucal("axis", study["a"], "--jobs", 1, "--plot", "k.png", cwd=tmp_path)
    assert run.returncode == 2 and run.stdout == b""
    assert run.stderr == (b"imucal: error: --plot draws one recording outside a study: leave "
                          b"out --jobs and --scheduler to draw it\n")
    assert list(tmp_path.iterdir()) == []


def test_a_lone_stdin_is_a_study_of_one_and_no_cluster_reads_it(study, tmp_path):
    # "- (standard input) can only be read as the only REC, not in a list of recordings"
    # was said of a lone - with --jobs: a pipeline adding --jobs 1 for JSON Lines broke
    # once its input was piped (a new-user trial)
    csv = subprocess.run([sys.executable, "-m", "imucal", "convert", study["a"], "-"],
                         capture_output=True, timeout=120).stdout
    run = imucal("axis", "-", *FAST, "--jobs", 2, "-q", input=csv, cwd=tmp_path)
    assert run.returncode == 0 and run.stderr == b"", run.stderr
    (line,) = lines(run.stdout)
    assert line["file"] == "-" and line["exit_code"] == 0
    assert line["result"]["input"]["path"] == "<stdin>"
    # a cluster's workers do not see this command's standard input: refused, truly
    run = imucal("axis", "-", *FAST, "--scheduler", "tcp://127.0.0.1:1", input=csv,
                 cwd=tmp_path)
    assert run.returncode == 2 and run.stdout == b""
    assert run.stderr == (b"imucal: error: - (standard input) cannot be read on a cluster; "
                          b"save the recording to a file the workers see\n")


def test_a_folder_named_imucal_where_the_study_runs_changes_nothing(study, tmp_path):
    # the workers' fresh interpreters put the current folder first on sys.path, so an
    # "imucal" folder there (standing in the parent of a checkout) shadowed the package
    # in every worker: exit 3 for every file. The console script, as a user runs it
    # ("python -m" would put the folder first in this process too).
    (tmp_path / "imucal").mkdir()
    env = {k: v for k, v in os.environ.items() if k != "PYTHONSAFEPATH"}
    run = subprocess.run([Path(sys.executable).with_name("imucal"), "axis", study["a"],
                          study["b"], *FAST, "--jobs", "2"], cwd=tmp_path, env=env,
                         capture_output=True, timeout=120)
    assert run.returncode == 0, run.stderr
    assert [o["exit_code"] for o in lines(run.stdout)] == [0, 0]


def test_single_rec_keeps_pretty_json_and_with_jobs_is_a_study(study, tmp_path):
    run = imucal("axis", study["a"], *FAST)
    assert run.returncode == 0
    assert run.stdout.startswith(b"{\n  ")
    # --jobs says "a study": a glob that matched one file gave one pretty document, which
    # the study's jq line read as nothing, exit 0 (a new-user trial)
    for command in ("axis", "calibrate"):
        out = tmp_path / f"{command}.jsonl"
        run = imucal(command, study["a"], *FAST, "--jobs", 2, "--out", out, "--force")
        assert run.returncode == 0 and run.stdout == b""
        (line,) = lines(out.read_bytes())
        assert line["file"] == str(study["a"]) and line["exit_code"] == 0
        assert line["result"]["settings" if command == "axis" else "joints"]


JOB = Job("axis", ("thigh", "shank"), AxisSettings(restarts=10, seed=1))


def _fake_work(task):
    index, _, file = task
    if Path(file).name == "crash":
        os._exit(1)  # as a segfault or the out-of-memory killer would end the worker
    return study_module.entry(index, file, 0, None, {"ok": True}, [])


@pytest.mark.filterwarnings("ignore::DeprecationWarning")  # fork in a threaded pytest
def test_a_dying_worker_fails_only_its_recording(monkeypatch):
    # fork: the workers inherit the patched function, and no recording is computed
    monkeypatch.setattr(study_module, "work", _fake_work)
    files = ["a", "b", "crash", "c", "d"]
    outcomes = list(study_module.process_recordings(JOB, files, jobs=2, start_method="fork"))
    assert [o.file for o in outcomes] == files
    assert [o.exit_code for o in outcomes] == [0, 0, study_module.INTERNAL_ERROR, 0, 0]
    assert "worker process died" in outcomes[2].error


def test_a_study_from_python_leaves_the_environment_as_it_was(study, monkeypatch):
    # the workers start with PYTHONSAFEPATH (see the test above); left set, the caller's
    # later Python subprocesses lost their script's folder on sys.path
    monkeypatch.delenv("PYTHONSAFEPATH", raising=False)
    outcomes = list(study_module.process_recordings(JOB, [str(study["a"]), str(study["b"])],
                                                    jobs=2, start_method="forkserver"))
    assert [o.exit_code for o in outcomes] == [0, 0]
    assert "PYTHONSAFEPATH" not in os.environ


def test_resolve_jobs():
    assert study_module.resolve_jobs(4, 2) == 2
    assert study_module.resolve_jobs(1, 10) == 1
    assert study_module.resolve_jobs(0, 1000) >= 1
    with pytest.raises(study_module.InputError):
        study_module.resolve_jobs(-1, 3)


def _preloading(pid: int) -> bool:
    """Whether a child of ``pid`` is a fork server that has loaded numpy, the first of
    the workers' modules it preloads (scipy and imucal take most of a second more);
    Linux /proc."""
    for entry in Path("/proc").iterdir():
        try:
            # the name may hold spaces and parentheses: the fields after its ')' count
            fields = (entry / "stat").read_text().rsplit(")", 1)[1].split()
            if not entry.name.isdigit() or int(fields[1]) != pid:
                continue
            if b"multiprocessing.forkserver" not in (entry / "cmdline").read_bytes():
                continue
            return "numpy" in (entry / "maps").read_text()
        except (OSError, IndexError, ValueError):
            continue  # not a process, or it ended meanwhile
    return False


@pytest.mark.parametrize("when", ["fork server starting", "workers running"])
def test_ctrl_c_in_a_study_exits_130_without_a_traceback(tmp_path, when):
    # Ctrl-C in the first second of `imucal axis a b c --jobs 2` printed the fork
    # server's KeyboardInterrupt traceback (it was importing numpy and scipy for the
    # workers), or the workers'. The terminal signals the whole process group, so does
    # this test; it waits for a moment it can see instead of guessing a delay: the fork
    # server in the middle of its preloading, or the first recording's line written.
    import signal
    import time

    sample = str(Path(__file__).resolve().parents[1] / "sample_data" / "circling.h5")
    out = tmp_path / "knees.jsonl"
    # many recordings: still running, whatever the load, when the signal comes
    proc = subprocess.Popen(
        [sys.executable, "-c", "from imucal.cli import main; main()", "axis",
         *[sample] * 64, "--jobs", "2", "-q"] + (["--out", str(out)] if when !=
                                                  "workers running" else []),
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, start_new_session=True)
    try:
        if when == "workers running":
            first = proc.stdout.readline()
            assert json.loads(first)["exit_code"] == 0
        else:
            deadline = time.monotonic() + 60
            while not _preloading(proc.pid):
                assert proc.poll() is None and time.monotonic() < deadline, \
                    "no fork server seen preloading"
                time.sleep(0.005)
        os.killpg(proc.pid, signal.SIGINT)
        _, err = proc.communicate(timeout=60)
    finally:
        if proc.poll() is None:
            os.killpg(proc.pid, signal.SIGKILL)
    assert proc.returncode == 130, err
    assert b"Traceback" not in err, err.decode()
    assert err in (b"", b"imucal: interrupted\n")
    assert not out.exists()  # --out: complete or not at all


def _in_session(sid: int) -> list[int]:
    """Processes of session ``sid`` still alive (not zombies); Linux /proc."""
    alive = []
    for entry in Path("/proc").iterdir():
        try:
            fields = (entry / "stat").read_text().rsplit(")", 1)[1].split()
            if entry.name.isdigit() and int(fields[3]) == sid and fields[0] != "Z":
                alive.append(int(entry.name))
        except (OSError, IndexError, ValueError):
            continue
    return alive


def _children(pid: int) -> int:
    try:
        return len((Path("/proc") / str(pid) / "task" / str(pid) / "children")
                   .read_text().split())
    except OSError:
        return 0


@pytest.mark.parametrize("signals", [("TERM",), ("INT", "INT")])
def test_a_study_ended_by_a_signal_stops_its_workers_and_leaves_no_file(tmp_path, signals):
    # SIGTERM to the command alone ended it on the spot: its --out's temporary file
    # stayed beside the target, and the workers went on with their recordings. A second
    # Ctrl-C during the clean-up could end it with Python's default status (-2).
    import signal
    import time

    sample = str(Path(__file__).resolve().parents[1] / "sample_data" / "circling.h5")
    out = tmp_path / "knees.jsonl"
    proc = subprocess.Popen(
        [sys.executable, "-m", "imucal", "axis", *[sample] * 64, "--jobs", "2", "-q",
         "--out", str(out)],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, start_new_session=True)
    try:
        deadline = time.monotonic() + 60
        # the temporary file exists and the workers run (the fork server's, or forked)
        while not (list(tmp_path.iterdir()) and _children(proc.pid) >= 1
                   and len(_in_session(proc.pid)) >= 3):
            assert proc.poll() is None and time.monotonic() < deadline, "no workers seen"
            time.sleep(0.01)
        time.sleep(0.3)
        for name in signals:
            if name == "TERM":
                os.kill(proc.pid, signal.SIGTERM)  # the command alone, as `kill` does
            else:
                os.killpg(proc.pid, signal.SIGINT)
            time.sleep(0.05)
        _, err = proc.communicate(timeout=60)
        deadline = time.monotonic() + 10
        while _in_session(proc.pid) and time.monotonic() < deadline:
            time.sleep(0.05)
        left = _in_session(proc.pid)
    finally:
        os.killpg(proc.pid, signal.SIGKILL) if proc.poll() is None else None
        for pid in _in_session(proc.pid):
            os.kill(pid, signal.SIGKILL)
    expected = (143, b"imucal: terminated (SIGTERM)\n") if signals == ("TERM",) else \
        (130, b"imucal: interrupted\n")
    assert (proc.returncode, err) == expected, err.decode()
    assert left == [], "worker processes outlived the command"
    assert list(tmp_path.iterdir()) == []  # --out: complete or not at all


def test_a_study_killed_outright_leaves_no_process_behind(tmp_path):
    # SIGKILL (the out-of-memory killer, a batch system's hard limit) of the command:
    # its workers, the fork server and the resource tracker stayed for good, idle, about
    # 375 MB (a study fuzz); the workers now watch the command and end without it
    import signal
    import time

    sample = str(Path(__file__).resolve().parents[1] / "sample_data" / "circling.h5")
    proc = subprocess.Popen(
        [sys.executable, "-m", "imucal", "axis", *[sample] * 64, "--jobs", "2", "-q",
         "--out", str(tmp_path / "knees.jsonl")],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, start_new_session=True)
    try:
        deadline = time.monotonic() + 60
        while not (_children(proc.pid) >= 1 and len(_in_session(proc.pid)) >= 3):
            assert proc.poll() is None and time.monotonic() < deadline, "no workers seen"
            time.sleep(0.01)
        time.sleep(0.3)
        os.kill(proc.pid, signal.SIGKILL)
        proc.communicate(timeout=60)
        deadline = time.monotonic() + 15
        while _in_session(proc.pid) and time.monotonic() < deadline:
            time.sleep(0.1)
        left = _in_session(proc.pid)
    finally:
        for pid in _in_session(proc.pid):
            os.kill(pid, signal.SIGKILL)
    assert left == [], "processes of the study outlived its command"


def test_a_signal_while_the_output_blocks_stops_the_workers_at_once():
    # Ctrl-C while the study waited for a reader (a pager, a stalled pipe) printed
    # "imucal: interrupted" at once but ended 7-13 s later: the workers went on with
    # their recordings, as the interruption came outside the loop that stops them
    import array
    import fcntl
    import signal
    import termios
    import time

    sample = str(Path(__file__).resolve().parents[1] / "sample_data" / "circling.h5")
    # slow recordings (about a second each) and a reader that never reads: after a
    # pipe's buffer of lines the command blocks in its write
    proc = subprocess.Popen(
        [sys.executable, "-m", "imucal", "axis", *[sample] * 16, "--jobs", "2",
         "--restarts", "1500", "--seed", "1", "-q"],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, start_new_session=True)
    try:
        deadline = time.monotonic() + 120
        # blocked once the pipe is full (Linux: F_GETPIPE_SZ gives its size)
        fd = proc.stdout.fileno()
        capacity = fcntl.fcntl(fd, 1032)
        waiting = array.array("i", [0])
        while fcntl.ioctl(fd, termios.FIONREAD, waiting) or waiting[0] < capacity:
            assert proc.poll() is None and time.monotonic() < deadline, "never blocked"
            time.sleep(0.02)
        time.sleep(0.2)  # (in its write)
        started = time.monotonic()
        os.kill(proc.pid, signal.SIGINT)  # the command alone
        while proc.poll() is None and time.monotonic() < started + 60:
            time.sleep(0.02)
        took = time.monotonic() - started
        err = proc.stderr.read()
    finally:
        if proc.poll() is None:
            os.killpg(proc.pid, signal.SIGKILL)
        for pid in _in_session(proc.pid):
            os.kill(pid, signal.SIGKILL)
    assert proc.returncode == 130 and err == b"imucal: interrupted\n", err.decode()
    assert took < 2.0, f"ended {took:.1f} s after the signal"


def test_the_summary_names_a_file_given_many_times_once():
    # "55 failed (x.h5, x.h5, x.h5 and 52 more)"
    assert study_module._short(["x.h5"] * 55) == "x.h5"
    assert study_module._short(["a", "b", "a", "c", "d"]) == "a, b, c and 1 more"


def _sleep_a_while():
    import time

    time.sleep(60)


@pytest.mark.filterwarnings("ignore::DeprecationWarning")  # fork in a threaded pytest
def test_a_study_left_early_from_python_stops_only_its_own_workers(study):
    # leaving a process_recordings loop early (break, or the generator collected) sent
    # Ctrl-C to every process started since the pool, the caller's own too
    import multiprocessing
    import time

    job = Job("axis", ("thigh", "shank"), AxisSettings(restarts=300, seed=1))
    entries = study_module.process_recordings(job, [str(study["a"])] * 8, jobs=2)
    assert next(entries).exit_code == 0
    own = multiprocessing.get_context("spawn").Process(target=_sleep_a_while)
    own.start()
    try:
        started = time.monotonic()
        entries.close()
        assert time.monotonic() - started < 10
        time.sleep(0.5)
        assert own.is_alive() and own.exitcode is None
    finally:
        own.kill()
        own.join()


def test_a_library_study_leaves_the_callers_environment_and_its_workers_one_thread(
        tmp_path):
    # the thread variables were set in the caller's environment for good (jobs=1 too),
    # then only during the study, and still leaked through the fork server that outlives
    # it into the caller's later subprocesses (an independent review)
    script = """
import multiprocessing as mp, os, sys
import numpy
from threadpoolctl import threadpool_info
from imucal import study
from imucal.runner import Job
from imucal.settings import AxisSettings

def env(q):
    q.put(os.environ.get("OPENBLAS_NUM_THREADS"))

def worker_threads(q):
    study._one_thread_here()
    q.put(sorted({i["num_threads"] for i in threadpool_info() if i["user_api"] == "blas"}))

if __name__ == "__main__":
    job = Job("axis", ("thigh", "shank"), AxisSettings(restarts=5, seed=1))
    for jobs in (1, 2):
        codes = [e.exit_code for e in study.process_recordings(job, [sys.argv[1]] * 2,
                                                                 jobs=jobs)]
        print(codes, os.environ.get("OPENBLAS_NUM_THREADS"))
    ctx = mp.get_context("forkserver")
    for target in (env, worker_threads):
        q = ctx.Queue()
        p = ctx.Process(target=target, args=(q,))
        p.start()
        print(q.get(timeout=60))
        p.join()
"""
    sample = str(Path(__file__).resolve().parents[1] / "sample_data" / "circling.h5")
    env = {k: v for k, v in os.environ.items() if k not in study_module.THREAD_VARIABLES}
    # a file, not -c: the fork server's children import the functions from it
    (tmp_path / "caller.py").write_text(script)
    run = subprocess.run([sys.executable, str(tmp_path / "caller.py"), sample],
                         capture_output=True, text=True, env=env, timeout=120)
    assert run.returncode == 0, run.stderr
    assert run.stdout.splitlines() == ["[0, 0] None", "[0, 0] None", "None", "[1]"]
