"""Helpers shared by tests: the test basenodes package, whether a process is still alive, a free port, an exported
script run without ipyros."""

from __future__ import annotations

import os
import signal
import socket
import subprocess
import sys
from pathlib import Path

#: Put this on ROS_PACKAGE_PATH to find the package ``ipyros_test_nodes`` (echo_node, ...).
TEST_NODES = Path(__file__).resolve().parents[1] / "nodes"


def use_test_nodes(monkeypatch) -> None:
    """Make ``ipyros_test_nodes`` findable by package and executable for this test."""
    paths = [str(TEST_NODES), *filter(None, os.environ.get("ROS_PACKAGE_PATH", "").split(os.pathsep))]
    monkeypatch.setenv("ROS_PACKAGE_PATH", os.pathsep.join(paths))


#: The ROS 2 test echo node ("in" → prefix + data → "out"), installed as a package by :func:`use_ament_echo`.
ROS2_ECHO = Path(__file__).resolve().parents[1] / "ros2" / "peers" / "echo_node.py"
ROS2_COUNT = Path(__file__).resolve().parents[1] / "both" / "peers" / "count_server_ros2.py"


def use_ament_echo(folder: Path, monkeypatch, python: str) -> Path:
    """Install package ``echo_pkg`` (executables ``echo_node`` and the action tests' ``count_server``, run by
    ``python``) in an ament index of its own under ``folder``, as colcon installs one, and put it on
    ``AMENT_PREFIX_PATH`` for this test; the prefix."""
    prefix = folder / "install"
    index = prefix / "share" / "ament_index" / "resource_index" / "packages"
    index.mkdir(parents=True)
    (index / "echo_pkg").touch()
    (prefix / "lib" / "echo_pkg").mkdir(parents=True)
    for name, source in (("echo_node", ROS2_ECHO), ("count_server", ROS2_COUNT)):
        node = prefix / "lib" / "echo_pkg" / name
        node.write_text(f"#!{python}\n" + source.read_text())
        node.chmod(0o755)
    monkeypatch.setenv("AMENT_PREFIX_PATH", os.pathsep.join([str(prefix), os.environ.get("AMENT_PREFIX_PATH", "")]))
    return prefix


class one_call:  # noqa: N801 - used as ServerProxy is: one_call(uri).getPid("/me")
    """An XML-RPC proxy of ROS 1's master or a node whose every call opens its connection and closes it after (a
    ``ServerProxy`` keeps its socket until the collector takes it: a ResourceWarning in whatever test runs then)."""

    def __init__(self, uri: str) -> None:
        self._uri = uri

    def __getattr__(self, method: str):
        import xmlrpc.client

        def call(*args):
            with xmlrpc.client.ServerProxy(self._uri) as proxy:
                return getattr(proxy, method)(*args)
        return call


def pid_alive(pid: int) -> bool:
    """Whether ``pid`` names a living process (a zombie waiting to be reaped counts as gone)."""
    try:
        stat = Path(f"/proc/{pid}/stat").read_text()
    except OSError:
        return False
    return stat.rsplit(")", 1)[1].split()[0] != "Z"


def descendants(pid: int) -> set[int]:
    """The pids of the processes ``pid`` started, and theirs, now (children of every thread): what a test started
    through one process, and may wait for, without looking at anything else on the machine."""
    found: set[int] = set()
    todo = [pid]
    while todo:
        parent = todo.pop()
        try:
            tasks = list(Path(f"/proc/{parent}/task").iterdir())
        except OSError:
            continue
        for task in tasks:
            try:
                kids = [int(k) for k in (task / "children").read_text().split()]
            except OSError:
                continue
            for kid in kids:
                if kid not in found:
                    found.add(kid)
                    todo.append(kid)
    return found


def free_port() -> int:
    """A TCP port of 127.0.0.1 that nothing listens on now (a master's, a Jupyter server's)."""
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def run_exported(script: Path, tmp_path: Path) -> tuple[subprocess.Popen, Path]:
    """Run an exported script as a process of its own (its own group), with an ipyros that fails to import; what it
    prints goes to the log returned beside it. Stop it with :func:`stop_exported`."""
    poisoned = tmp_path / "no_ipyros" / "ipyros"
    poisoned.mkdir(parents=True, exist_ok=True)
    (poisoned / "__init__.py").write_text('raise ImportError("an exported node runs without ipyros")\n')
    env = {**os.environ, "PYTHONPATH": str(poisoned.parent), "PYTHONUNBUFFERED": "1"}
    log = script.with_suffix(".log")
    with log.open("w") as out:
        return subprocess.Popen([sys.executable, str(script)], env=env, stdout=out, stderr=subprocess.STDOUT,
                                start_new_session=True), log


def stop_exported(proc: subprocess.Popen) -> None:
    """Stop what :func:`run_exported` started as roslaunch would: Ctrl-C to its group, then SIGKILL after 20 s."""
    os.killpg(proc.pid, signal.SIGINT)
    try:
        proc.wait(20)
    except subprocess.TimeoutExpired:
        os.killpg(proc.pid, signal.SIGKILL)
        proc.wait()
