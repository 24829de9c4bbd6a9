"""Studies on a Dask cluster: ``imucal axis A.h5 B.h5 ... --scheduler tcp://host:8786``.

The recordings go to the workers of an existing Dask cluster (``dask scheduler`` on one
machine, ``dask worker tcp://host:8786`` on each machine that computes); each worker
runs :func:`imucal.study.work`, the function a local ``--jobs`` study runs, and the
entries come back here, where they are written in input order exactly as a local study
writes them. Workers read the recordings by the paths given, so every worker must see
the files under the same paths (a shared file system), and the workers and the scheduler
need imucal installed (Dask unpickles the tasks on the scheduler too).

Dask is optional (``pip install -e '.[dask]'`` from the checkout); this module imports it only
when a study asks for a cluster.
"""

from __future__ import annotations

import contextlib
import logging
import os
import queue
import re
import threading
import time
from collections.abc import Callable, Iterator, Sequence

from .errors import INTERNAL_ERROR, InputError
from .runner import Job

__all__ = ["Cluster", "connect", "INSTALL_HINT"]

#: How to install what ``--scheduler`` needs.
#: imucal-joints is not on PyPI: the extra installs from the checkout
INSTALL_HINT = "pip install -e '.[dask]' in imucal's checkout"
#: Seconds to wait for the scheduler to answer and for its first worker.
CONNECT_TIMEOUT_S = 10.0
#: Extra time for the handshake after Dask's own connect timeout, s.
HANDSHAKE_GRACE_S = 5.0
#: A study stops when its cluster has had no worker for this long, s: every worker died
#: or was stopped, and none came back (a nanny restarts a crashed one within seconds).
NO_WORKER_TIMEOUT_S = 60.0
#: How often a study looks at its cluster while it waits for results, s.
POLL_S = 1.0


class Cluster:
    """A connected Dask client that runs study entries (see :func:`connect`)."""

    def __init__(self, client, address: str = "", log_levels: dict | None = None):
        self.client = client
        self.address = address
        self._log_levels = log_levels or {}

    @property
    def workers(self) -> int:
        """Number of workers the scheduler knows now."""
        return len(self.client.scheduler_info().get("workers", {}))

    def process(self, job: Job, files: Sequence[str],
                on_done: Callable[[int, int], None] | None = None) -> Iterator:
        """Run ``job`` on every file on the cluster; yield the entries in input order.

        ``on_done(done, failed)`` is called with the running counts as results arrive.

        Yields
        ------
        imucal.study.Entry
            One per file, in the order of ``files``, each as soon as it and all before it
            are done; a recording whose task failed on the cluster (a worker that died
            repeatedly, a worker without imucal) gets an entry with exit code 3.

        Raises
        ------
        InputError
            The connection to the scheduler was lost, or the cluster has had no worker
            for :data:`NO_WORKER_TIMEOUT_S`: the study stops (the entries yielded so far
            stand). Before, each unfinished recording got an exit-3 entry ("a bug in
            imucal"), or the study waited for ever.

        Examples
        --------
        >>> from imucal.cluster import connect
        >>> from imucal.runner import Job
        >>> from imucal.settings import AxisSettings
        >>> job = Job("axis", ("thigh", "shank"), AxisSettings(seed=1))
        >>> cluster = connect("tcp://127.0.0.1:8786")                 # doctest: +SKIP
        >>> [e.exit_code for e in cluster.process(job, ["a.h5"])]     # doctest: +SKIP
        [0]
        """
        from .study import InOrder, entry

        # Relative paths mean the same as here: the workers resolve them against this
        # process's working directory (which they must see under the same path).
        cwd = os.getcwd()
        futures = self.client.map(_work, [(i, job, f) for i, f in enumerate(files)],
                                  cwd=cwd, pure=False)
        index = {future.key: i for i, future in enumerate(futures)}
        order = InOrder(on_done)
        # Done (finished, failed or cancelled) futures arrive here from Dask's thread;
        # waiting on them with a timeout lets the study look at its cluster meanwhile.
        arrived: queue.SimpleQueue = queue.SimpleQueue()
        for future in futures:
            future.add_done_callback(arrived.put)
        unfetched: dict = {}  # key -> future: done, its result not yet here
        fetched: set = set()
        watch = _Watch(self, len(files))
        try:
            while len(fetched) < len(futures):
                with contextlib.suppress(queue.Empty):
                    future = arrived.get(timeout=POLL_S)
                    while True:
                        unfetched.setdefault(future.key, future)
                        future = arrived.get_nowait()
                watch.check(order.done)
                for key, future in list(unfetched.items()):
                    del unfetched[key]
                    if key in fetched:  # (done again after its result was lost)
                        continue
                    i = index[key]
                    try:
                        # bounded: a result lost with its worker is computed again, and
                        # an unbounded wait would never get back to the watch above
                        result = future.result(timeout=POLL_S)
                    except TimeoutError:
                        unfetched[key] = future
                        break
                    except Exception as err:  # fails one recording, not the study
                        watch.check(order.done, err)
                        # One line, as every error: Dask's messages run over several.
                        first = (str(err).strip().splitlines() or [""])[0]
                        result = entry(i, files[i], INTERNAL_ERROR,
                                       f"{files[i]}: the Dask task failed: "
                                       f"{type(err).__name__}: {first}", None, [])
                    fetched.add(key)
                    order.add(result)
                order.report()
                yield from order.release()
        finally:
            with contextlib.suppress(Exception):  # (a lost scheduler cannot cancel)
                self.client.cancel(futures)

    def close(self) -> None:
        """Disconnect (the cluster itself keeps running), and give Dask's loggers back
        their levels."""
        try:
            with contextlib.suppress(Exception):
                self.client.close(timeout=CONNECT_TIMEOUT_S)
        finally:
            for name, level in self._log_levels.items():
                logging.getLogger(name).setLevel(level)


