"""Atomic file output: write to a temporary name in the target folder, then rename.

A failure or Ctrl-C therefore leaves either the old file or none, never half a file.
Targets that are not regular files (``/dev/null``, ``/dev/stdout``, a FIFO) are written
through instead: renaming over them would replace the device or pipe by a plain file.
A symbolic link to a file has the file it names replaced, the link kept.
"""

from __future__ import annotations

import contextlib
import errno
import io
import os
import re
import stat
import sys
import tempfile
from collections.abc import Callable
from pathlib import Path

from .errors import InputError
from .signals import held


def check_writable(path: str | Path) -> Path:
    """Fail early (before any computation) when ``path`` cannot be written.

    Returns
    -------
    pathlib.Path
        ``path`` as given (a symbolic link not resolved); nothing is created there.

    Raises
    ------
    InputError
        ``path`` is a folder or a block device, a descriptor that is closed or not open for
        writing, not writable, or its folder is missing, a file or not writable.
    """
    path = Path(path)
    fd = descriptor_of(path)
    if fd is not None:
        if fd in CLOSED_AT_START:
            raise InputError(f"{path}: descriptor {fd} was closed when imucal started "
                             f"({fd}>&-): nothing can be written there")
        if not _writable_descriptor(fd):
            raise InputError(f"{path}: descriptor {fd} is not open for writing")
        return path
    if _through(path):
        if stat.S_ISBLK(os.stat(path).st_mode):
            raise InputError(f"{path}: is a block device (a disk); give a file name")
        if not os.access(path, os.W_OK):
            raise InputError(f"{path}: cannot write to it (permission denied)")
        return path  # (not opened here: a FIFO would wait for its reader)
    target = _target(path)
    if target.is_dir():
        raise InputError(f"{path}: is a folder; give a file name")
    folder = target.parent if str(target.parent) else Path(".")
    if folder.exists() and not folder.is_dir():
        raise InputError(f"{path}: '{folder}' is a file, not a folder")
    if not folder.is_dir():
        raise InputError(f"{path}: folder '{folder}' does not exist")
    if not os.access(folder, os.W_OK | os.X_OK):
        raise InputError(f"{path}: folder '{folder}' is not writable ({_why_not(folder)})")
    # os.access trusts permission bits; root, read-only mounts, ACLs and network file
    # systems can disagree with them, so create (and remove) a real file to be sure.
    try:
        with held(), tempfile.NamedTemporaryFile(dir=folder, prefix=_prefix(target),
                                                 suffix=".probe"):
            pass  # held: a signal between creating and removing the probe would leave it
    except OSError as err:
        raise InputError(
            f"{path}: folder '{folder}' is not writable ({err.strerror or err})"
        ) from None
    return path


def _why_not(folder: Path) -> str:
    """Why ``folder`` refuses writes, in the words errors.md gives: a read-only file
    system or its permissions (the message gave no reason on a read-only mount)."""
    try:
        if os.statvfs(folder).f_flag & os.ST_RDONLY:
            return "Read-only file system"
    except (OSError, AttributeError):  # (no statvfs on Windows)
        pass
    return "Permission denied"


def _target(path: Path) -> Path:
    """The file that writing ``path`` replaces: the one a symbolic link names (replacing
    the link itself would cut it from its file); InputError for a link loop."""
    try:
        os.stat(path)
    except OSError as err:
        if err.errno == errno.ELOOP:
            raise InputError(f"{path}: symbolic link loop") from None
    except ValueError as err:  # a NUL byte in the name
        raise InputError(f"{path}: invalid file name ({err})") from None
    return Path(os.path.realpath(path)) if os.path.islink(path) else path


