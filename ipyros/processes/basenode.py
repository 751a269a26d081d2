"""The basenode as a process: run as a managed child, logged, stopped as roslaunch stops a node, never orphaned.

A wrapping node launches its basenode itself at ``create()``: no terminal window, no
``rosrun`` shell script in between. Which file runs and its command line (remaps, name,
namespace, parameters) are each ROS's own (``ros1/nodes.py``: as rosrun finds it, with
``from:=to``; ``ros2/nodes.py``: as ``ros2 run`` finds it, after ``--ros-args``); what is
the same is here.

:class:`BaseProcess` runs a command line, writes its stdout and stderr to a log file the
session can :meth:`~BaseProcess.tail`, and stops it the way roslaunch does (SIGINT, then
SIGTERM, then SIGKILL, to its whole process group). A watcher thread per run blocks in
``wait()`` and reports an exit nobody asked for to ``on_exit`` (exit code and last log
lines), so a crashed basenode is news, not a hang.

No orphans, in three layers: the wrapping node calls :meth:`~BaseProcess.stop` at its
shutdown; an ``atexit`` hook stops every basenode still running when the interpreter
exits; and if the interpreter is SIGKILLed, the kernel sends the basenode SIGTERM
(``PR_SET_PDEATHSIG``, set by :func:`ipyros.processes.process.spawn`).
"""

from __future__ import annotations

import atexit
import importlib.metadata
import os
import re
import shlex
import signal
import sys
import threading
import time
from pathlib import Path
from typing import Any, Callable, Mapping, Optional, Protocol, Sequence

import yaml

from ..core.errors import BaseNodeError, NodeStateError
from ..core.model import BaseModel
from ..core.nodecode import entry_point_of, node_name_in
from .process import spawn, stop_process

__all__ = ["BaseHandle", "BaseProcess", "OnExit", "child_env", "exit_reason", "is_executable_file", "log_dir", "own_node_name",
           "param_value", "plain", "python_command", "refuse_path_with_package", "script_command", "stop_all",
           "stop_together", "temp_log"]


def is_executable_file(path: Path) -> bool:
    return path.is_file() and os.access(path, os.X_OK)


def refuse_path_with_package(executable: str) -> None:
    """With a package, the executable is a name in it: a path there is refused, saying how to run a file."""
    if os.path.isabs(executable) or executable.startswith("~"):
        raise BaseNodeError(f"with a package, the executable is a name in it (e.g. 'talker'), not the path "
                            f"{executable!r}; to run a file by its path, give no package: baseNode({executable!r})")


def python_command(path: Path, args: Sequence[str] = ()) -> tuple[Path, list[str]]:
    """How to run an executable: a Python script for "a python3" with this interpreter, anything else as it is.

    A script whose ``#!`` line asks for the system's python (``/usr/bin/env python3``,
    ``/usr/bin/python3``) runs with this interpreter, which imports ROS (ipyros does): so a
    node written for Debian's python3 runs in a venv (ROS 2 from PyPI) or a conda (RoboStack)
    environment as well. One that names an interpreter of its own (a workspace's venv) runs
    with that one, which has the workspace's packages.
    """
    try:
        with open(path, "rb") as f:
            first = f.readline(200)
    except OSError:
        first = b""
    if not (first.startswith(b"#!") and b"python" in first):
        return path, list(args)
    interpreter = first[2:].decode(errors="replace").split()
    own = interpreter and Path(interpreter[0]).name.startswith("python") and \
        not interpreter[0].startswith(("/usr/bin/", "/bin/", "/usr/local/bin/"))
    if own and is_executable_file(Path(interpreter[0])):
        return Path(interpreter[0]), [*interpreter[1:], str(path), *args]
    return Path(sys.executable), [str(path), *args]


#: What a ROS 2 wheels venv's bootstrap sets in its own environment (it re-executes Python with them): a child
#: that runs another interpreter must not inherit them, or it loads this venv's libraries instead of its own.
_BOOTSTRAP_GUARD = "_ROS_WHEELS_BOOTSTRAP_COMPLETE"


