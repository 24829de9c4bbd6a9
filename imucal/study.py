"""Whole studies: ``imucal axis A.h5 B.h5 ... --jobs N`` (and ``position``) in parallel.

Every recording goes through the same runner as ``imucal axis REC`` alone
(:func:`imucal.runner.run`), and its outcome becomes one line of JSON Lines, in input
order::

    {"file": "A.h5", "exit_code": 0, "error": null, "warnings": [], "result": {...}}
    {"file": "B.h5", "exit_code": 2, "error": "B.h5: no such file", "warnings": [], "result": null}

``result`` is the document the single-file command prints (docs/json.md), compact on one
line. ``warnings`` holds the warnings the single-file command prints while loading (about
the two sensors in their window). A failed recording does not stop the others. The exit
status is the most severe (highest) code of all recordings: 0 all succeeded, 1 some were
not identifiable (``--force`` writes them), 2 some had bad input, 3 an internal error or
a worker process that died.

The recordings run in local worker processes (``--jobs``; Python threads would serialise
on the interpreter) or on a Dask cluster (``--scheduler``, :mod:`imucal.cluster`). Each
process is limited to one BLAS/OpenMP thread: with N processes on N cores, more threads
per process would only compete for the same cores. See docs/performance.md.
"""

from __future__ import annotations

import json
import os
import select
import shutil
import signal
import sys
import threading
import time
from collections.abc import Callable, Iterator, Sequence
from contextlib import closing, contextmanager, suppress
from dataclasses import dataclass, replace
from pathlib import Path

from .atomic import check_not_inputs, check_writable, write_atomic, write_stdout
from .errors import INTERNAL_ERROR, InputError, as_line, say
from .runner import Job, run
from .signals import held, restore_defaults

__all__ = ["Entry", "run_study", "process_recordings", "resolve_jobs", "entry"]

#: Environment variables that size the thread pools of the BLAS and OpenMP libraries
#: numpy and scipy may be linked against; they are read once, when the library loads.
BLAS_THREAD_VARIABLES = (
    "OPENBLAS_NUM_THREADS",
    "MKL_NUM_THREADS",
    "BLIS_NUM_THREADS",
    "VECLIB_MAXIMUM_THREADS",
)
THREAD_VARIABLES = ("OMP_NUM_THREADS", *BLAS_THREAD_VARIABLES, "NUMEXPR_NUM_THREADS")
#: Modules every worker needs; imported once before the workers start (fork) or in the
#: fork server, so that no worker pays their import time (about a second) again.
WORKER_MODULES = ("imucal.runner", "imucal.axis", "imucal.position", "imucal.report",
                  "imucal.loaders", "imucal.calibration", "imucal.angles")
#: The progress bar redraws at least this often, s (its clock and estimate keep moving).
PROGRESS_REFRESH_S = 0.5
#: How often a worker process checks that its study's command still runs, s.
PARENT_CHECK_S = 1.0
WARNING_PREFIX = "imucal: warning: "


@dataclass(frozen=True)
class Entry:
    """One recording of a study: its JSON line (no newline) and what to tell the user.

    ``messages`` are the warning lines the single-file command prints while loading.
    """

    index: int
    file: str
    exit_code: int
    error: str | None
    line: str
    messages: tuple[str, ...]


def resolve_jobs(jobs: int, n_files: int) -> int:
    """Worker processes to use: ``jobs`` (0: one per available core), at most one per file.

    Returns
    -------
    int
        ``jobs`` (or the cores) capped at ``n_files``, and at least 1 (also for no
        files).

    Raises
    ------
    InputError
        ``jobs`` is negative.

    Examples
    --------
    >>> from imucal.study import resolve_jobs
    >>> resolve_jobs(4, 2)
    2
    """
    if jobs < 0:
        raise InputError(f"--jobs must be 0 (one per core) or a positive number, got {jobs}")
    if jobs == 0:
        try:
            jobs = len(os.sched_getaffinity(0))
        except AttributeError:  # not on Linux
            jobs = os.cpu_count() or 1
    return max(1, min(jobs, n_files))


