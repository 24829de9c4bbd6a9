"""How the command line ends on Ctrl-C, SIGTERM and SIGHUP: by an exception, once.

Python's default for SIGTERM and SIGHUP ends the process on the spot, which leaves the
temporary copy of an ``--out`` file (``.knees.jsonl.x1y2.jsonl``) beside the target and
a study's worker processes running on. Raised as exceptions instead, they run the same
clean-up as Ctrl-C: temporary files removed, workers stopped, one stderr line, the
status a shell gives a process ended by that signal. The first such signal handled wins
(signals that arrive together, or while held, are handled lowest number first: SIGHUP 1,
SIGINT 2, SIGTERM 15); later ones are ignored, so a second Ctrl-C cannot cut the
clean-up short. A signal the command was started with ignored (``nohup``, a background
job of a script) stays ignored.

Only the command line installs this (:func:`raise_on_signals`); a Python caller keeps
its own handlers, and nothing is held (:func:`held`) for it.
"""

from __future__ import annotations

import signal
import sys
from contextlib import contextmanager

#: The signals the command line ends on; SIGHUP does not exist on Windows.
ENDING = tuple(getattr(signal, name) for name in ("SIGINT", "SIGTERM", "SIGHUP")
               if hasattr(signal, name))


class Interrupted(KeyboardInterrupt):
    """Ctrl-C (SIGINT) as raised by :func:`raise_on_signals`.

    A subclass, not KeyboardInterrupt itself: CPython marks a plain KeyboardInterrupt
    that leaves code run by ``eval`` (``collections.namedtuple`` while a module loads,
    say) as unhandled even when it is caught, and at exit then kills itself with SIGINT
    (status -2 to a parent process) after imucal has written its line and chosen 130.
    """

    signum = signal.SIGINT
    exit_code = 130


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
    """Make the first of Ctrl-C, SIGTERM and SIGHUP raise (:class:`Interrupted` or
    :class:`Terminated`) and every later one be ignored; one that is ignored already
    (``nohup``) stays so. Call from the main thread."""
    if not _installed:
        _previous.update({s: signal.getsignal(s) for s in (*ENDING, *_ALARM)})
    _installed[:] = [s for s in ENDING if _previous[s] is not signal.SIG_IGN]
    for signum in _installed:
        signal.signal(signum, _raise)
    if sys.unraisablehook is not _unraisable:
        _hooks[:] = [sys.unraisablehook]
        sys.unraisablehook = _unraisable


def uninstall() -> None:
    """Undo :func:`raise_on_signals`: the handlers and unraisable hook from before it, for
    a caller that runs the command line in its own process (the test suite)."""
    for signum, handler in _previous.items():
        signal.signal(signum, handler)
    _previous.clear()
    _installed.clear()
    _unreported.clear()
    _pending.clear()
    _armed.clear()
    if sys.unraisablehook is _unraisable and _hooks:
        sys.unraisablehook = _hooks[0]


def finish() -> None:
    """Ignore the ending signals from here on, and disarm a pending re-raise: the
    command is done, and Python restores the signals' default actions while it shuts
    down, so a signal during its exit would end it with another status (SIGALRM's, for a
    re-raise armed then)."""
    for signum in _installed:
        signal.signal(signum, signal.SIG_IGN)
    if _armed:  # only a timer of ours: a caller's alarm (the test suite's) is its own
        signal.setitimer(signal.ITIMER_REAL, 0)
        signal.signal(signal.SIGALRM, signal.SIG_IGN)
        _armed.clear()


_ALARM = (signal.SIGALRM,) if hasattr(signal, "setitimer") else ()  # the re-raise's timer
_installed: list[int] = []  # the signals raise_on_signals took over
_previous: dict = {}  # their handlers before it


# The interruption raised, until its line is written: typer turns one that comes while
# it parses the command line into a silent status 130 (imucal.cli.main asks here).
_unreported: list[KeyboardInterrupt] = []