def child_env(argv0: str, extra: Optional[Mapping[str, str]] = None) -> dict[str, str]:
    """The environment of a child process: this one's, then ``extra``.

    When the child is not this interpreter (a workspace's venv, the system python, a
    binary), what this venv's bootstrap added for itself alone is left out: its guard and
    its library folders on ``LD_LIBRARY_PATH`` (a child of this interpreter keeps them, and
    starts at once).
    """
    env = dict(os.environ)
    if _BOOTSTRAP_GUARD in env and Path(argv0) != Path(sys.executable):
        del env[_BOOTSTRAP_GUARD]
        prefixes = (sys.prefix, str(Path(sys.prefix).resolve()))
        kept = [p for p in env.get("LD_LIBRARY_PATH", "").split(os.pathsep) if p and not (
            p in (os.path.join(prefix, "lib") for prefix in prefixes)
            or p.startswith(prefixes) and "/site-packages/ros_" in p and p.endswith(".libs"))]
        if kept:
            env["LD_LIBRARY_PATH"] = os.pathsep.join(kept)
        else:
            env.pop("LD_LIBRARY_PATH", None)
    env.update(extra or {})
    return env


#: The most of a script read to find the name its code gives its node: a node's source is far smaller.
_MOST_SOURCE = 1 << 20


def own_node_name(base: BaseModel, find_executable: Callable[[str, str], Path], calls: Sequence[str]) -> Optional[str]:
    """The name the Python code of basenode ``base`` gives its node (:func:`~ipyros.core.nodecode.node_name_in`
    with its ROS's ``calls``), read from its file: ``find_executable(package, executable)`` finds it in its
    package, else its executable is a path. An entry-point script (what colcon and pip install) is followed to
    the module it runs. ``None`` for what is not a Python script that names one node (a binary, a name computed
    at run time), or is not found (the error comes when it is run)."""
    executable = base.executable or ""
    try:
        if base.package:
            path = find_executable(base.package, executable)
        elif "/" in executable or executable.startswith("~"):  # a bare name without its package is no file yet
            path = Path(executable).expanduser()
        else:
            return None
    except (BaseNodeError, RuntimeError):  # RuntimeError: a ~user that does not exist (said when it is run)
        return None
    source = _python_source(path)
    if source is None:
        return None
    name = node_name_in(source, calls)
    entry = entry_point_of(source) if name is None else None
    module = _module_file(*entry) if entry is not None else None
    inner = _python_source(module) if module is not None else None
    return node_name_in(inner, calls) if inner is not None else name


def _python_source(path: Path) -> Optional[str]:
    """The text of ``path`` if it is a Python script (``.py``, or a ``#!`` line naming python) of a node's size."""
    try:
        with open(path, "rb") as f:
            source = f.read(_MOST_SOURCE + 1)
    except OSError:
        return None
    first_line = source.split(b"\n", 1)[0]
    python = path.suffix == ".py" or (first_line.startswith(b"#!") and b"python" in first_line)
    return source.decode(errors="replace") if python and len(source) <= _MOST_SOURCE else None


def _module_file(kind: str, what: str) -> Optional[Path]:
    """The file of the module an entry-point script runs, found on this Python's path without importing anything
    (a package's ``__init__`` is code); a ``console_scripts`` entry is looked up in its distribution's metadata."""
    if kind == "console_scripts":
        dist, _, script = what.partition("/")
        try:
            points = importlib.metadata.distribution(dist).entry_points
        except importlib.metadata.PackageNotFoundError:
            return None
        what = next((p.value.split(":", 1)[0].strip() for p in points
                     if p.group == "console_scripts" and p.name == script), "")
    parts = what.split(".")
    if not all(part.isidentifier() for part in parts):
        return None
    for folder in sys.path:
        for candidate in (Path(folder, *parts[:-1], parts[-1] + ".py"), Path(folder, *parts, "__init__.py")):
            if candidate.is_file():
                return candidate
    return None


def script_command(executable: str, args: Sequence[str] = ()) -> tuple[Path, list[str]]:
    """What runs a basenode given by its path (no package): the file itself, or Python running it.

    An executable file runs as it is; a ``.py`` file that is not executable runs with this
    interpreter (which imports ROS, as ipyros does). A bare name is not a path: it needs its
    package.
    """
    if "/" not in executable and not executable.startswith("~"):
        raise BaseNodeError(f"basenode {executable!r} needs its package: add .basePackage('package'), "
                            f"or give the path of the file to run, e.g. baseNode('./{executable}')")
    path = Path(executable).expanduser().absolute()
    if is_executable_file(path):
        return python_command(path, args)
    if path.is_file() and path.suffix == ".py":
        program, rest = python_command(path, args)
        return (program, rest) if program != path else (Path(sys.executable), [str(path), *args])
    raise BaseNodeError(f"basenode {executable!r} is not an executable file or a .py script"
                        f"{' (no such file)' if not path.exists() else ''}; give the path of the node to run, "
                        "or its package with basePackage('...')")