def descriptor_of(path: Path) -> int | None:
    """The descriptor N that ``path`` names (``/dev/stdout``, ``/dev/fd/N``,
    ``/proc/self/fd/N``, links to them).

    Such a target is written through that very descriptor: it shares the shell's file
    position, so what the shell writes before and after
    (``{ echo H; imucal ... -o /dev/stdout; } > f``, ``> log 2>&1``) stays in order; a
    file opened anew would write over it.

    Returns
    -------
    int or None
        The descriptor number (1 for ``/dev/stdout``, following links); None for any
        other path, and after 40 links.

    Examples
    --------
    >>> from pathlib import Path
    >>> from imucal.atomic import descriptor_of
    >>> descriptor_of(Path("/dev/fd/3")), descriptor_of(Path("out.json"))
    (3, None)
    """
    p = os.path.abspath(path)
    for _ in range(40):  # the kernel's own limit on links followed
        match = _FD_PATH.match(p)
        if match and match["pid"] in (None, "self", str(os.getpid())):
            return int(match["fd"])
        if not os.path.islink(p):
            return None
        p = os.path.normpath(os.path.join(os.path.dirname(p), os.readlink(p)))
    return None


#: Standard descriptors (0-2) that were closed when the command started and are held
#: by /dev/null since (:func:`imucal.cli.main`): writing "through" them would lose the
#: output without a word.
CLOSED_AT_START: set[int] = set()

_FD_PATH = re.compile(r"^/(?:dev|proc/(?P<pid>self|\d+))/fd/(?P<fd>\d+)$")


def _writable_descriptor(fd: int) -> bool:
    try:
        import fcntl
    except ImportError:  # (no descriptor paths without it)
        return False
    try:
        mode = fcntl.fcntl(fd, fcntl.F_GETFL) & os.O_ACCMODE
    except OSError:
        return False
    return mode in (os.O_WRONLY, os.O_RDWR)


def _through(path: Path) -> bool:
    """Whether ``path`` is written through rather than replaced: a descriptor
    (:func:`descriptor_of`), or an existing file that is not a regular one (a device, a
    FIFO, a terminal)."""
    if descriptor_of(path) is not None:
        return True
    try:
        st = os.stat(path)
    except (OSError, ValueError):
        return False  # missing (created) or unusable (named by check_writable)
    if stat.S_ISDIR(st.st_mode):
        return False
    return not stat.S_ISREG(st.st_mode)


def _prefix(path: Path) -> str:
    """The hidden temporary files' prefix: the target's name, shortened so that a name
    near the file system's 255-byte limit still leaves room for the random part."""
    return f".{path.name[:40]}."


def as_path(path, what: str = "a file name") -> Path:
    """``path`` (str, bytes or os.PathLike) as a Path: None or a number from a notebook
    failed as a TypeError deep inside.

    Returns
    -------
    pathlib.Path
        ``path``; bytes decoded with the file system's encoding.

    Raises
    ------
    InputError
        ``path`` is not a str, bytes or os.PathLike; ``what`` names what was expected.
    """
    if isinstance(path, bytes):
        path = os.fsdecode(path)
    if not isinstance(path, str | os.PathLike):
        raise InputError(f"expected {what} (str or pathlib.Path), got {type(path).__name__}")
    return Path(path)


def write_atomic(path: str | Path, write: Callable[[Path], None]) -> None:
    """Call ``write(tmp)`` to create a temporary file beside ``path``, then rename it.

    The temporary file keeps the target's suffix (libraries pick formats by it) and gets
    the permissions of the file it replaces, else the usual umask-based ones rather than
    tempfile's 0600. A target that is not a
    regular file is written through (:func:`_write_through`).

    Raises
    ------
    InputError
        The temporary file or the target cannot be written (:func:`staged`); exceptions
        of ``write`` other than OSError pass through, and nothing is left behind.
    """
    with staged(path, write):
        pass


