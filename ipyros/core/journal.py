"""The session's history on disk: one JSON line per change, written as it happens.

A crash of the interpreter loses nothing already recorded: each line is handed to the
operating system before the change returns. Its sync to the disk, which only a machine that
loses power needs, comes within :data:`SYNC_WITHIN` seconds, one sync for every line written
meanwhile (a sync takes milliseconds to tens of them: one a line made leaving a session of 150
nodes, a line each, 4 s slower). The files hold handler sources and parameter values, so
the directory is created 0700 and each file 0600. Every session writes a file of its own, created
exclusively (``<start time>-<pid>.jsonl`` in the history directory), so no session
ever overwrites another's history. A line looks like::

    {"time": 1795254721.3, "node": "/kobuki", "change": "new.subscribe /cmd_vel [geometry_msgs/Twist] -> clamp",
     "slot": "topic /cmd_vel", "version": 2, "handler": "clamp", "source": "def clamp(msg):\\n    ..."}

``slot``, ``version``, ``handler`` and ``source`` are there for handler changes only.
:func:`read` turns a file back into :class:`Change` records.
"""

from __future__ import annotations

import json
import os
import threading
import time
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Optional, TextIO

__all__ = ["Change", "Journal", "default_dir", "read"]

ENV_DIR = "IPYROS_HISTORY_DIR"
#: At most how long a recorded line waits for its sync to the disk (s); the lines written meanwhile share it.
SYNC_WITHIN = 0.2


@dataclass(frozen=True)
class Change:
    """One change a DSL node went through, as it would be typed (``new.subscribe /x [T] -> h``).

    A change that gives a handler slot a new function also says which slot, the
    version number it became, and the function's name and source (None if not found).
    """

    time: float
    node: str
    change: str
    slot: Optional[str] = None
    version: Optional[int] = None
    handler: Optional[str] = None
    source: Optional[str] = None
    by: Optional[str] = None  # who made it, when not the person at the prompt ("the agent, request #3")


def default_dir() -> Path:
    """``$IPYROS_HISTORY_DIR``, else ``~/.ipyros/history``."""
    return Path(os.environ.get(ENV_DIR) or Path.home() / ".ipyros" / "history").expanduser()


class Journal:
    """Appends changes to a file of this session's own, opened on the first change; a thread of its own syncs
    them to the disk (see the module's docstring), and :meth:`close` once more.

    If the directory cannot be written, :meth:`append` raises ``OSError`` once and the
    journal turns itself off: losing the file must not stop anyone's work at the prompt.
    A sync that fails is raised by the next :meth:`append`, the same way.
    """

    def __init__(self, directory: Optional[Path] = None) -> None:
        self.directory = directory or default_dir()
        self.path: Optional[Path] = None
        self.failed = False
        self._file: Optional[TextIO] = None
        self._lock = threading.Lock()
        self._unsynced = threading.Event()
        self._sync_error: Optional[OSError] = None
        self._syncer: Optional[threading.Thread] = None

    def append(self, change: Change) -> None:
        if self.failed:
            return
        try:
            with self._lock:
                if self._sync_error is not None:
                    raise self._sync_error
                file = self._file
                if file is None:
                    file = self._file = self._open()
                    self._syncer = threading.Thread(target=self._sync, name="ipyros-history-sync", daemon=True)
                    self._syncer.start()
                file.write(json.dumps({k: v for k, v in asdict(change).items() if v is not None}) + "\n")
                file.flush()
            self._unsynced.set()
        except OSError:
            self.failed = True
            raise

    def _sync(self) -> None:
        """Sync what was written, at most :data:`SYNC_WITHIN` s after it was, until the file is closed."""
        while True:
            self._unsynced.wait()
            time.sleep(SYNC_WITHIN)  # the lines written meanwhile share this sync
            self._unsynced.clear()
            try:
                with self._lock:  # the sync itself is outside: an append (a handler edited) never waits for the disk
                    if self._file is None:
                        return
                    fd = os.dup(self._file.fileno())  # close() may close the file meanwhile; a copy syncs the same
                try:
                    os.fsync(fd)
                finally:
                    os.close(fd)
            except OSError as error:  # raised by the next append, at the prompt (no descriptor left: the same)
                self._sync_error = error
                return

    def _open(self) -> TextIO:
        # Handler sources and parameter values (tokens, passwords typed at the prompt) are in
        # here: the directory is the user's alone (0700), each file too (0600).
        self.directory.mkdir(mode=0o700, parents=True, exist_ok=True)
        info = self.directory.stat()
        if info.st_uid == os.getuid() and info.st_mode & 0o077:
            self.directory.chmod(0o700)  # made before ipyros kept it private
        stem = time.strftime("%Y%m%d-%H%M%S") + f"-{os.getpid()}"
        for n in range(1000):
            path = self.directory / (stem + (f"-{n}" if n else "") + ".jsonl")
            try:  # O_EXCL: never an existing file
                fd = os.open(path, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o600)
            except FileExistsError:
                continue
            self.path = path
            return os.fdopen(fd, "w", encoding="utf-8")
        raise FileExistsError(f"{self.directory} has 1000 history files named {stem}*")

    def close(self) -> None:
        """Sync what is left and close the file (its syncing thread then ends)."""
        with self._lock:
            if self._file is not None:
                try:
                    os.fsync(self._file.fileno())
                except OSError:  # nothing to tell at exit: the lines are written, only not synced
                    pass
                self._file.close()
                self._file = None
        self._unsynced.set()  # wakes the syncing thread to see the file closed


def read(path: "str | os.PathLike[str]") -> list[Change]:
    """The changes recorded in a journal file, oldest first (a torn last line is skipped)."""
    changes = []
    for line in Path(path).read_text(encoding="utf-8").splitlines():
        try:
            changes.append(Change(**json.loads(line)))
        except (ValueError, TypeError):  # the interpreter died while writing this line
            continue
    return changes