def run_study(job: Job, files: Sequence[str], *, out: Path | None = None,
              plot: Path | None = None, jobs: int = 1, scheduler: str | None = None,
              quiet: bool = False) -> int:
    """``imucal axis``/``position``/``calibrate``/``angles`` with several RECs; writes JSON
    Lines, returns the status.

    Lines go to stdout as soon as they are ready in input order, or, with ``out``, into
    that file, which appears complete (atomically) at the end. Errors and warnings go to
    stderr, with a progress bar on a terminal unless ``quiet``.

    Parameters
    ----------
    job
        The options shared by every recording (:class:`imucal.runner.Job`).
    files
        The recordings, in output order.
    out
        ``--out``: the JSON Lines file, or None for stdout.
    plot
        ``--plot``: refused (one figure per file needs one name per file).
    jobs
        Local worker processes (0: one per core); ignored with ``scheduler``.
    scheduler
        Address of a Dask scheduler (``tcp://host:8786``) to run the study on, or None.
    quiet
        No progress bar, warnings or summary on stderr (errors still).

    Returns
    -------
    int
        The exit status: the highest of the recordings' exit codes.

    Raises
    ------
    InputError
        Before anything runs: ``plot`` given, ``-`` among several files or with
        ``scheduler``, a broken sensor map,
        an ``out`` that cannot be written, a cluster that cannot be reached.

    Examples
    --------
    >>> import json, tempfile
    >>> from pathlib import Path
    >>> from imucal.runner import Job
    >>> from imucal.settings import AxisSettings
    >>> from imucal.study import run_study
    >>> job = Job("axis", ("thigh", "shank"), AxisSettings(restarts=10, seed=1))
    >>> with tempfile.TemporaryDirectory() as folder:
    ...     out = Path(folder) / "study.jsonl"
    ...     status = run_study(job, ["sample_data/circling.h5"], out=out, jobs=1,
    ...                        quiet=True)
    ...     lines = [json.loads(line) for line in out.read_text().splitlines()]
    >>> status, [(e["file"], e["exit_code"], e["result"]["quality"]["verdict"])
    ...          for e in lines]
    (0, [('sample_data/circling.h5', 0, 'good')])
    """
    files = [str(f) for f in files]
    job = _checked_study(job, files, out, plot)
    client, jobs, where = _workers(job, files, scheduler, jobs, quiet)
    progress = _Progress(len(files), f"imucal {job.command}",
                         enabled=not quiet and _is_terminal(sys.stderr))
    tally = _Tally(job.command)
    started = time.perf_counter()

    def consume(write_line: Callable[[str], None]) -> None:
        if client is not None:
            entries = client.process(job, files, on_done=progress.done)
        else:
            entries = process_recordings(job, files, jobs=jobs, on_done=progress.done)
        # closed here when writing fails or a signal comes while it blocks: its workers
        # stop now (later, the study waited for their recordings) and a cluster's tasks
        # are cancelled while the client is still open
        with closing(entries):
            for result in entries:
                # the lines carry the warnings: -q leaves them there (150 recordings of a
                # study printed one calibration's warning 150 times: a new-user trial)
                for message in () if quiet else result.messages:
                    progress.message(message)
                if result.error is not None:
                    progress.message(f"imucal: error: {result.error}")
                tally.add(result)
                write_line(result.line + "\n")

    try:
        _write_lines(consume, out)
    finally:
        progress.close()
        if client is not None:
            client.close()
    if not quiet:
        say(tally.summary(f"imucal {job.command}", len(files),
                          time.perf_counter() - started, where, out))
    return tally.worst


