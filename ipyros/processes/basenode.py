"""The basenode: found as ``rosrun`` finds it, run as a managed child process.

A wrapping node launches its basenode itself at ``create()``: no terminal window, no
``rosrun`` shell script in between. This module does the two halves of that.

**Lookup.** :func:`find_executable` answers ``rosrun PACKAGE EXECUTABLE``'s question in
Python, without forking ``catkin_find`` and ``rospack``: a package's executables live
anywhere below

- its catkin *libexec* dir ``<workspace>/lib/<package>`` (Debian: ``/usr/lib/<package>``,
  e.g. ``/usr/lib/topic_tools/relay``), for the first workspace of ``CMAKE_PREFIX_PATH``
  that has the package (``/usr`` always counts, as Debian's catkin has it);
- its package dir: the folder with a ``package.xml`` naming it, found by crawling
  ``ROS_PACKAGE_PATH`` (as rospack does), else ``<workspace>/share/<package>``;
- and ipyros's own demo package ``ipyros_demo`` (``ipyros/demo``), last.

The package index is cached per ``(ROS_PACKAGE_PATH, CMAKE_PREFIX_PATH)`` so that tab
completion answers at once; a lookup that misses drops the cache and looks once more,
so a package or script created during the session is still found.

**Process.** :class:`BaseProcess` runs the executable with ROS's command-line
remappings (``__name:=``, ``__ns:=``, ``from:=to``, ``_param:=value``), writes its
stdout and stderr to a log file the session can :meth:`~BaseProcess.tail`, and stops it
the way roslaunch does (SIGINT, then SIGTERM, then SIGKILL, to its whole process group).
A watcher thread per run blocks in ``wait()`` and reports an exit nobody asked for to
``on_exit`` (exit code and last log lines), so a crashed basenode is news, not a hang.

No orphans, in three layers: the wrapping node calls :meth:`~BaseProcess.stop` at its
shutdown; an ``atexit`` hook stops every basenode still running when the interpreter
exits; and if the interpreter is SIGKILLed, the kernel sends the basenode SIGTERM
(``PR_SET_PDEATHSIG``, set by :func:`ipyros.processes.process.spawn`).
"""

from __future__ import annotations

import atexit
import difflib
import functools
import os
import re
import shlex
import signal
import sys
import threading
import time
import xml.etree.ElementTree as ET
from pathlib import Path
from typing import Any, Callable, Iterable, Mapping, Optional, Sequence

import yaml

from ..core.errors import BaseNodeError, NodeStateError
from ..core.model import BaseModel
from .process import spawn, stop_process

#: ipyros's bundled ROS package (``ipyros_demo``): a small demo robot.
DEMO_DIR = Path(__file__).resolve().parents[1] / "demo"

_IGNORE_MARKERS = ("CATKIN_IGNORE", "COLCON_IGNORE", "AMENT_IGNORE")


# ---------------------------------------------------------------------------
# Lookup: packages and their executables, as rosrun finds them
# ---------------------------------------------------------------------------


def _workspaces() -> list[Path]:
    """Catkin workspaces in overlay order, as ``catkin.workspace.get_workspaces`` lists them."""
    paths = [Path(p) for p in os.environ.get("CMAKE_PREFIX_PATH", "").split(os.pathsep) if p]
    found = [p for p in paths if (p / ".catkin").is_file()]
    return found + [Path("/usr")] if Path("/usr") not in found else found


def _package_name(package_dir: Path) -> Optional[str]:
    """The ``<name>`` in a package.xml (rosbuild's manifest.xml: the folder's name)."""
    manifest = package_dir / "package.xml"
    if not manifest.is_file():
        return package_dir.name if (package_dir / "manifest.xml").is_file() else None
    try:
        name = ET.parse(manifest).getroot().findtext("name")
    except (ET.ParseError, OSError):
        return None
    return name.strip() if name else None


def _walk(top: Path, seen: set[str]) -> Iterable[tuple[Path, list[str], list[str]]]:
    """``os.walk`` following symlinks (as ``find -L`` does), in sorted order, without hidden
    folders, and visiting each real folder once (``seen``) so that symlink loops end.

    Like ``os.walk``, the caller may prune the ``dirs`` list it is handed.
    """
    for current, dirs, files in os.walk(top, followlinks=True):
        real = os.path.realpath(current)
        if real in seen:
            dirs.clear()
            continue
        seen.add(real)
        dirs[:] = sorted(d for d in dirs if not d.startswith("."))
        yield Path(current), dirs, sorted(files)