class _Watch:
    """Whether a study's cluster can still finish it (see :meth:`Cluster.process`)."""

    def __init__(self, cluster: Cluster, total: int):
        self.cluster, self.total = cluster, total
        self.alone_since: float | None = None
        self.counted = -float("inf")

    def check(self, done: int, err: BaseException | None = None) -> None:
        """InputError if the scheduler is lost (its status, a task cancelled for that
        reason, or no answer within :data:`CONNECT_TIMEOUT_S`) or no worker has been
        there for :data:`NO_WORKER_TIMEOUT_S`."""
        lost = (f"--scheduler {self.cluster.address}: lost the connection to the Dask "
                f"scheduler after {done} of {self.total} recordings; the study stopped")
        if (self.cluster.client.status != "running"
                or "scheduler-connection-lost" in str(err or "")):
            raise InputError(lost)
        now = time.monotonic()
        if now - self.counted < POLL_S:  # (counting asks the scheduler about every worker)
            return
        self.counted = now
        workers = _within(lambda: self.cluster.workers, CONNECT_TIMEOUT_S)
        if workers is None:  # it went away between the two looks, or froze
            raise InputError(lost)
        if workers:
            self.alone_since = None
            return
        if self.alone_since is None:
            self.alone_since = now
        elif now - self.alone_since >= NO_WORKER_TIMEOUT_S:
            raise InputError(f"--scheduler {self.cluster.address}: the cluster has had no "
                             f"worker for {NO_WORKER_TIMEOUT_S:g} s (they stopped or died) "
                             f"after {done} of {self.total} recordings; the study stopped "
                             f"(start workers with 'dask worker {self.cluster.address}')")


def _within(ask: Callable[[], int], timeout: float) -> int | None:
    """``ask()`` on a helper thread; None if it failed or took longer than ``timeout`` s
    (a call to a scheduler that froze, SIGSTOP or a machine that hangs, never returns)."""
    box: dict = {}

    def run():
        with contextlib.suppress(Exception):
            box["value"] = ask()

    thread = threading.Thread(target=run, daemon=True)
    thread.start()
    thread.join(timeout)
    return box.get("value")


def check_address(address: str) -> str:
    """``address`` checked for the form of a scheduler's address (HOST:PORT with an
    optional scheme) before anything is read or connected.

    Returns
    -------
    str
        ``address`` unchanged.

    Raises
    ------
    InputError
        It has not that form.

    Examples
    --------
    >>> from imucal.cluster import check_address
    >>> check_address("tcp://127.0.0.1:8786")
    'tcp://127.0.0.1:8786'
    """
    if not re.fullmatch(r"(\w+://)?[^\s/]+:\d+", address):
        raise InputError(f"--scheduler {address}: not a scheduler address; expected "
                         "tcp://HOST:PORT (dask scheduler prints it)")
    return address


