"""How the command line ends on Ctrl-C, SIGTERM and SIGHUP: by an exception, once.

Python's default for SIGTERM and SIGHUP ends the process on the spot, which leaves the
temporary copy of an ``--out`` file (``.knees.jsonl.x1y2.jsonl``) beside the target and
a study's worker processes running on. Raised as exceptions instead, they run the same
clean-up as Ctrl-C: temporary files removed, workers stopped, one stderr line, the
status a shell gives a process ended by that signal. The first such signal wins; later
ones are ignored, so a second Ctrl-C cannot cut the clean-up short.

Only the command line installs this (:func:`raise_on_signals`); a Python caller keeps
its own handlers.
"""

from __future__ import annotations

import signal
import sys
from contextlib import contextmanager

#: The signals the command line ends on; SIGHUP does not exist on Windows.
ENDING = tuple(getattr(signal, name) for name in ("SIGINT", "SIGTERM", "SIGHUP")
               if hasattr(signal, name))


class Terminated(KeyboardInterrupt):
    """SIGTERM or SIGHUP, raised as a KeyboardInterrupt so Ctrl-C's clean-up runs.

    Attributes
    ----------
    signum : int
        The signal's number.
    exit_code : int
        128 + ``signum``, the status a shell reports for a process that signal ended.
    """

    def __init__(self, signum: int):
        super().__init__(signal.Signals(signum).name)
        self.signum = signum
        self.exit_code = 128 + signum


def raise_on_signals() -> None:
    """Make the first of Ctrl-C, SIGTERM and SIGHUP raise (KeyboardInterrupt or
    :class:`Terminated`) and every later one be ignored. Call from the main thread."""
    for signum in ENDING:
        signal.signal(signum, _raise)
    if sys.unraisablehook is not _unraisable:
        _hooks[:] = [sys.unraisablehook]
        sys.unraisablehook = _unraisable


# The interruption raised, until its line is written: typer turns one that comes while
# it parses the command line into a silent status 130 (imucal.cli.main asks here).
_unreported: list[KeyboardInterrupt] = []


def _raise(signum, frame) -> None:
    for other in ENDING:
        # a no-op, not SIG_IGN: a signal that arrived before this line runs would then
        # find no handler and print Python's "ignored due to race condition" error
        signal.signal(other, _ignore)
    err = KeyboardInterrupt() if signum == signal.SIGINT else Terminated(signum)
    _unreported.append(err)
    raise err


def _ignore(signum, frame) -> None:
    pass


_hooks: list = []  # the unraisable hook before _unraisable


def _unraisable(unraisable) -> None:
    """An interruption raised inside a finaliser (a weak reference's callback, say) is
    printed as "Exception ignored in ..." and lost, and the command would run on: raise
    it again a millisecond later, by then (almost always) where it can end the command;
    if not, this comes round again."""
    if _unreported and unraisable.exc_value is _unreported[0] and hasattr(signal,
                                                                          "setitimer"):
        signal.signal(signal.SIGALRM, _raise_again)
        signal.setitimer(signal.ITIMER_REAL, 0.001)
        return
    (_hooks[0] if _hooks else sys.__unraisablehook__)(unraisable)


def _raise_again(signum, frame) -> None:
    if _unreported:  # not yet written up by report(): the command is still running
        raise _unreported[0]


def unreported() -> KeyboardInterrupt | None:
    """The interruption :func:`raise_on_signals` raised, if :func:`report` has not
    written its line yet."""
    return _unreported[0] if _unreported else None


@contextmanager
def held():
    """Ctrl-C, SIGTERM and SIGHUP held in this thread (POSIX), delivered when the block
    ends; child processes started meanwhile inherit the block."""
    if not hasattr(signal, "pthread_sigmask"):  # not POSIX: nothing to hold with
        yield
        return
    old = signal.pthread_sigmask(signal.SIG_BLOCK, set(ENDING))
    try:
        yield
    finally:
        signal.pthread_sigmask(signal.SIG_SETMASK, old)


def restore_defaults() -> None:
    """Default SIGTERM in a study's worker process, and let it through.

    Forked from the command, a worker inherits :func:`_raise`, and the ending signals
    held while it started (``imucal.study._parallel``); its pool stops a
    broken worker with SIGTERM, which must end it quietly, not raise inside the pool's
    code. Ctrl-C and SIGHUP, which reach the whole process group, stay held: the command
    passes them on as Ctrl-C, which a worker takes only inside a recording
    (``_pool_work``); workers dying on their own at a hang-up leave multiprocessing's
    resource tracker printing tracebacks.
    """
    signal.signal(signal.SIGTERM, signal.SIG_DFL)
    if hasattr(signal, "pthread_sigmask"):
        signal.pthread_sigmask(signal.SIG_UNBLOCK, {signal.SIGTERM})


def report(err: KeyboardInterrupt) -> int:
    """Write the one stderr line for an interruption; return the exit status."""
    _unreported.clear()
    if isinstance(err, Terminated):
        line, code = f"imucal: terminated ({err})", err.exit_code
    else:
        line, code = "imucal: interrupted", 130
    try:
        sys.stderr.write(line + "\n")
        sys.stderr.flush()
    except (OSError, ValueError):  # the terminal that hung up (SIGHUP) is gone
        pass
    # Python restores the default action of signals with Python handlers as it shuts
    # down; a second Ctrl-C then would end the process with another status.
    for signum in ENDING:
        signal.signal(signum, signal.SIG_IGN)
    return code