def _checked_study(job: Job, files: list[str], out: Path | None, plot: Path | None) -> Job:
    """Refuse what a study cannot do before anything runs; the job with its sensor map
    read once, here: every recording gets its content (a map given as a pipe,
    ``--map <(...)``, was empty for all but the first reader, and a cluster's workers
    need not see the file), and a broken map is one error, not one per recording."""
    if plot is not None:
        if len(files) == 1:  # (it said "with several RECs" of one; a new-user trial)
            raise InputError("--plot draws one recording outside a study: leave out --jobs "
                             "and --scheduler to draw it")
        raise InputError("--plot draws one recording; with several RECs leave it out and run "
                         f"'imucal {job.command} REC --plot FILE.png' for the recordings to "
                         "draw")
    if "-" in files and len(files) > 1:  # (alone it is read here: one file, one process)
        raise InputError("- (standard input) can only be read as the only REC, not in a list "
                         "of recordings")
    sensor_map = job.sensor_map
    if sensor_map is not None:
        from .sensor_map import read_sensor_map

        job = replace(job, sensor_map_pairs=tuple(read_sensor_map(sensor_map).items()))
    if out is not None:
        check_not_inputs([("--out", out)], files + ([sensor_map] if sensor_map else []))
    if job.command in ("angles", "calibrate"):
        job = _checked_folder(job, files, out)
    if out is not None:
        check_writable(out)
    return job


def _checked_folder(job: Job, files: list[str], out: Path | None) -> Job:
    """An angles study's tables folder or a calibrate study's calibrations folder, before
    anything runs: one that can be written, one name per recording (the job gets them,
    :func:`imucal.runner.output_names`), no output (nor ``out``) where a recording, the
    map or the calibration is, and a calibration that reads (a broken one is one error,
    not one per recording). The folder is made by each run, when it writes."""
    from .calibration import load_calibration
    from .runner import check_replaceable, check_table, output_names

    s = job.settings
    angles = job.command == "angles"
    folder, option, suffix = ((s.tables, "--tables", ".csv") if angles
                              else (s.calibrations, "--calibrations", ".json"))
    if folder is None:
        if angles:
            raise InputError("an angles study writes one table per recording: give a tables "
                             "folder (--tables DIR, AnglesSettings(tables=...))")
        return job
    what = "tables" if angles else "calibrations"
    if "-" in files:
        raise InputError(f"{option}: each file is named after its recording's, and - "
                         "(standard input) has none: write its output with --out")
    folder = Path(folder)
    if folder.exists() and not folder.is_dir():
        raise InputError(f"{folder}: the {what} folder is a file")
    names = output_names(files, f"{folder}/{{}}{suffix}")
    outputs = [(option, folder / f"{name}{suffix}") for name in dict.fromkeys(names.values())]
    inputs = files + ([job.sensor_map] if job.sensor_map else [])
    if angles:
        for _, table in outputs:
            check_table(table, inputs, s.calibration)
        inputs = inputs + [s.calibration]
    check_not_inputs(outputs + [("--out", out)], inputs)
    made = next((p for p in (folder, *folder.parents) if p.exists()), Path("."))
    if not made.is_dir():
        raise InputError(f"{folder}: the {what} folder cannot be made: {made} is a file")
    if not os.access(made, os.W_OK | os.X_OK):
        raise InputError(f"{folder}: the {what} folder cannot be written ({made} is not "
                         "writable)")
    # then each name's own folders below it (found after fitting, a review)
    for _, path in outputs:
        near = next(p for p in (path.parent, *path.parent.parents) if p.exists() or
                    p == Path("."))
        if not near.is_dir():
            raise InputError(f"{path}: {option} cannot make its folder: {near} is a file")
    for file, name in names.items():
        check_replaceable(folder / f"{name}{suffix}", option, file)
    if angles:  # (read once: a pipe, -c <(...), gave every run after this one nothing)
        job = replace(job, calibration_read=load_calibration(s.calibration))
    if out is not None and not folder.exists() and Path(out).parent.resolve() == \
            folder.resolve():
        # the lines beside their tables: their file is opened as the study starts, the
        # folder otherwise made with the first table ("folder does not exist", a
        # new-user trial)
        try:
            folder.mkdir(parents=True, exist_ok=True)
        except OSError as err:
            raise InputError(f"{folder}: the {what} folder cannot be made "
                             f"({err.strerror or err})") from None
    return replace(job, output_names=tuple(names.items()))