def connect(address: str, timeout: float = CONNECT_TIMEOUT_S) -> Cluster:
    """Connect to the Dask scheduler at ``address`` and wait for a worker.

    Returns
    -------
    Cluster
        Ready to :meth:`~Cluster.process` a study.

    Raises
    ------
    InputError
        ``address`` is not HOST:PORT with an optional scheme, Dask is not installed
        (the message says how to install it), the scheduler does not answer within
        ``timeout`` s, or it has no worker by then.

    Examples
    --------
    >>> from imucal.cluster import connect
    >>> cluster = connect("tcp://127.0.0.1:8786")                     # doctest: +SKIP
    >>> cluster.workers                                               # doctest: +SKIP
    2
    """
    check_address(address)
    try:
        import distributed
    except ImportError:
        raise InputError(f"--scheduler needs Dask, which is not installed: "
                         f"{INSTALL_HINT}") from None
    try:
        client = _client(distributed, address, timeout)
    except (OSError, TimeoutError, ValueError) as err:
        raise InputError(f"--scheduler {address}: cannot reach the Dask scheduler "
                         f"({type(err).__name__}: {err})") from None
    try:
        client.wait_for_workers(1, timeout=timeout)
    except (OSError, TimeoutError):
        client.close()
        raise InputError(f"--scheduler {address}: the scheduler has no workers (start "
                         f"some with 'dask worker {address}')") from None
    return Cluster(client, address, _quiet_dask())


def _quiet_dask() -> dict:
    """Silence Dask's own log lines (a traceback when the scheduler goes away, "Couldn't
    gather 1 keys, rescheduling" when a worker dies) for the study: imucal says what
    matters in its own one-line messages. Returns the levels to restore."""
    # each of Dask's loggers has its own level and handler (not only the parents')
    names = {"distributed", "tornado"} | {
        name for name in logging.root.manager.loggerDict
        if name.startswith(("distributed.", "tornado."))}
    levels = {}
    for name in names:
        logger = logging.getLogger(name)
        levels[name] = logger.level
        logger.setLevel(logging.CRITICAL + 1)
    return levels


def _client(distributed, address: str, timeout: float):
    """``distributed.Client(address)`` within ``timeout`` s plus a grace period.

    Dask's own timeout covers reaching the port, not the handshake after it: a port
    that accepts and never answers as a scheduler (the dashboard's, 8787, next to the
    scheduler's 8786; any other service) would hang the study forever.
    """
    made: dict = {}

    class Tracked(distributed.Client):
        """A client that is kept track of from its start: one whose start failed would
        otherwise close itself when collected (at exit), waiting 2 x ``timeout`` for a
        scheduler that is not there and printing "Exception ignored ..."."""

        def __init__(self, *args, **kwargs):
            made["partial"] = self
            super().__init__(*args, **kwargs)

    def make():
        try:
            made["client"] = Tracked(address, timeout=timeout, set_as_default=False)
        except Exception as err:  # handed to the caller's thread
            made["error"] = err
            _discard(made.pop("partial", None))

    thread = threading.Thread(target=make, daemon=True)
    thread.start()
    thread.join(timeout + HANDSHAKE_GRACE_S)
    if thread.is_alive():
        raise TimeoutError(f"something answers at {address} but not as a Dask scheduler "
                           f"within {timeout + HANDSHAKE_GRACE_S:g} s (the dashboard's "
                           "port? the scheduler's is usually 8786)")
    if "error" in made:
        err = made["error"]
        if isinstance(err, (OSError, TimeoutError, ValueError)):
            raise err
        # another protocol's bytes read as a Dask message: a frame length of exabytes
        # (MemoryError), or whatever else the parser makes of them
        raise InputError(f"--scheduler {address}: something answers there, but not as a "
                         "Dask scheduler (another service on that port?)") from err
    return made["client"]


def _discard(client) -> None:
    """Mark a client whose start failed as closed, and stop its event loop, so that its
    finaliser has nothing to wait for (private attributes of distributed's Client: any
    failure here only brings the wait back)."""
    if client is None:
        return
    with contextlib.suppress(Exception):
        client.status = "closed"
        client._loop_runner.stop()


def _work(task, cwd: str):
    """:func:`imucal.study.work` in the study's working directory ``cwd``, with one
    BLAS/OpenMP thread, as in a local study.

    A Dask worker loaded numpy long before this task, so the thread variables a local
    study sets before the workers start would come too late here; threadpoolctl limits
    the loaded libraries themselves.
    """
    from threadpoolctl import threadpool_limits

    from .study import entry, work

    index, _, file = task
    before = os.getcwd()
    try:
        os.chdir(cwd)
    except OSError as err:
        return entry(index, file, 2, f"{file}: the study's folder {cwd} is not there on this "
                     f"Dask worker ({err.strerror}); the workers must see the files under "
                     "the same paths", None, [])
    try:
        with threadpool_limits(limits=1):
            return work(task)
    finally:
        os.chdir(before)