def _crawl(root: Path) -> Iterable[tuple[str, Path]]:
    """``(name, dir)`` of every package below ``root``, the way rospack crawls.

    A package's own subfolders are not searched for more packages; folders marked
    CATKIN_IGNORE are skipped, and ``rospack_nosubdirs`` stops the descent.
    """
    for here, dirs, _files in _walk(root, set()):
        name = _package_name(here)
        if name or any((here / m).exists() for m in (*_IGNORE_MARKERS, "rospack_nosubdirs")):
            dirs.clear()
            if name and not any((here / m).exists() for m in _IGNORE_MARKERS):
                yield name, here


def _is_ros_share_dir(share: Path) -> bool:
    """Whether ``<ws>/share/<name>`` belongs to a ROS package (not just any /usr/share folder).

    Debian's runtime-only packages (e.g. ``topic-tools``) ship no package.xml, only a
    catkin env hook or cmake config next to their executables in ``/usr/lib/<name>``.
    """
    return any((share / m).exists() for m in ("package.xml", "catkin_env_hook", f"cmake/{share.name}Config.cmake"))


@functools.lru_cache(maxsize=4)
def _index(env_key: tuple[str, str]) -> dict[str, Path]:
    """Package name → package dir (first found wins: ROS_PACKAGE_PATH, workspaces, demo).

    ``env_key`` is only there to key the cache on the environment that shaped it.
    Packages with only a libexec dir map to their ``<ws>/share/<name>`` marker folder.
    """
    found: dict[str, Path] = {}
    for root in os.environ.get("ROS_PACKAGE_PATH", "").split(os.pathsep):
        if root and Path(root).is_dir():
            for name, path in _crawl(Path(root)):
                found.setdefault(name, path)
    for ws in _workspaces():
        share = ws / "share"
        for lib_dir in sorted((ws / "lib").glob("*/")):
            if _is_ros_share_dir(share / lib_dir.name):
                found.setdefault(_package_name(share / lib_dir.name) or lib_dir.name, share / lib_dir.name)
        for manifest in sorted(share.glob("*/package.xml")):
            name = _package_name(manifest.parent)
            if name:
                found.setdefault(name, manifest.parent)
    found.setdefault(_package_name(DEMO_DIR) or "ipyros_demo", DEMO_DIR)
    return found


def _env_key() -> tuple[str, str]:
    return os.environ.get("ROS_PACKAGE_PATH", ""), os.environ.get("CMAKE_PREFIX_PATH", "")


def _search_dirs(package: str) -> list[Path]:
    """Where rosrun looks for ``package``'s executables: catkin libexec/share dirs, then its package dir.

    Like ``catkin_find --without-underlays --libexec --share``, only the first workspace
    that has the package counts; a libexec dir counts even for a package rospack does not
    know (Debian ships some, like ``roslib``, without any package.xml).
    """
    dirs: list[Path] = []
    for ws in _workspaces():
        dirs = [d for d in (ws / "lib" / package, ws / "share" / package) if d.is_dir()]
        if dirs:
            break
    package_dir = _index(_env_key()).get(package)
    if package_dir is not None and package_dir.is_dir():
        dirs.append(package_dir)
    unique: dict[str, Path] = {}
    for d in dirs:
        unique.setdefault(os.path.realpath(d), d)
    return list(unique.values())


def _is_executable_file(path: Path) -> bool:
    return path.is_file() and os.access(path, os.X_OK)


@functools.lru_cache(maxsize=256)
def _executables(package: str, env_key: tuple[str, str]) -> dict[str, tuple[Path, ...]]:
    """Basename → executable files of ``package``, searched like rosrun's ``find -L``.

    Folders named ``build`` right below a package dir (rosrun skips them) and hidden
    folders are not searched; symlink loops are cut by remembering real paths.
    """
    found: dict[str, list[Path]] = {}
    seen: set[str] = set()
    for top in _search_dirs(package):
        for here, dirs, files in _walk(top, seen):
            if here == top and "build" in dirs:
                dirs.remove("build")
            for f in files:
                if _is_executable_file(here / f):
                    found.setdefault(f, []).append(here / f)
    return {name: tuple(paths) for name, paths in sorted(found.items())}