def _workers(job: Job, files: list[str], scheduler: str | None, jobs: int, quiet: bool):
    """(Dask client or None, local processes, "on/with ..." for the summary)."""
    piped = _descriptor_paths(files)
    if scheduler is not None:
        if "-" in files:
            # (a study of one is still a study: "- ... not in a list of recordings" was
            # said of a lone -; a new-user trial)
            raise InputError("- (standard input) cannot be read on a cluster; save the "
                             "recording to a file the workers see")
        if piped:
            raise InputError(f"{piped[0]}: a pipe of this command "
                             "(<(...), /dev/fd/N) cannot be read on a cluster; save the "
                             "recording to a file the workers see")
        from .cluster import connect

        client = connect(scheduler)
        try:
            workers = client.workers
        except BaseException:  # (the scheduler gone already: the client still closes)
            client.close()
            raise
        return client, jobs, (f"on {workers} Dask worker{'s' if workers != 1 else ''} at "
                              f"{scheduler}")
    jobs = resolve_jobs(jobs, len(files))
    if jobs > 1 and piped:
        # (a worker process has no such descriptor: it read "no such file")
        jobs = 1
        if not quiet:
            say(f"imucal {job.command}: {piped[0]} is a pipe of this "
                "command (<(...), /dev/fd/N): the recordings run in this process")
    return None, jobs, f"with {jobs} process{'es' if jobs > 1 else ''}"


def _write_lines(consume: Callable, out: Path | None) -> None:
    """The lines to stdout as they come, or into ``out``, which appears complete at the
    end (written to a temporary file beside it and renamed) or not at all."""
    if out is None:
        consume(write_stdout)
        return

    def to_file(tmp: Path) -> None:
        with open(tmp, "w", encoding="utf-8") as fh:
            consume(fh.write)

    write_atomic(out, to_file)


class _Tally:
    """The study's exit status (the highest of the recordings') and the recordings that
    did not succeed: ``refused`` (exit 1: the data could not identify the answer, or a
    calibration written with a joint marked) and ``failed`` (2 or 3: bad input, an
    internal error). A calibration written with one knee not identifiable was counted as
    "1 failed" (a new-user trial)."""

    #: How a command's exit 1 reads in the summary.
    REFUSED = {"calibrate": "with a joint not usable",
               "angles": "not measured (does not fit, or a knee not identifiable)"}

    def __init__(self, command: str):
        self.refused_words = self.REFUSED.get(command, "not identifiable")
        self.worst = 0
        self.refused: list[str] = []
        self.failed: list[str] = []

    def add(self, result) -> None:
        if result.error is not None:
            (self.refused if result.exit_code == 1 else self.failed).append(result.file)
        self.worst = max(self.worst, result.exit_code)

    def summary(self, who: str, n: int, elapsed: float, where: str,
                out: Path | None) -> str:
        target = "" if out is None else f" -> {out}"
        parts = [f"{len(names)} {what} ({_short(names)})" for what, names in (
            (self.refused_words, self.refused), ("failed", self.failed)) if names]
        status = ("all succeeded" if not parts else
                  f"{', '.join(parts)}, exit status {self.worst}")
        return (f"{who}: {n} recording{'s' if n != 1 else ''} in {elapsed:.1f} s {where}"
                f"{target}: {status}")


def process_recordings(
    job: Job,
    files: Sequence[str],
    *,
    jobs: int = 1,
    on_done: Callable[[int, int], None] | None = None,
    start_method: str | None = None,
) -> Iterator[Entry]:
    """Run ``job`` on every file in local processes; yield the entries in input order.

    ``jobs`` 1 runs in this process; more use that many worker processes. ``on_done(done,
    failed)`` is called whenever a recording finishes (in any order) and periodically
    while waiting. ``start_method`` forces a multiprocessing start method (default:
    "fork" on Linux when numpy is not yet loaded here, else "forkserver" or "spawn").

    Each worker process runs its BLAS/OpenMP libraries with one thread, unless its
    environment sets :data:`THREAD_VARIABLES` otherwise; this process's environment is
    left as it is.

    Yields
    ------
    Entry
        One per file, in the order of ``files``, each as soon as it and all before it are
        done; a failed recording gets its exit code and error (a worker process that died
        on it: exit code 3), and the others go on.

    Examples
    --------
    >>> from imucal.runner import Job
    >>> from imucal.settings import AxisSettings
    >>> from imucal.study import process_recordings
    >>> job = Job("axis", ("thigh", "shank"), AxisSettings(restarts=10, seed=1))
    >>> entries = list(process_recordings(job, ["sample_data/circling.h5", "missing.h5"]))
    >>> [(e.index, e.exit_code, e.error) for e in entries]
    [(0, 0, None), (1, 2, 'missing.h5: no such file')]
    """
    tasks = [(i, job, f) for i, f in enumerate(files)]
    if jobs <= 1:
        done = failed = 0
        for task in tasks:
            result = work(task)
            done += 1
            failed += result.exit_code != 0
            if on_done is not None:
                on_done(done, failed)
            yield result
        return
    yield from _parallel(tasks, jobs, on_done, start_method)