@contextlib.contextmanager
def staged(path: str | Path, write: Callable[[Path], None]):
    """:func:`write_atomic` in two steps: ``write(tmp)`` on entering the block, the file
    put in place when the block ends, and nothing written when it raises. (A target that
    is not a regular file, a device or pipe, is written on entering.)

    For an output that must not appear unless another one is written too: a figure
    whose run then failed to write its JSON (``--out /dev/full``) was left behind.

    Yields
    ------
    None
        Once, after ``write(tmp)`` has run; the file is put in place when the block ends.

    Raises
    ------
    InputError
        the temporary file or the target cannot be written. Exceptions of the block itself
        pass through, and nothing is left behind.
    """
    path = as_path(path, "an output file name")
    if _through(path):
        # a device or pipe cannot be put in place later: written now, as before the
        # output it waits for (a copy that failed after a complete JSON on stdout would
        # leave a result behind with exit 2)
        _write_through(path, write)
        yield
        return
    target = _target(path)
    folder = target.parent if str(target.parent) else Path(".")
    tmp = None
    try:
        # held, so that the file cannot be created without its name being kept; a signal
        # meanwhile is raised when the block ends, and removes it below
        with held():
            try:
                fd, name = tempfile.mkstemp(dir=folder, prefix=_prefix(target),
                                            suffix=_suffix(target))
            except OSError as err:
                raise InputError(f"{path}: cannot write to folder '{folder}' "
                                 f"({err.strerror or err})") from None
            tmp = Path(name)
            os.close(fd)
        try:
            write(tmp)
            os.chmod(tmp, _mode_of(target))
        except OSError as err:
            raise InputError(f"{path}: cannot write file ({err.strerror or err})") from None
        yield
        try:
            os.replace(tmp, target)
        except OSError as err:
            raise InputError(f"{path}: cannot write file ({err.strerror or err})") from None
    finally:
        if tmp is not None:
            tmp.unlink(missing_ok=True)


def _mode_of(target: Path) -> int:
    """The permissions an output gets: those of the file it replaces (a result set to
    0600 by hand came back 0644, readable by all: a new-user trial), else a new file's
    under the umask."""
    try:
        return stat.S_IMODE(os.stat(target).st_mode) & 0o777  # (not set-id bits)
    except OSError:
        umask = os.umask(0)
        os.umask(umask)
        return 0o666 & ~umask


def _suffix(path: Path) -> str:
    return path.suffix if len(path.suffix) <= 16 else ""


def _write_through(path: Path, write: Callable[[Path], None]) -> None:
    """Write a descriptor, device or FIFO: the whole output is made in a temporary file
    first (writers need a file name, and a failure then writes nothing), then copied in:
    through the descriptor itself where ``path`` names one (:func:`descriptor_of`), else
    through ``path`` opened for writing."""
    tmp = None
    try:
        try:
            with held():
                fd, name = tempfile.mkstemp(prefix=".imucal.", suffix=_suffix(path))
                tmp = Path(name)
                os.close(fd)
            write(tmp)
        except OSError as err:
            raise InputError(f"{path}: cannot make the output in the temporary folder "
                             f"'{tempfile.gettempdir()}' first ({err.strerror or err})"
                             ) from None
        descriptor = descriptor_of(path)
        if descriptor is not None:
            if descriptor == 1:
                sys.stdout.flush()  # what the command printed there comes first
            # the same file position; unbuffered: write_fully sees every short write
            target = os.fdopen(os.dup(descriptor), "wb", buffering=0)
        else:
            target = open(path, "wb", buffering=0)  # closed by the with block below
        with open(tmp, "rb") as src, target:
            for chunk in iter(lambda: src.read(COPY_CHUNK), b""):
                write_fully(target.write, chunk)
    except BrokenPipeError:
        raise  # the reader stopped: the command line's SIGPIPE exit, as for stdout
    except OSError as err:
        raise InputError(f"{path}: cannot write file ({err.strerror or err})") from None
    finally:
        if tmp is not None:
            tmp.unlink(missing_ok=True)


def write_hdf5_atomic(path: str | Path, fill: Callable) -> None:
    """Write an HDF5 file atomically: ``fill(h5)`` fills an open, empty ``h5py.File``.

    The file is built in memory and its bytes written as any other output's: the HDF5
    library writing to a full disk itself printed a dozen tracebacks and then crashed
    the interpreter (segmentation fault) instead of failing with the error.

    Raises
    ------
    InputError
        not enough memory to build the file, or it cannot be written.
    """
    import h5py

    path = as_path(path, "an output file name")
    try:
        buffer = io.BytesIO()
        with h5py.File(buffer, "w", track_order=True) as h5:
            fill(h5)
        data = buffer.getvalue()
    except MemoryError:
        raise InputError(f"{path}: not enough memory to build the HDF5 file") from None
    write_atomic(path, lambda tmp: tmp.write_bytes(data))


def write_text_atomic(path: str | Path, text: str) -> None:
    """Write ``text`` (UTF-8) to ``path`` atomically.

    Raises
    ------
    InputError
        ``path`` cannot be written (:func:`write_atomic`).
    """
    write_atomic(path, lambda tmp: tmp.write_text(text, encoding="utf-8"))


