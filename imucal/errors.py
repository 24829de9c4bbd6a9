"""The project's exception types and the exit codes the command line maps them to."""


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


def one_line(text: str) -> str:
    """``text`` with every run of whitespace, newlines included, as one space: an error
    is one stderr line even where it quotes a name or a library's text with newlines."""
    return " ".join(str(text).split())