def refresh_packages() -> None:
    """Forget the cached package index (e.g. after installing or creating a package)."""
    _index.cache_clear()
    _executables.cache_clear()


def list_packages() -> list[str]:
    """Names of the ROS packages rosrun could run something from (cached; for completion)."""
    return sorted(_index(_env_key()))


def list_executables(package: str) -> list[str]:
    """Names of ``package``'s executables (cached; for completion); ``[]`` for an unknown package."""
    return list(_executables(package, _env_key()))


def did_you_mean(word: str, candidates: Sequence[str]) -> str:
    """``did you mean a or b?`` for the candidates close to ``word``, else ``""``."""
    close = difflib.get_close_matches(word, candidates, n=3, cutoff=0.6)
    return f"did you mean {' or '.join(close)}?" if close else ""


def refuse_path_with_package(executable: str) -> None:
    """With a package, the executable is a name in it: a path there is refused, saying how to run a file."""
    if os.path.isabs(executable) or executable.startswith("~"):
        raise BaseNodeError(f"with a package, the executable is a name in it (e.g. 'talker'), not the path "
                            f"{executable!r}; to run a file by its path, give no package: baseNode({executable!r})")


def find_executable(package: str, executable: str) -> Path:
    """The file ``rosrun package executable`` would run.

    ``executable`` may also be a path relative to the package dir (``scripts/talker``),
    as rosrun allows. Raises :class:`BaseNodeError` naming close matches when the
    package or executable is unknown, or when the name is ambiguous.
    """
    if not package or not executable:
        raise BaseNodeError(
            "a basenode needs a package and an executable, e.g. basePackage('topic_tools') and baseNode('relay')"
        )
    refuse_path_with_package(executable)
    for fresh in (False, True):  # the second try forgets the caches: something new may have appeared
        if fresh:
            refresh_packages()
        if "/" in executable:  # rosrun takes a path as relative to the package dir
            package_dir = _index(_env_key()).get(package)
            if package_dir is not None and _is_executable_file(package_dir / executable):
                return _inside(package_dir, package_dir / executable, package, executable)
            continue
        candidates = _executables(package, _env_key()).get(executable)
        if candidates:
            return _pick(package, executable, candidates)
    raise _lookup_error(package, executable)


def _inside(package_dir: Path, path: Path, package: str, executable: str) -> Path:
    """``path``, if it lies inside ``package_dir`` (after links and ``..``): a package runs only its own files."""
    if not os.path.realpath(path).startswith(os.path.realpath(package_dir) + os.sep):
        raise BaseNodeError(f"{executable!r} leads out of package {package!r} ({os.path.realpath(path)}); name an "
                            f"executable inside it, or run a file by its path with no package: baseNode('/path/to/node')")
    return path


def _pick(package: str, executable: str, candidates: tuple[Path, ...]) -> Path:
    """One of several same-named files: rosrun prefers a catkin libexec one over a share/source one."""
    if len(candidates) == 1:
        return candidates[0]
    # links to one file are that file (ipyros_demo lists its scripts again in its ament prefix, demo/ament)
    if len({os.path.realpath(p) for p in candidates}) == 1:
        return next((p for p in candidates if not p.is_symlink()), candidates[0])
    libexec = [p for p in candidates if any(p.is_relative_to(ws / "lib" / package) for ws in _workspaces())]
    if len(libexec) == 1:
        return libexec[0]
    raise BaseNodeError(
        f"package {package!r} has several executables named {executable!r} ({', '.join(map(str, candidates))}): "
        "name one by its path relative to the package, e.g. 'scripts/" + executable + "'"
    )


