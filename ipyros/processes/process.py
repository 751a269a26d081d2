"""Child processes that never outlive the session.

Each child gets its own process group (Ctrl-C at the prompt must not reach it) and
asks the kernel to send it SIGTERM when its parent dies (``PR_SET_PDEATHSIG``), so
even a SIGKILLed interpreter leaves no orphan. The death signal is tied to the
*thread* that forked, so children are spawned from the main thread or from a thread
that lives as long as the process.

No Python runs in the child between fork and exec: the death signal is set by
util-linux's ``setpriv --pdeathsig`` exec'ing the program. A ``preexec_fn`` would run
Python in a child forked while another thread may hold the import lock (a first import
at the prompt, logging's at-fork hooks), and such a child can deadlock before exec.
"""

from __future__ import annotations

import concurrent.futures
import ctypes
import errno
import os
import queue
import shutil
import signal
import subprocess
import threading
from typing import Any, Callable, Optional, Sequence

_PR_SET_PDEATHSIG = 1
_libc = ctypes.CDLL(None, use_errno=True)


_SETPRIV = shutil.which("setpriv")


def _die_with_parent(parent_pid: int) -> None:
    # Runs in the child between fork and exec; only where setpriv is missing.
    os.setpgid(0, 0)
    _libc.prctl(_PR_SET_PDEATHSIG, signal.SIGTERM)
    if os.getppid() != parent_pid:  # the parent died before prctl took effect
        os._exit(1)


class _Launcher:
    """A daemon thread that lives as long as the interpreter and forks every basenode.

    Why not fork from whatever thread calls spawn(): the kernel's
    ``PR_SET_PDEATHSIG`` fires when the *thread* that forked the child exits, not the
    process. A basenode started from a short-lived thread (a rospy callback, a helper
    thread in the runtime, a restart from a callback) would get SIGTERM as soon as that
    thread ends. The main thread would do, but start() is not always called from it;
    a dedicated thread that only ever blocks on its queue dies only with the process,
    which is exactly when the basenode should die too.
    """

    def __init__(self) -> None:
        self._jobs: "queue.SimpleQueue[tuple[Callable[[], Any], concurrent.futures.Future]]" = queue.SimpleQueue()
        self._thread: Optional[threading.Thread] = None
        self._lock = threading.Lock()

    def call(self, fn: Callable[[], Any]) -> Any:
        """Run ``fn`` on the launcher thread; return its result or raise its exception."""
        with self._lock:
            if self._thread is None:
                self._thread = threading.Thread(target=self._serve, name="ipyros-launcher", daemon=True)
                self._thread.start()
        if threading.current_thread() is self._thread:
            return fn()
        future: concurrent.futures.Future = concurrent.futures.Future()
        self._jobs.put((fn, future))
        return future.result()

    def _serve(self) -> None:
        while True:
            fn, future = self._jobs.get()
            try:
                future.set_result(fn())
            except BaseException as exc:  # handed to the caller, who raises it
                future.set_exception(exc)


_launcher = _Launcher()


def spawn(argv: Sequence[str], *, env: Optional[dict] = None, log: Optional[int] = None,
          cwd: Optional[str] = None, stdin_pipe: bool = False, stdout_pipe: bool = False) -> subprocess.Popen:
    """Start ``argv`` in its own process group, dying with this process.

    The fork happens on the launcher thread, whichever thread calls. ``log`` is a file descriptor for stdout and
    stderr together (default: discarded). ``stdin_pipe``: its stdin is a pipe this process writes lines to (a bag
    player's controls); otherwise it reads nothing. ``stdout_pipe``: its stdout is a pipe this process reads (a
    relay host's answers), and only its stderr goes to ``log``.
    """
    parent = os.getpid()
    out = subprocess.DEVNULL if log is None else log
    common: dict[str, Any] = dict(env=env, cwd=cwd, stdin=subprocess.PIPE if stdin_pipe else subprocess.DEVNULL,
                                  stdout=subprocess.PIPE if stdout_pipe else out,
                                  stderr=out if stdout_pipe else subprocess.STDOUT, close_fds=True)
    if _SETPRIV:
        _check_executable(argv[0], (env or os.environ).get("PATH"))  # setpriv would only exit 126/127
        command = [_SETPRIV, "--pdeathsig", "TERM", "--", *argv]
        return _launcher.call(lambda: subprocess.Popen(command, process_group=0, **common))
    return _launcher.call(lambda: subprocess.Popen(list(argv), preexec_fn=lambda: _die_with_parent(parent), **common))


def _check_executable(program: str, path: Optional[str]) -> None:
    """Raise the ``OSError`` that exec'ing ``program`` would raise: not found, not executable, not a program."""
    found = program if "/" in program else shutil.which(program, path=path)
    if found is None or not os.path.isfile(found):
        raise FileNotFoundError(errno.ENOENT, os.strerror(errno.ENOENT), program)
    if not os.access(found, os.X_OK):
        raise PermissionError(errno.EACCES, os.strerror(errno.EACCES), program)
    with open(found, "rb") as file:
        head = file.read(4)
    if head != b"\x7fELF" and not head.startswith(b"#!"):  # a binary, or a script the kernel can run
        raise OSError(errno.ENOEXEC, os.strerror(errno.ENOEXEC), program)


def stop_process(proc: subprocess.Popen, timeout: float = 5.0) -> Optional[int]:
    """Stop ``proc`` and its process group: SIGINT (as roslaunch does), then SIGTERM, then SIGKILL."""
    for sig, wait in ((signal.SIGINT, timeout * 0.6), (signal.SIGTERM, timeout * 0.4), (signal.SIGKILL, 5.0)):
        if proc.poll() is not None:
            break
        try:
            os.killpg(proc.pid, sig)
        except ProcessLookupError:
            break
        try:
            proc.wait(wait)
        except subprocess.TimeoutExpired:
            continue
    _reap_group(proc.pid)
    return proc.wait()


def _reap_group(pgid: int) -> None:
    """Kill what is left of the group (grandchildren of a basenode), best effort."""
    try:
        os.killpg(pgid, signal.SIGKILL)
    except (ProcessLookupError, PermissionError):
        pass
