"""Atomic file output: write to a temporary name in the target folder, then rename.

A failure or Ctrl-C therefore leaves either the old file or none, never half a file.
Targets that are not regular files (``/dev/null``, ``/dev/stdout``, a FIFO) are written
through instead: renaming over them would replace the device or pipe by a plain file.
A symbolic link to a file has the file it names replaced, the link kept.
"""

from __future__ import annotations

import errno
import io
import os
import shutil
import stat
import tempfile
from collections.abc import Callable
from pathlib import Path

from .errors import InputError
from .signals import held


def check_writable(path: str | Path) -> Path:
    """Fail early (before any computation) when ``path`` cannot be written."""
    path = Path(path)
    if _through(path):
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
        raise InputError(f"{path}: folder '{folder}' is not writable")
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


def _through(path: Path) -> bool:
    """Whether ``path`` is written through rather than replaced: an existing file that is
    not a regular one (a device, a FIFO, a terminal), or a regular file reached through
    /proc's descriptor links (``/dev/stdout`` redirected to a file: the shell opened it,
    perhaps to append)."""
    try:
        st = os.stat(path)
    except (OSError, ValueError):
        return False  # missing (created) or unusable (named by check_writable)
    if stat.S_ISDIR(st.st_mode):
        return False
    return not stat.S_ISREG(st.st_mode) or _via_proc(path)


def _via_proc(path: Path) -> bool:
    p = os.path.abspath(path)
    for _ in range(40):  # the kernel's own limit on links followed
        if os.path.realpath(os.path.dirname(p)).startswith("/proc/"):
            return True
        if not os.path.islink(p):
            return False
        p = os.path.join(os.path.realpath(os.path.dirname(p)), os.readlink(p))
    return False


def _prefix(path: Path) -> str:
    """The hidden temporary files' prefix: the target's name, shortened so that a name
    near the file system's 255-byte limit still leaves room for the random part."""
    return f".{path.name[:40]}."


def write_atomic(path: str | Path, write: Callable[[Path], None]) -> None:
    """Call ``write(tmp)`` to create a temporary file beside ``path``, then rename it.

    The temporary file keeps the target's suffix (libraries pick formats by it) and gets
    the usual umask-based permissions rather than tempfile's 0600. A target that is not a
    regular file is written through (:func:`_write_through`).
    """
    path = Path(path)
    if _through(path):
        _write_through(path, write)
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
        write(tmp)
        umask = os.umask(0)
        os.umask(umask)
        os.chmod(tmp, 0o666 & ~umask)
        os.replace(tmp, target)
    except BaseException as err:
        if tmp is not None:
            tmp.unlink(missing_ok=True)
        if isinstance(err, OSError):
            raise InputError(f"{path}: cannot write file ({err.strerror or err})") from None
        raise


def _suffix(path: Path) -> str:
    return path.suffix if len(path.suffix) <= 16 else ""


def _write_through(path: Path, write: Callable[[Path], None]) -> None:
    """Write a device, FIFO or descriptor link: the whole output is made in a temporary
    file first (writers need a file name, and a failure then writes nothing), then copied
    in (appended: a shell's ``>>`` keeps what was there)."""
    tmp = None
    try:
        with held():
            fd, name = tempfile.mkstemp(prefix=".imucal.", suffix=_suffix(path))
            tmp = Path(name)
            os.close(fd)
        write(tmp)
        with open(tmp, "rb") as src, open(path, "ab") as dst:
            shutil.copyfileobj(src, dst)
    except BaseException as err:
        if isinstance(err, OSError):
            raise InputError(f"{path}: cannot write file ({err.strerror or err})") from None
        raise
    finally:
        if tmp is not None:
            tmp.unlink(missing_ok=True)


def write_hdf5_atomic(path: str | Path, fill: Callable) -> None:
    """Write an HDF5 file atomically: ``fill(h5)`` fills an open, empty ``h5py.File``.

    The file is built in memory and its bytes written as any other output's: the HDF5
    library writing to a full disk itself printed a dozen tracebacks and then crashed
    the interpreter (segmentation fault) instead of failing with the error.
    """
    import h5py

    buffer = io.BytesIO()
    with h5py.File(buffer, "w", track_order=True) as h5:
        fill(h5)
    data = buffer.getvalue()
    write_atomic(path, lambda tmp: tmp.write_bytes(data))


def write_text_atomic(path: str | Path, text: str) -> None:
    """Write ``text`` (UTF-8) to ``path`` atomically."""
    write_atomic(path, lambda tmp: tmp.write_text(text, encoding="utf-8"))


def check_not_inputs(outputs, inputs) -> None:
    """InputError when an output path names one of the input files or another output.

    ``outputs``: (option, path or None) pairs such as ("--out", path); ``inputs``: the
    recordings read ("-" for stdin is skipped). Writing such an output would destroy the
    recording, or one output would silently replace the other.
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
