"""Writing a file whole or not at all: readers never see half a file, a full disk changes nothing."""

from __future__ import annotations

import contextlib
import os
import tempfile
from pathlib import Path

from ..core.errors import IpyrosError

__all__ = ["write_atomic"]


def write_atomic(path: "str | os.PathLike[str]", text: str, mode: int = 0o644) -> Path:
    """Write ``text`` to a temporary file beside ``path`` and rename it: readers never see half a file."""
    path = Path(path).expanduser().absolute()
    try:
        fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".tmp")
    except OSError as error:
        raise IpyrosError(f"cannot write {path}: {error.strerror}") from None
    try:
        with os.fdopen(fd, "w", encoding="utf-8") as out:
            out.write(text)
            out.flush()
            os.fsync(out.fileno())
        os.chmod(tmp, mode)
        os.replace(tmp, path)
    except BaseException as error:
        with contextlib.suppress(OSError):
            os.unlink(tmp)
        if isinstance(error, OSError):  # a full disk, a quota: the file as it was stays
            raise IpyrosError(f"cannot write {path}: {error.strerror or error}; nothing was changed there") from None
        raise
    return path