# ---------------------------------------------------------------------------
# The managed process
# ---------------------------------------------------------------------------

#: ``on_exit(process, returncode, last_log_lines)``, called on the watcher thread.
OnExit = Callable[["BaseProcess", int, list[str]], None]


_running: set["BaseProcess"] = set()  # strong refs: a running basenode is stopped at exit even if forgotten
_running_lock = threading.Lock()


def param_value(value: Any) -> str:
    """A parameter's value as a command line gives it (ROS 1 ``_key:=value``, ROS 2 ``-p key:=value``).

    rospy and rclpy read the value as YAML, roscpp as int, double, bool or else string;
    plain strings are passed as they are so all read them alike, and only strings that
    YAML would read as something else (``'5'``, ``'true'``) are quoted.
    """
    if isinstance(value, bool):
        text = "true" if value else "false"
    elif isinstance(value, (int, float)):
        text = repr(value)
    elif isinstance(value, str) and _reads_back_as_itself(value):
        text = value
    else:
        text = yaml.safe_dump(value, default_flow_style=True, width=1 << 20).strip()
        text = text.removesuffix("...").strip()  # the end-of-document mark YAML puts after a bare scalar
    return text


def _reads_back_as_itself(text: str) -> bool:
    try:
        return bool(text) and yaml.safe_load(text) == text
    except yaml.YAMLError:
        return False


def exit_reason(returncode: Optional[int]) -> str:
    """``exited with code 3`` or ``killed by SIGSEGV``: what a return code means, in words."""
    if returncode is None:
        return "still running"
    if returncode < 0:
        try:
            return f"killed by {signal.Signals(-returncode).name}"
        except ValueError:
            return f"killed by signal {-returncode}"
    return f"exited with code {returncode}"


class BaseHandle(Protocol):
    """A wrapped node's basenode, wherever it runs: a process of this machine (:class:`BaseProcess`), one a robot's
    keeper runs (:class:`ipyros.node.placedbase.PlacedBase`), or a launch file's node with the rest of its file.
    What ``nd.base`` is: its node's shutdown stops it, ``restart()`` starts it again with the same command line."""

    node_name: Optional[str]

    @property
    def pid(self) -> Optional[int]: ...  # on the machine it runs on
    @property
    def running(self) -> bool: ...
    @property
    def returncode(self) -> Optional[int]: ...
    def start(self) -> Any: ...
    def stop(self, timeout: float = 5.0) -> Optional[int]: ...
    def restart(self, timeout: float = 5.0) -> Any: ...
    def tail(self, n: int = 20) -> list[str]: ...


class _Run:
    """One start of the process: the Popen, and whether its end was asked for."""

    def __init__(self, proc) -> None:
        self.proc = proc
        self.expected_exit = threading.Event()