def _lookup_error(package: str, executable: str) -> BaseNodeError:
    if not _search_dirs(package):
        hint = did_you_mean(package, list_packages())
        return BaseNodeError(
            f"unknown ROS package {package!r}: " + (hint or "check the name with `rospack list`")
            + " (packages are searched in ROS_PACKAGE_PATH, the catkin workspaces and ipyros_demo)"
        )
    names = list_executables(package)
    hint = did_you_mean(executable.rsplit("/", 1)[-1], names)
    listing = f"its executables: {', '.join(names)}" if names else "it has no executable files"
    return BaseNodeError(f"package {package!r} has no executable {executable!r}: {hint + ' ' if hint else ''}{listing}")


def link_outside(package: str, path: Path) -> Optional[str]:
    """Where ``path``, an executable found in ``package``, really is, if a link takes it out of the package.

    rosrun follows such links (``find -L``), and so does ipyros: a package may well link to a
    program installed elsewhere. But what runs is then not the package's own file, so it is
    said.
    """
    real = os.path.realpath(path)
    homes = [os.path.realpath(d) + os.sep for d in _search_dirs(package)]
    if not homes or any(real.startswith(home) for home in homes):
        return None
    return real


def package_executable(package: str, executable: str, ros2: bool) -> Path:
    """The file ``rosrun`` (ROS 1) or ``ros2 run`` (ROS 2, the ament index) would run."""
    if ros2:
        from ..ros2.packages import find_executable as find_in_ament

        return find_in_ament(package, executable)
    return find_executable(package, executable)


def python_command(path: Path, args: Sequence[str] = ()) -> tuple[Path, list[str]]:
    """How to run an executable: a Python script with this interpreter, anything else as it is.

    This interpreter imports ROS (ipyros does), whatever the script's ``#!`` line names:
    so a node written for Debian's python3 runs in a venv (ROS 2 from PyPI) or a conda
    (RoboStack) environment as well.
    """
    try:
        with open(path, "rb") as f:
            first = f.readline(200)
    except OSError:
        first = b""
    if first.startswith(b"#!") and b"python" in first:
        return Path(sys.executable), [str(path), *args]
    return path, list(args)


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
    if _is_executable_file(path):
        return path, list(args)
    if path.is_file() and path.suffix == ".py":
        return Path(sys.executable), [str(path), *args]
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


def param_arg(name: str, value: Any) -> str:
    """A private parameter as a command-line argument: ``_name:=value``.

    rospy reads the value as YAML, roscpp as int, double, bool or else string; plain
    strings are passed as they are so both read them alike, and only strings that
    YAML would read as something else (``'5'``, ``'true'``) are quoted.
    """
    key = name[1:] if name[:1] in ("~", "_") else name
    if isinstance(value, bool):
        text = "true" if value else "false"
    elif isinstance(value, (int, float)):
        text = repr(value)
    elif isinstance(value, str) and _reads_back_as_itself(value):
        text = value
    else:
        text = yaml.safe_dump(value, default_flow_style=True, width=1 << 20).strip()
        text = text.removesuffix("...").strip()  # the end-of-document mark YAML puts after a bare scalar
    return f"_{key}:={text}"


def _reads_back_as_itself(text: str) -> bool:
    try:
        return bool(text) and yaml.safe_load(text) == text
    except yaml.YAMLError:
        return False


def exit_reason(returncode: int) -> str:
    """``exited with code 3`` or ``killed by SIGSEGV``: what a return code means, in words."""
    if returncode < 0:
        try:
            return f"killed by {signal.Signals(-returncode).name}"
        except ValueError:
            return f"killed by signal {-returncode}"
    return f"exited with code {returncode}"


class _Run:
    """One start of the process: the Popen, and whether its end was asked for."""

    def __init__(self, proc) -> None:
        self.proc = proc
        self.expected_exit = threading.Event()