def _parallel(tasks, jobs, on_done, start_method) -> Iterator[Entry]:
    import multiprocessing
    from concurrent.futures import FIRST_COMPLETED, ProcessPoolExecutor, wait
    from concurrent.futures.process import BrokenProcessPool

    context = _context(start_method)
    order = InOrder(on_done)
    pending = list(tasks)
    workers = jobs
    while pending:
        before = {p.pid for p in multiprocessing.active_children()}
        _start_resource_tracker(context)
        executor = ProcessPoolExecutor(max_workers=min(workers, len(pending)),
                                       mp_context=context, initializer=_worker_start,
                                       initargs=(os.getpid(),))
        broken = False
        futures = []
        try:
            # Ctrl-C, SIGTERM and SIGHUP held while the workers start (by the command line;
            # from Python nothing is held, and each worker blocks Ctrl-C and SIGHUP in
            # restore_defaults): they (and the fork
            # server, whose preloading takes a second) inherit the block and never print
            # a KeyboardInterrupt traceback for the terminal's Ctrl-C to the whole group;
            # a worker lets Ctrl-C through only inside a recording (_pool_work). A signal
            # meanwhile reaches this process once the workers are up, and is passed on
            # below. Stopping earlier is no cure: the fork server would go on to start
            # workers that then fail to attach to this process's gone semaphores.
            with held(), _safe_path():
                try:
                    for task in pending:
                        futures.append(executor.submit(_pool_work, task))
                except BrokenProcessPool:  # a worker died while the rest were being queued
                    broken = True
            waiting = set(futures)
            while waiting:
                finished, waiting = wait(waiting, timeout=PROGRESS_REFRESH_S,
                                         return_when=FIRST_COMPLETED)
                for future in finished:
                    try:
                        order.add(future.result())
                    except BrokenProcessPool:
                        broken = True
                order.report()
                yield from order.release()
        except (KeyboardInterrupt, GeneratorExit):
            # GeneratorExit: the reader stopped (its output failed, or a signal came
            # while it wrote); nobody wants the rest.
            # Ctrl-C, or SIGTERM / SIGHUP turned into one (imucal.signals): a worker that
            # started after a Ctrl-C (held above) has not seen it, nor
            # has any worker a signal sent to this process alone, and the shutdown below
            # would wait for their recordings; SIGINT
            # ends a worker only inside a recording (_pool_work), where that is safe.
            # SIGTERM could cut a result off mid-write and hang the pool.
            for pid in _pool_pids(executor, before):
                with suppress(ProcessLookupError):
                    os.kill(pid, signal.SIGINT)
            raise
        finally:
            executor.shutdown(wait=True, cancel_futures=True)
        pending = [t for t in pending if t[0] not in order.ready and t[0] >= order.next_index]
        if not broken or not pending:
            break
        # A worker died (a crash in a library, or the out-of-memory killer) and took the
        # pool with it; the futures cannot say which recording did it. Rerun the rest one
        # at a time: there the first unfinished recording is the culprit, which gets an
        # error line, and then the rest continue with all workers again.
        if workers > 1:
            workers = 1
            continue
        culprit = pending.pop(0)
        order.add(entry(
            culprit[0], culprit[2], INTERNAL_ERROR,
            f"{culprit[2]}: the worker process died while processing this recording (a "
            "crash, or killed for lack of memory)", None, []))
        order.report()
        yield from order.release()
        workers = jobs
    yield from order.release()


