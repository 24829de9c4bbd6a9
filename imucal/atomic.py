"""Atomic file output: write to a temporary name in the target folder, then rename.

A failure or Ctrl-C therefore leaves either the old file or none, never half a file.
"""

from __future__ import annotations

import os
import tempfile
from collections.abc import Callable
from pathlib import Path

from .errors import InputError
from .signals import held


def check_writable(path: str | Path) -> Path:
    """Fail early (before any computation) when ``path`` cannot be written."""
    path = Path(path)
    if path.is_dir():
        raise InputError(f"{path}: is a folder; give a file name")
    folder = path.parent if str(path.parent) else Path(".")
    if folder.exists() and not folder.is_dir():
        raise InputError(f"{path}: '{folder}' is a file, not a folder")
    if not folder.is_dir():
        raise InputError(f"{path}: folder '{folder}' does not exist")
    if not os.access(folder, os.W_OK | os.X_OK):
        raise InputError(f"{path}: folder '{folder}' is not writable")
    # os.access trusts permission bits; root, read-only mounts, ACLs and network file
    # systems can disagree with them, so create (and remove) a real file to be sure.
    try:
        with held(), tempfile.NamedTemporaryFile(dir=folder, prefix=f".{path.name}.",
                                                 suffix=".probe"):
            pass  # held: a signal between creating and removing the probe would leave it
    except OSError as err:
        raise InputError(
            f"{path}: folder '{folder}' is not writable ({err.strerror or err})"
        ) from None
    return path


def write_atomic(path: str | Path, write: Callable[[Path], None]) -> None:
    """Call ``write(tmp)`` to create a temporary file beside ``path``, then rename it.

    The temporary file keeps the target's suffix (libraries pick formats by it) and gets
    the usual umask-based permissions rather than tempfile's 0600.
    """
    path = Path(path)
    folder = path.parent if str(path.parent) else Path(".")
    tmp = None
    try:
        # held, so that the file cannot be created without its name being kept; a signal
        # meanwhile is raised when the block ends, and removes it below
        with held():
            try:
                fd, name = tempfile.mkstemp(dir=folder, prefix=f".{path.name}.",
                                            suffix=path.suffix)
            except OSError as err:
                raise InputError(f"{path}: cannot write to folder '{folder}' "
                                 f"({err.strerror or err})") from None
            tmp = Path(name)
            os.close(fd)
        write(tmp)
        umask = os.umask(0)
        os.umask(umask)
        os.chmod(tmp, 0o666 & ~umask)
        os.replace(tmp, path)
    except BaseException as err:
        if tmp is not None:
            tmp.unlink(missing_ok=True)
        if isinstance(err, OSError):
            raise InputError(f"{path}: cannot write file ({err.strerror or err})") from None
        raise


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
    except OSError:
        return str(p.resolve())
    return (st.st_dev, st.st_ino)