#: Bytes copied per write when an output is written through (a device, a pipe).
COPY_CHUNK = 1 << 16


def write_fully(write: Callable, data: bytes) -> None:
    """``data`` through ``write`` (a binary stream's ``write``) until all of it is out.

    A short write is retried with the rest. When the reader of a pipe goes away during a
    large write (``| head``), CPython's buffered stream returns the bytes written so far
    instead of failing, and a text stream drops that count: the output was cut short
    with exit status 0 and no word. The retry fails with BrokenPipeError instead.

    Raises
    ------
    BrokenPipeError
        the reader has gone.
    OSError
        the stream accepts nothing more (or any other write error).
    """
    view = memoryview(data)
    while view.nbytes:
        n = write(view)
        if not n:  # (None: a non-blocking stream that would block)
            raise OSError(errno.EIO, "the output accepted no more bytes")
        view = view[n:]


#: Encodings whose encoder starts every call with a byte-order mark: encoded per call,
#: each output would carry one (the text stream writes it once).
_BOM_ENCODINGS = frozenset({"utf-16", "utf-32", "utf-8-sig"})


def _byte_stream():
    """Standard output's binary buffer where writing the encoded text there is what the
    text stream would write: the interpreter's own stream (a TextIOWrapper over a
    buffered file, or the raw file itself with ``python -u`` / PYTHONUNBUFFERED, whose
    short writes the text stream drops as well), no newline translation (POSIX) and no
    byte-order mark. Else None: a stand-in (imucal.cli's closed stdout, a notebook's or
    a test harness's stream), which gets the text as it is."""
    import codecs

    out = sys.stdout
    if type(out) is not io.TextIOWrapper or os.linesep != "\n":
        return None
    buffer = getattr(out, "buffer", None)
    if not isinstance(buffer, io.BufferedWriter | io.FileIO):
        return None
    try:
        if codecs.lookup(out.encoding).name in _BOM_ENCODINGS:
            return None
    except (LookupError, TypeError):
        return None
    return buffer


def write_stdout(text: str) -> None:
    """``text`` to standard output, flushed (a reader, jq or ``tail -f``, sees it at
    once). A failed write names standard output (it said only "No space left on device"
    for ``> /dev/full``); a reader that is gone stays a BrokenPipeError, which the command
    line ends quietly as a shell does.

    Raises
    ------
    InputError
        standard output cannot be written (a full disk, a closed descriptor).
    BrokenPipeError
        the reader has gone.
    """
    try:
        buffer = _byte_stream()
        if buffer is None:
            sys.stdout.write(text)
            sys.stdout.flush()
        else:
            sys.stdout.flush()
            write_fully(buffer.write, text.encode(sys.stdout.encoding, sys.stdout.errors))
            buffer.flush()
    except BrokenPipeError:
        raise
    except OSError as err:
        if err.filename is not None:
            raise
        raise InputError(f"standard output: cannot write ({err.strerror or err})") from None


def check_not_inputs(outputs, inputs) -> None:
    """Check that no output path names one of the input files or another output.

    ``outputs``: (option, path or None) pairs such as ("--out", path); ``inputs``: the
    recordings read ("-" for stdin is skipped). Writing such an output would destroy the
    recording, or one output would silently replace the other.

    Raises
    ------
    InputError
        An output is an input file, or two outputs are one file (links and other
        spellings of one existing file count as that file).
    """
    read = {_identity(p) for p in inputs if str(p) != "-"}
    seen: dict = {}
    for option, path in outputs:
        if path is None:
            continue
        key = _identity(path)
        if key in read:
            raise InputError(f"{path}: {option} names an input recording and would overwrite "
                             "it; give another file name")
        if key in seen:
            raise InputError(f"{path}: {option} and {seen[key]} name the same file; give "
                             "each its own name")
        seen[key] = option


def _identity(path):
    """The file a path names: device and inode when it exists (links and other spellings
    of one file compare equal), else the absolute path."""
    p = Path(path)
    try:
        st = p.stat()
    except (OSError, ValueError):
        # (a link loop, a missing folder: the loader or check_writable names the problem)
        return os.path.abspath(p)
    return (st.st_dev, st.st_ino)