class BaseProcess:
    """A basenode run as a managed child process.

    ``argv`` is the command line (the file to run first: see each ROS's ``nodes.py``, or a
    backend's ``basenode()``); ``env`` adds to this process's environment.
    ``on_exit(proc, returncode, last_lines)`` is called, on a watcher thread, when the
    process ends without :meth:`stop` being asked, including a crash right at start.
    ``control``: it reads lines from its stdin, which :meth:`tell` writes (a bag player's
    pause, seek, ...); its answers come in its log.

        >>> base = BaseProcess(["/usr/lib/topic_tools/relay", "/in", "/out", "__name:=relay"],
        ...                    node_name="relay").start()
        >>> base.tail(5)
        ['[ipyros] ... starting: /usr/lib/topic_tools/relay /in /out __name:=relay']
        >>> base.stop()
    """

    def __init__(self, argv: Sequence["str | os.PathLike[str]"], *, node_name: Optional[str] = None,
                 env: Optional[Mapping[str, str]] = None, log_path: "str | os.PathLike[str] | None" = None,
                 on_exit: Optional[OnExit] = None, control: bool = False) -> None:
        self.argv: list[str] = [str(word) for word in argv]
        self.control = control
        self.executable = Path(self.argv[0])
        self.node_name = node_name
        self.env = {**child_env(self.argv[0], env), "PYTHONUNBUFFERED": "1"}  # a Python node's prints reach the log now
        self.log_path = Path(log_path) if log_path else temp_log(node_name or self.executable.name)
        self.on_exit = on_exit
        self._run: Optional[_Run] = None
        self._lifecycle = threading.RLock()  # start/stop/restart one at a time

    # -- state ---------------------------------------------------------------
    @property
    def pid(self) -> Optional[int]:
        """The process id while it runs, else None."""
        run = self._run
        return run.proc.pid if run is not None and run.proc.returncode is None else None

    @property
    def running(self) -> bool:
        run = self._run
        return run is not None and run.proc.returncode is None

    @property
    def returncode(self) -> Optional[int]:
        """How the last run ended (negative: killed by that signal); None while running or never run."""
        run = self._run
        return None if run is None else run.proc.returncode

    def __repr__(self) -> str:
        state = f"running, pid {self.pid}" if self.running else (
            "not started" if self._run is None else exit_reason(self.returncode))
        return f"<BaseProcess {self.executable.name} ({state}), log {self.log_path}>"

    # -- lifecycle -----------------------------------------------------------
    def start(self) -> "BaseProcess":
        """Launch the process; raise :class:`BaseNodeError` if it cannot be executed at all."""
        with self._lifecycle:
            if self.running:
                raise NodeStateError(
                    f"basenode {self.executable.name} is already running (pid {self.pid}); use restart()"
                )
            self._note(f"starting: {shlex.join(self.argv)}")
            with open(self.log_path, "ab", buffering=0) as log:
                try:
                    proc = spawn(self.argv, env=self.env, log=log.fileno(), stdin_pipe=self.control)
                except OSError as exc:
                    self._note(f"could not start: {exc}")
                    raise BaseNodeError(
                        f"cannot run basenode {self.argv[0]}: {exc.strerror or exc}; "
                        "check that it is an executable file"
                    ) from None
            run = self._run = _Run(proc)
            with _running_lock:
                _running.add(self)
            threading.Thread(target=self._watch, args=(run,), name=f"ipyros-watch-{proc.pid}", daemon=True).start()
            return self

    def stop(self, timeout: float = 5.0) -> Optional[int]:
        """Stop the process and its process group: SIGINT, then SIGTERM, then SIGKILL; return its exit code.

        Returns None if it was never started. Stopping a process that already ended is a no-op.
        """
        with self._lifecycle:
            run = self._run
            if run is None:
                return None
            if run.proc.returncode is not None:
                # Ended and reaped already: its pid, and so its group id, may belong to
                # another process by now, so there is nothing we may signal.
                return run.proc.returncode
            run.expected_exit.set()  # before any signal: the watcher must not report this exit
            returncode = stop_process(run.proc, timeout)
            # Noted here, not by the watcher: stop() must not wait for the watcher, which may be
            # inside on_exit calling restart() and so waiting for this very lock.
            self._note(f"stopped ({exit_reason(returncode)})")
            return returncode

    def tell(self, line: str) -> None:
        """Write one line to its stdin (a process started with ``control``); a one-line error if it cannot."""
        run = self._run
        stdin = run.proc.stdin if run is not None and self.running else None
        if stdin is None:
            raise NodeStateError(f"{self.executable.name} is not running" if self.control else
                                 f"{self.executable.name} takes no controls")
        try:
            stdin.write((line.rstrip("\n") + "\n").encode())
            stdin.flush()
        except (BrokenPipeError, OSError, ValueError):  # it ended meanwhile (ValueError: closed on its end)
            raise NodeStateError(f"{self.executable.name} is not running") from None

    def restart(self, timeout: float = 5.0) -> "BaseProcess":
        """Stop (if running) and start again with the same argv: same remaps, params and log file."""
        with self._lifecycle:
            self.stop(timeout)
            return self.start()

    # -- log -----------------------------------------------------------------
    def tail(self, n: int = 20) -> list[str]:
        """The last ``n`` lines of the log (the process's stdout and stderr, and ipyros's notes)."""
        return _last_lines(self.log_path, n)

    def _note(self, text: str) -> None:
        """A line of ipyros's own in the log, so that the log tells the whole story."""
        with open(self.log_path, "a", encoding="utf-8") as log:
            log.write(f"[ipyros] {time.strftime('%H:%M:%S')} {text}\n")

    def _watch(self, run: _Run) -> None:
        """Block until the process ends (no polling), then tell ``on_exit`` if nobody asked for it."""
        returncode = run.proc.wait()
        if run.proc.stdin is not None:
            try:
                run.proc.stdin.close()
            except OSError:  # its end closed first: nothing left to flush
                pass
        with _running_lock:
            if self._run is run:
                _running.discard(self)
        if run.expected_exit.is_set():
            return
        try:  # what the crashed basenode started goes with it (the group outlives its leader)
            os.killpg(run.proc.pid, signal.SIGKILL)
        except (ProcessLookupError, PermissionError):
            pass
        last_lines = self.tail()
        self._note(f"basenode {exit_reason(returncode)}")
        if self.on_exit is not None:
            try:
                self.on_exit(self, returncode, last_lines)
            except Exception as exc:  # a broken callback must not go unnoticed, nor kill the watcher silently
                self._note(f"on_exit callback failed: {exc!r}")