class BaseProcess:
    """A basenode run as a managed child process.

    ``executable`` is the file to run (see :func:`find_executable`, or
    :meth:`from_model`); ``remaps`` maps resolved names to resolved names; ``params``
    are the node's private parameters (``{"rate": 10}`` → ``_rate:=10``).
    ``on_exit(proc, returncode, last_lines)`` is called, on a watcher thread, when the
    process ends without :meth:`stop` being asked, including a crash right at start.

        >>> base = BaseProcess(find_executable("topic_tools", "relay"), ["/in", "/out"],
        ...                    node_name="relay", remaps={"/in": "/w/base/in"}).start()
        >>> base.tail(5)
        ['[ipyros] ... starting: /usr/lib/topic_tools/relay /in /out __name:=relay /in:=/w/base/in']
        >>> base.stop()
    """

    def __init__(
        self,
        executable: "str | os.PathLike[str]",
        args: Sequence[str] = (),
        *,
        node_name: Optional[str] = None,
        namespace: Optional[str] = None,
        remaps: Optional[Mapping[str, str]] = None,
        params: Optional[Mapping[str, Any]] = None,
        master_uri: Optional[str] = None,
        log_path: "str | os.PathLike[str] | None" = None,
        on_exit: Optional[OnExit] = None,
        env: Optional[Mapping[str, str]] = None,
        ros2: bool = False,
    ) -> None:
        self.executable = Path(executable)
        self.argv: list[str] = [str(self.executable), *map(str, args)]
        if ros2:  # after --ros-args: -r for the name, namespace and remaps, -p for params
            rules = ([f"__node:={node_name}"] if node_name else [])
            rules += [f"__ns:={namespace.rstrip('/') or '/'}"] if namespace else []  # ROS 2: no trailing /
            rules += [f"{src}:={dst}" for src, dst in (remaps or {}).items()]
            settings = [param_arg(k, v)[1:] for k, v in (params or {}).items()]  # key:=value, no leading _
            if rules or settings:
                self.argv += ["--ros-args", *[w for r in rules for w in ("-r", r)],
                              *[w for p in settings for w in ("-p", p)]]
        else:
            if node_name:
                self.argv.append(f"__name:={node_name}")
            if namespace:
                self.argv.append(f"__ns:={namespace}")
            self.argv += [f"{src}:={dst}" for src, dst in (remaps or {}).items()]
            self.argv += [param_arg(k, v) for k, v in (params or {}).items()]
        self.node_name = node_name
        self.env = {**os.environ, **(env or {}), "PYTHONUNBUFFERED": "1"}  # a Python node's prints reach the log now
        if master_uri:
            self.env["ROS_MASTER_URI"] = master_uri
        self.log_path = Path(log_path) if log_path else temp_log(node_name or self.executable.name)
        self.on_exit = on_exit
        self._run: Optional[_Run] = None
        self._lifecycle = threading.RLock()  # start/stop/restart one at a time

    @classmethod
    def from_model(
        cls,
        base: BaseModel,
        *,
        remaps: Optional[Mapping[str, str]] = None,
        master_uri: Optional[str] = None,
        log_path: "str | os.PathLike[str] | None" = None,
        on_exit: Optional[OnExit] = None,
        ros2: bool = False,
    ) -> "BaseProcess":
        """The process for a declared basenode; ``remaps`` (the wrapping's) add to the model's own.

        Without a package, ``base.executable`` must be a path to an executable file. ``ros2``:
        name, namespace, remaps and params go after ``--ros-args``, as ROS 2 nodes read them.
        """
        if not base.executable:
            raise BaseNodeError(
                "no basenode executable declared: call baseNode('executable') and basePackage('package')"
            )
        args = list(base.args)
        if base.package and ros2:
            path, args = python_command(package_executable(base.package, base.executable, ros2=True), args)
        elif base.package:
            path = find_executable(base.package, base.executable)
        else:
            path, args = script_command(base.executable, args)
        return cls(
            path, args, node_name=base.node_name, namespace=base.namespace,
            remaps={**base.remaps, **(remaps or {})}, params=base.params,
            master_uri=master_uri, log_path=log_path, on_exit=on_exit, env=base.env, ros2=ros2,
        )

    # -- state ---------------------------------------------------------------
    @property
    def pid(self) -> Optional[int]:
        """The process id while it runs, else None."""
        return self._run.proc.pid if self.running else None

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
                    proc = spawn(self.argv, env=self.env, log=log.fileno())
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


@atexit.register
def stop_all(timeout: float = 3.0) -> None:
    """Stop every basenode still running (registered with atexit: the interpreter leaves no orphan)."""
    with _running_lock:
        live = list(_running)
    for proc in live:
        try:
            proc.stop(timeout)
        except Exception:  # at exit, one basenode's trouble must not spare the others
            pass
