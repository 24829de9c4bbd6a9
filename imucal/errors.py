"""The project's exception types, the exit codes the command line maps them to, and how
a message becomes one stderr line."""

import os
import sys


class ImucalError(Exception):
    """Base class of every error imucal raises on purpose.

    ``exit_code`` is the status the command line exits with: 2 for bad input or usage,
    1 when the data cannot answer the question.
    """

    exit_code = 2


class InputError(ImucalError):
    """A recording or an argument is unusable; the message names the file and the problem."""

    exit_code = 2


class NotIdentifiableError(ImucalError):
    """The data cannot identify the requested quantity (joint did not move, wrong joint type)."""

    exit_code = 1


#: Exit status of an unexpected error: a bug, or memory exhausted.
INTERNAL_ERROR = 3


def exit_code_of(err: BaseException) -> int:
    """The exit status an exception maps to.

    Returns
    -------
    int
        An imucal error's own ``exit_code`` (2 input, 1 not identifiable), 2 for an
        operating-system error (a file, a disk), ``INTERNAL_ERROR`` (3) for anything else.

    Examples
    --------
    >>> from imucal.errors import NotIdentifiableError, exit_code_of
    >>> [exit_code_of(e) for e in (NotIdentifiableError("flat"), OSError(), KeyError())]
    [1, 2, 3]
    """
    if isinstance(err, ImucalError):
        return err.exit_code
    return 2 if isinstance(err, OSError) else INTERNAL_ERROR


def number_text(x: float, decimals: int) -> str:
    """``x`` as text for a message.

    Returns
    -------
    str
        ``x`` with ``decimals`` decimals, or 4 significant digits (``.4g``, exponent form)
        when ``abs(x) >= 1e6`` (a hand-edited calibration's 1e300 printed 300 digits).

    Examples
    --------
    >>> from imucal.errors import number_text
    >>> number_text(2.345, 1), number_text(1e300, 1)
    ('2.3', '1e+300')
    """
    return f"{x:.4g}" if abs(x) >= 1e6 else f"{x:.{decimals}f}"


def signed_ms(seconds: float, decimals: int) -> str:
    """A time offset, s, as signed milliseconds for a message.

    Returns
    -------
    str
        ``1000 * seconds`` with its sign and ``decimals`` decimals; an offset that rounds
        to zero reads ``+0``, never ``-0`` (a found -0.04 ms printed "-0 ms").

    Examples
    --------
    >>> from imucal.errors import signed_ms
    >>> signed_ms(0.0281, 1), signed_ms(-4e-5, 0)
    ('+28.1', '+0')
    """
    # adding +0.0 turns a rounded -0.0 into +0.0
    return f"{round(1000 * seconds, decimals) + 0.0:+.{decimals}f}"


def one_line(text: str) -> str:
    """``text`` with every run of whitespace, newlines included, as one space: an error
    is one stderr line even where it quotes a name or a library's text with newlines.

    Returns
    -------
    str
        ``str(text)`` so joined, without leading or trailing whitespace.

    Examples
    --------
    >>> from imucal.errors import one_line
    >>> one_line("  bad\\n  file\\tname ")
    'bad file name'
    """
    return " ".join(str(text).split())


#: Every character ``str.splitlines`` breaks a line at, shown as its escape.
_LINE_BREAKS = {ord(c): c.encode("unicode_escape").decode("ascii")
                for c in "\n\r\v\f\x1c\x1d\x1e\x85\u2028\u2029"}


def as_line(text) -> str:
    """``text`` with its line breaks shown as escapes (``\\n``, ``\\r``, ``\\x0b``, ...): a
    file named with a newline, quoted in a headline or a warning, leaves the message one
    line for whoever reads stderr line by line, and still readable (``one_line`` above
    turns them into spaces).

    Returns
    -------
    str
        ``str(text)`` with every character ``str.splitlines`` breaks at replaced by its
        escape; everything else kept.

    Examples
    --------
    >>> from imucal.errors import as_line
    >>> print(as_line("a\\nb.h5"))
    a\\nb.h5
    """
    return str(text).translate(_LINE_BREAKS)


def say(text) -> None:
    """Print one message line on stderr (:func:`as_line`). A standard error that cannot
    be written (a full disk, a read-only descriptor) loses this and later messages, never
    the result or the exit status; a reader gone (a broken pipe) ends the run as anywhere."""
    try:
        print(as_line(text), file=sys.stderr, flush=True)
    except BrokenPipeError:
        raise
    except OSError:
        # (the first message's ENOSPC left the command, and main's error message failed
        # again: exit 1, "not identifiable", with nothing written; a new-user trial)
        sys.stderr = open(os.devnull, "w")