def _raise(signum, frame) -> None:
    for other in _installed:
        # a no-op, not SIG_IGN: a signal that arrived before this line runs would then
        # find no handler and print Python's "ignored due to race condition" error
        signal.signal(other, _ignore)
    err = Interrupted() if signum == signal.SIGINT else Terminated(signum)
    if _holding:
        # delivered to another thread (BLAS, Dask's client) despite this thread's mask,
        # and run here inside held(): raised when the hold ends
        _pending.append(err)
        return
    _unreported.append(err)
    raise err


def _ignore(signum, frame) -> None:
    pass


_hooks: list = []  # the unraisable hook before _unraisable
_armed: list[bool] = []  # whether _unraisable set the re-raise timer


def _unraisable(unraisable) -> None:
    """An interruption raised inside a finaliser (a weak reference's callback, say) is
    printed as "Exception ignored in ..." and lost, and the command would run on: raise
    it again a millisecond later, by then (almost always) where it can end the command;
    if not, this comes round again."""
    if _unreported and unraisable.exc_value is _unreported[0] and _ALARM:
        signal.signal(signal.SIGALRM, _raise_again)
        signal.setitimer(signal.ITIMER_REAL, 0.001)
        _armed[:] = [True]
        return
    (_hooks[0] if _hooks else sys.__unraisablehook__)(unraisable)


def _raise_again(signum, frame) -> None:
    if _unreported:  # not yet written up by report(): the command is still running
        raise _unreported[0]


def unreported() -> KeyboardInterrupt | None:
    """The interruption :func:`raise_on_signals` raised, if :func:`report` has not
    written its line yet.

    Returns
    -------
    err : KeyboardInterrupt or None
        The :class:`Interrupted` or :class:`Terminated` raised first; None when none was
        raised or its line was written.
    """
    return _unreported[0] if _unreported else None


_holding: list[int] = []  # one entry per held() block open in the main thread
_pending: list[KeyboardInterrupt] = []  # an interruption that came while held


@contextmanager
def held():
    """Ctrl-C, SIGTERM and SIGHUP held (POSIX), delivered when the block ends; child
    processes started meanwhile inherit the block. Only under :func:`raise_on_signals`:
    from Python the caller's signals are left as they are (a fork server started here
    would keep them blocked for the caller's later processes).

    The mask holds them in this thread; one that another thread takes is held by
    :func:`_raise` until the block ends.

    Yields
    ------
    None
        Once: the block runs (with the signals held under :func:`raise_on_signals`).

    Raises
    ------
    KeyboardInterrupt
        when the block ends, for a signal held during it (:class:`Terminated` for SIGTERM
        and SIGHUP).
    """
    if not _installed or not hasattr(signal, "pthread_sigmask"):
        yield
        return
    # counted before the mask goes up and until it is down: a signal that another
    # thread takes in between must wait too, not raise with the mask left up
    _holding.append(1)
    try:
        old = signal.pthread_sigmask(signal.SIG_BLOCK, set(ENDING))
        try:
            yield
        finally:
            signal.pthread_sigmask(signal.SIG_SETMASK, old)
    finally:
        _holding.pop()
        if _pending and not _holding:
            err = _pending.pop()
            _unreported.append(err)
            raise err


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
        # from Python nothing was held while the worker started (held())
        signal.pthread_sigmask(signal.SIG_BLOCK, set(ENDING) - {signal.SIGTERM})
        signal.pthread_sigmask(signal.SIG_UNBLOCK, {signal.SIGTERM})


def report(err: KeyboardInterrupt) -> int:
    """Write the one stderr line for an interruption ``err`` ("imucal: interrupted" or
    "imucal: terminated (SIGTERM)"), and ignore the ending signals from then on
    (:func:`finish`).

    Returns
    -------
    status : int
        The exit status: 128 + the signal's number for :class:`Terminated` (143 for
        SIGTERM, 129 for SIGHUP), else 130 (Ctrl-C).
    """
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
    finish()
    return code