def log_dir() -> Path:
    """Where basenode logs go: ipyros/ in the ROS log directory, as ROS tools pick it.

    ``ROS_LOG_DIR``, else ``$ROS_HOME/log``, else ``~/.ros/log`` (the same rule on ROS 1
    and ROS 2), so that they sit beside the other ROS logs and ``rosclean`` sweeps them.
    """
    if os.environ.get("ROS_LOG_DIR"):
        root = Path(os.environ["ROS_LOG_DIR"])
    else:
        root = Path(os.environ.get("ROS_HOME") or Path.home() / ".ros") / "log"
    path = root.expanduser() / "ipyros"
    path.mkdir(parents=True, exist_ok=True)
    return path


def temp_log(label: str) -> Path:
    """A fresh log file in :func:`log_dir`, named after the basenode (or what else runs) and the time."""
    stem = f"{label.strip('/').replace('/', '_') or 'node'}-{time.strftime('%Y%m%d-%H%M%S')}-{os.getpid()}"
    directory = log_dir()
    for n in range(1000):
        path = directory / (f"{stem}.log" if n == 0 else f"{stem}-{n}.log")
        try:
            os.close(os.open(path, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o644))
            return path
        except FileExistsError:
            continue
    raise BaseNodeError(f"cannot create a log file for {label} in {directory}; clean it up (rosclean purge)")


_ESCAPES = re.compile(r"\x1b\[[0-9;?]*[ -/]*[@-~]|\x1b\][^\x07]*\x07|\x1b[@-Z\\-_]")


def plain(line: str) -> str:
    """A log line without terminal escape codes (rospy and roscpp colour their warnings and errors)."""
    return _ESCAPES.sub("", line)


def _last_lines(path: Path, n: int) -> list[str]:
    """The last ``n`` lines of a text file, reading backwards from its end (logs can be large)."""
    if n <= 0:
        return []
    try:
        with open(path, "rb") as f:
            end = f.seek(0, os.SEEK_END)
            chunk, data = 8192, b""
            while end > 0 and data.count(b"\n") <= n:
                start = max(0, end - chunk)
                f.seek(start)
                data = f.read(end - start) + data
                end = start
    except FileNotFoundError:
        return []
    return [plain(line) for line in data.decode("utf-8", errors="replace").splitlines()[-n:]]


def stop_together(processes: Sequence[Any], timeout: float = 5.0) -> None:
    """Stop several processes at once (anything with ``stop(timeout)``: a basenode, a launch file's rest), each on a
    thread of its own: stopping them one after another would take the sum of their times (up to ``timeout`` each,
    for nodes slow to stop); together, the longest one's. One's trouble does not spare the others."""
    def stop(process: Any) -> None:
        try:
            process.stop(timeout)
        except Exception:  # noqa: BLE001 - said in its own log; the others must still stop
            pass

    threads = []
    for process in processes:
        thread = threading.Thread(target=stop, args=(process,), name="ipyros-stop", daemon=True)
        try:
            thread.start()
        except RuntimeError:  # at interpreter exit (Python 3.12 on) no thread may start: stopped here, in turn
            stop(process)
            continue
        threads.append(thread)
    for thread in threads:
        thread.join()


@atexit.register
def stop_all(timeout: float = 3.0) -> None:
    """Stop every basenode still running (registered with atexit: the interpreter leaves no orphan)."""
    with _running_lock:
        live = list(_running)
    stop_together(live, timeout)