def _pool_pids(executor, before: set[int]) -> list[int]:
    """The pool's worker processes: its own record of them (CPython's
    ``ProcessPoolExecutor._processes``), else the children started since ``before``
    (which, from a notebook, may include processes of the caller's own)."""
    import multiprocessing

    own = getattr(executor, "_processes", None)
    if isinstance(own, dict):
        return list(own)
    return [p.pid for p in multiprocessing.active_children() if p.pid not in before]


def _worker_start(command_pid: int) -> None:
    """A study's worker process: signals as :func:`imucal.signals.restore_defaults` says,
    and a watch that ends it with its command. Without one, workers outlived a command
    killed outright (SIGKILL: the out-of-memory killer, a batch system's hard limit):
    their pool's pipes stay open in the workers themselves, and the fork server and
    resource tracker live as long as they do, all idle for good."""
    restore_defaults()
    _one_thread_here()
    watch = _command_watch(command_pid)
    if watch is not None:
        threading.Thread(target=watch, daemon=True).start()


def _command_watch(pid: int) -> Callable[[], None] | None:
    """A function that waits for process ``pid`` to end, then ends this process.

    Linux: a pidfd, readable once the process has ended (a zombie too, which a script
    that started the command leaves while it waits for the output the workers hold
    open), and bound to that process, not to its number (reused, or in another PID
    namespace's /proc). Elsewhere: its number checked every second. None on Windows,
    where signal 0 is Ctrl-C."""
    if os.name == "nt":
        return None
    try:
        fd = os.pidfd_open(pid)
    except ProcessLookupError:  # gone before this worker started
        os._exit(1)
    except (AttributeError, OSError):  # not Linux 5.3+, or a sandbox refusing it
        return lambda: _poll_command(pid)

    def wait_for_end():
        select.select([fd], [], [])
        os._exit(1)
    return wait_for_end


def _poll_command(pid: int) -> None:
    while True:
        time.sleep(PARENT_CHECK_S)
        try:
            os.kill(pid, 0)
        except ProcessLookupError:
            os._exit(1)
        except OSError:  # there, owned by someone else
            pass


class InOrder:
    """Entries that finish in any order (worker processes, Dask), handed on in input
    order, with the running counts the progress bar shows (``on_done(done, failed)``)."""

    def __init__(self, on_done: Callable[[int, int], None] | None):
        self.ready: dict[int, Entry] = {}
        self.next_index = self.done = self.failed = 0
        self._on_done = on_done

    def add(self, finished: Entry) -> None:
        """One more recording done."""
        self.ready[finished.index] = finished
        self.done += 1
        self.failed += finished.exit_code != 0

    def report(self) -> None:
        """Tell the progress bar."""
        if self._on_done is not None:
            self._on_done(self.done, self.failed)

    def release(self) -> Iterator[Entry]:
        """The entries that are next in input order, as far as they are done.

        Yields
        ------
        Entry
            Each in input order, from the next index on, until the first one not yet
            added (:meth:`add`); each is handed on once.
        """
        while self.next_index in self.ready:
            yield self.ready.pop(self.next_index)
            self.next_index += 1


def _start_resource_tracker(context) -> None:
    """Start multiprocessing's resource tracker (the fork server and spawn need one) with
    the ending signals held, before the pool's queues would start it without.

    It ignores Ctrl-C and SIGTERM but not a hang-up, which reaches the whole process
    group: killed by it, it is started again, told of semaphores it never saw, and
    prints a KeyError traceback for each. Holding SIGHUP at its start keeps it blocked
    there for good. Starting it unblocks SIGINT and SIGTERM in this process afterwards
    (Python 3.11-3.13), so it must come before the pool's start in :func:`_parallel`.
    """
    if context.get_start_method() == "fork" or not hasattr(signal, "pthread_sigmask"):
        return
    from multiprocessing import resource_tracker

    with held():
        resource_tracker.ensure_running()


def _context(start_method):
    """The multiprocessing context for the workers (see :func:`process_recordings`)."""
    import importlib
    import multiprocessing

    methods = multiprocessing.get_all_start_methods()
    if start_method is None:
        # fork is the cheapest start (workers inherit the imports), and safe only while
        # this process runs a single thread: with numpy not yet loaded, it is imported
        # now under the one-thread limit, so no BLAS thread pool exists when forking.
        if sys.platform == "linux" and "fork" in methods and "numpy" not in sys.modules:
            start_method = "fork"
        else:
            start_method = "forkserver" if "forkserver" in methods else "spawn"
    if start_method == "forkserver" and sys.version_info < (3, 11):
        start_method = "spawn"  # see _safe_path: spawn takes this process's sys.path
    context = multiprocessing.get_context(start_method)
    if start_method == "fork":
        with _one_thread_env():  # no BLAS thread pool may exist when forking
            for module in WORKER_MODULES:
                importlib.import_module(module)
    elif start_method == "forkserver":
        context.set_forkserver_preload(list(WORKER_MODULES))
    return context


@contextmanager
def _safe_path():
    """While workers start: the fork server's fresh interpreter ("-c") puts the current
    folder first on sys.path and ignores the parent's path it is given (CPython 3.11), so
    a folder named "imucal" where the user stands (the parent of a checkout) shadowed the
    installed package in every worker: exit 3 for every file (a new-user review). Python
    3.11 leaves the folder out when asked (PYTHONSAFEPATH); the variable is restored
    afterwards, so the caller's later subprocesses keep their usual path."""
    before = os.environ.get("PYTHONSAFEPATH")
    os.environ["PYTHONSAFEPATH"] = "1"
    try:
        yield
    finally:
        if before is None:
            os.environ.pop("PYTHONSAFEPATH", None)
        else:
            os.environ["PYTHONSAFEPATH"] = before


@contextmanager
def _one_thread_env() -> Iterator[None]:
    """The thread variables not already set are 1 for the duration (libraries loaded then
    start with one thread), and removed again after."""
    added = [name for name in THREAD_VARIABLES if name not in os.environ]
    for name in added:
        os.environ[name] = "1"
    try:
        yield
    finally:
        for name in added:
            os.environ.pop(name, None)


def _one_thread_here() -> None:
    """One BLAS/OpenMP thread in this worker process, unless its environment chose
    otherwise: the variables for libraries it loads later, threadpoolctl for those loaded
    (preloaded by the fork server, or inherited). Set in the worker, not in the study's
    process: there they leaked into the caller's later subprocesses, through the fork
    server that outlives the study too (an independent review)."""
    from threadpoolctl import threadpool_limits

    blas_chosen = any(name in os.environ for name in BLAS_THREAD_VARIABLES)
    openmp_chosen = "OMP_NUM_THREADS" in os.environ
    for name in THREAD_VARIABLES:
        os.environ.setdefault(name, "1")
    if not blas_chosen:
        threadpool_limits(1, user_api="blas")
    if not openmp_chosen:
        threadpool_limits(1, user_api="openmp")


def _pool_work(task: tuple[int, Job, str]) -> Entry:
    """:func:`work` in a pool worker, which starts with SIGINT blocked (:func:`_parallel`,
    :func:`imucal.signals.restore_defaults`). Ctrl-C is let through only while a recording
    runs, and then ends the worker at once, without a word: a KeyboardInterrupt could
    surface in a finaliser ("Exception ignored ..."), and between recordings, in the
    pool's own code, as a traceback or a result cut off mid-write that hangs the pool."""
    if not hasattr(signal, "pthread_sigmask"):
        return work(task)
    signal.signal(signal.SIGINT, _end_worker)
    signal.pthread_sigmask(signal.SIG_UNBLOCK, {signal.SIGINT})
    try:
        return work(task)
    finally:
        signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGINT})


def _end_worker(signum, frame) -> None:
    os._exit(128 + signum)


def work(task: tuple[int, Job, str]) -> Entry:
    """One recording of a study, ``(index, job, file)`` -> its :class:`Entry`.

    Runs in a worker process (local or on a Dask worker) or in this one with one job;
    never raises for a failure of the recording.

    Returns
    -------
    Entry
        The recording's JSON line (:func:`entry`) with its exit code, error and the
        loading warnings as stderr lines.
    """
    index, job, file = task
    outcome = run(job, file)
    return entry(index, file, outcome.exit_code, outcome.error, outcome.document,
                 [f"{WARNING_PREFIX}{w}" for w in outcome.warnings])


def entry(index: int, file: str, code: int, error: str | None, doc: dict | None,
          messages: Sequence[str]) -> Entry:
    """The study's line for one recording (see the module docstring for its fields).

    ``messages`` are stderr lines; the line's ``warnings`` are them without the
    ``imucal: warning: `` prefix.

    Returns
    -------
    Entry
        ``index``, ``file``, ``code`` as ``exit_code``, ``error``, the compact JSON line
        (no newline; ``doc`` as its ``result``) and ``messages`` as a tuple.

    Raises
    ------
    ValueError
        ``doc`` holds NaN or Inf (documents are built with :func:`imucal.report.clean`,
        which removes them).

    Examples
    --------
    >>> from imucal.study import entry
    >>> entry(0, "a.h5", 2, "a.h5: no such file", None, []).line
    '{"file":"a.h5","exit_code":2,"error":"a.h5: no such file","warnings":[],"result":null}'
    """
    warnings = [m[len(WARNING_PREFIX):] if m.startswith(WARNING_PREFIX) else m
                for m in messages]
    line = json.dumps({"file": file, "exit_code": code, "error": error, "warnings": warnings,
                       "result": doc}, separators=(",", ":"), allow_nan=False)
    return Entry(index, file, code, error, line, tuple(messages))


class _Progress:
    """A one-line progress bar on a terminal's stderr; does nothing when disabled."""

    def __init__(self, total: int, label: str, *, enabled: bool, stream=None):
        self.total, self.label, self.enabled = total, label, enabled
        self.stream = stream if stream is not None else sys.stderr
        self.says = stream is None  # (say drops what an unwritable stderr cannot take)
        self.started = time.perf_counter()
        self.state = (0, 0)
        self.shown = False

    def done(self, done: int, failed: int) -> None:
        self.state = (done, failed)
        self._draw()

    def message(self, text: str) -> None:
        """Print a line above the bar (the bar is redrawn below it)."""
        self._clear()
        if self.says:
            say(text)
        else:
            print(as_line(text), file=self.stream, flush=True)
        self._draw()

    def close(self) -> None:
        self._clear()

    def _draw(self) -> None:
        if not self.enabled:
            return
        done, failed = self.state
        elapsed = time.perf_counter() - self.started
        left = f", ~{elapsed / done * (self.total - done):.0f} s left" if 0 < done < self.total \
            else ""
        bad = f", {failed} failed" if failed else ""
        text = f" {done}/{self.total} recordings{bad}, {elapsed:.0f} s{left}"
        columns = shutil.get_terminal_size((80, 24)).columns
        width = max(10, min(40, columns - len(self.label) - len(text) - 4))
        filled = int(width * done / max(self.total, 1))
        bar = f"{self.label} [{'#' * filled}{'.' * (width - filled)}]{text}"
        self._write("\r" + bar[: columns - 1] + "\x1b[K")
        self.shown = True

    def _clear(self) -> None:
        if self.enabled and self.shown:
            self._write("\r\x1b[K")
            self.shown = False

    def _write(self, text: str) -> None:
        try:
            self.stream.write(text)
            self.stream.flush()
        except (OSError, ValueError):  # the terminal hung up (SIGHUP): no bar to draw
            self.enabled = False


def _is_terminal(stream) -> bool:
    try:
        return stream.isatty()
    except (AttributeError, ValueError):  # replaced or closed streams
        return False


def _short(names: list[str], limit: int = 3) -> str:
    names = list(dict.fromkeys(names))  # a file given many times is named once
    more = f" and {len(names) - limit} more" if len(names) > limit else ""
    return ", ".join(names[:limit]) + more


def _descriptor_paths(files) -> list[str]:
    """The RECs that name a descriptor of this process (/dev/fd/N, /dev/stdin, <(...)):
    another process cannot open them."""
    from .atomic import descriptor_of

    return [str(f) for f in files if str(f) != "-" and descriptor_of(f) is not None]

