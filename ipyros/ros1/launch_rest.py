"""The rest of a launch file: everything it starts except the node ipyros wraps.

``nd.baseLaunch("robot.launch", "/robot1/planner")`` followed by ``nd.create()`` runs
two things, held by one handle, :class:`LaunchBase` (``nd.base``):

1. **the rest**, as roslaunch runs it: ``python -m ipyros.ros1.launch_rest FILE --exclude
   /robot1/planner`` is a child process of the session that loads the file with
   roslaunch's loader (:mod:`ipyros.ros1.launchfile`), drops that node and its private
   params, and runs the rest with roslaunch's own ``ROSLaunchParent``: params uploaded,
   nodes started, monitored and respawned as the file says. It uses the session's
   master and never starts one of its own (roslaunch would), and it stops like
   ``roslaunch`` on SIGINT or SIGTERM, stopping its nodes;
2. **the basenode**, once the rest is up: its private params are set on the parameter
   server (as roslaunch would have set them) and it is started remapped as for
   ``baseNode`` (:class:`~ipyros.processes.basenode.BaseProcess`), at the name it has in the file.

``stop()`` stops the basenode, then the rest. The runner is a managed child process
(own process group, SIGINT → SIGTERM → SIGKILL, stopped at exit, dies with the
session); roslaunch starts each node in a session of its own, so the runner also asks
the kernel to send every node SIGTERM should the runner itself die (SIGKILL included):
no node of the rest outlives it.
"""

from __future__ import annotations

import argparse
import ctypes
import os
import signal
import sys
import time
from pathlib import Path
from typing import Any, Optional

from ..core.errors import BaseNodeError, IpyrosError
from ..core.model import BaseModel
from ..demo import DEMO_DIR
from ..processes.basenode import BaseProcess, OnExit, temp_log
from ..processes.launched import LaunchedBase
from . import launchfile
from .launchfile import fullname
from .master import master_proxy

#: Lines the runner prints to say how its start went (the session reads its log for them).
READY = "ipyros-launch-rest: running"
FAILED = "ipyros-launch-rest: failed:"
NOT_STARTED = "ipyros-launch-rest: roslaunch could not start:"

#: roslaunch's patience with each node of the rest at stop (its defaults are 15 s and 2 s);
#: short enough that the session's stop of the runner never has to SIGKILL it.
NODE_SIGINT_TIMEOUT = 3.0
NODE_SIGTERM_TIMEOUT = 1.0
RUNNER_STOP_TIMEOUT = 3 * (NODE_SIGINT_TIMEOUT + NODE_SIGTERM_TIMEOUT)


# -- the session's side ---------------------------------------------------------------------

def package_path() -> str:
    """``ROS_PACKAGE_PATH`` for roslaunch: the session's, then ipyros_demo's folder, which ipyros finds by itself
    (a launch file may run the demo robot beside the wrapped node)."""
    parts = [p for p in os.environ.get("ROS_PACKAGE_PATH", "").split(os.pathsep) if p]
    return os.pathsep.join([*parts, str(DEMO_DIR)] if str(DEMO_DIR) not in parts else parts)


class LaunchBase(LaunchedBase):
    """A basenode from a launch file together with the rest of that file: started and stopped as one.

    ``rest`` is the runner of the rest of the launch file, with a log of its own
    (``rest.tail()``); the rest is :class:`~ipyros.processes.launched.LaunchedBase`'s.
    """

    def __init__(self, base: BaseModel, basenode: BaseProcess, *, node: str, master_uri: str,
                 on_rest_exit: Optional[OnExit] = None) -> None:
        """``base`` as declared (launch file, node in it, params); ``basenode`` its process, running as ``node``."""
        super().__init__(base, basenode, node=node, on_rest_exit=on_rest_exit)
        self.params = dict(base.params)
        self.master_uri = master_uri
        self.not_started: list[str] = []  # nodes of the rest that roslaunch could not start (it goes on without)
        self.rest = BaseProcess(
            [sys.executable, "-m", "ipyros.ros1.launch_rest", self.launch,
             *[f"{name}:={value}" for name, value in base.launch_args.items()], "--exclude", base.launch_node or ""],
            env={"ROS_MASTER_URI": master_uri, "ROS_PACKAGE_PATH": package_path()}, on_exit=self._rest_exited,
            log_path=temp_log(f"rest-of-{Path(self.launch).stem}"),
        )

    def start(self, timeout: float = 30.0) -> "LaunchBase":
        """Start the rest, wait until it runs, set the basenode's params, start the basenode.

        On failure whatever started keeps running until :meth:`stop` (the wrapping node's
        shutdown calls it), so the caller owns one handle for all of it.
        """
        self.rest.start()
        self._wait_until_running(timeout)
        self._up = True
        self._set_params()
        self.basenode.start()
        return self

    def rest_stop_timeout(self, timeout: float) -> float:
        return max(timeout, RUNNER_STOP_TIMEOUT)  # roslaunch's own patience with each node

    def __repr__(self) -> str:
        rest = f"running, pid {self.rest.pid}" if self.rest.running else "not running"
        return f"<LaunchBase {self.node} from {self.launch}: {self.basenode!r}; rest of the launch {rest}, " \
               f"log {self.rest.log_path}>"

    # -- steps ------------------------------------------------------------------
    def _wait_until_running(self, timeout: float) -> None:
        """Block until the runner says the rest runs; raise its one-line failure if it ends first."""
        deadline = time.monotonic() + timeout
        while True:
            text = _read(self.rest.log_path)
            if READY in text:
                self.not_started = [name.strip() for line in text.splitlines() if line.startswith(NOT_STARTED)
                                    for name in line[len(NOT_STARTED):].split(",") if name.strip()]
                return
            if not self.rest.running:
                failure = next((line.split(FAILED, 1)[1].strip() for line in text.splitlines() if FAILED in line),
                               None)
                raise BaseNodeError(failure or f"the rest of {self.launch} ended at start; its log: "
                                    f"{' | '.join(self.rest.tail(5))}")
            if time.monotonic() > deadline:
                raise BaseNodeError(f"the rest of {self.launch} did not start within {timeout:g} s; "
                                    f"see its log {self.rest.log_path}")
            time.sleep(0.05)

    def _set_params(self) -> None:
        """The basenode's private params, set where roslaunch would have set them (``/ns/name/key``)."""
        if not self.params:
            return
        proxy = master_proxy(self.master_uri, timeout=5.0)
        try:
            for key, value in self.params.items():
                code, message, _ = proxy.setParam("/ipyros", f"{self.node}/{key}", value)
                if code != 1:
                    raise BaseNodeError(f"cannot set {self.node}/{key}: {message}")
        except (OSError, OverflowError, TypeError) as error:
            raise BaseNodeError(f"cannot set the params of {self.node} on the master {self.master_uri}: "
                                f"{error}") from None


def _read(path: Path) -> str:
    try:
        return path.read_text(encoding="utf-8", errors="replace")
    except FileNotFoundError:
        return ""


# -- the runner's side -----------------------------------------------------------------------

_PR_SET_PDEATHSIG = 1


def _nodes_die_with_runner() -> None:
    """Make every node roslaunch starts get SIGTERM when this runner dies.

    roslaunch forks each node into a session of its own (``preexec_fn=os.setsid``), out
    of reach of a signal to the runner's process group; if the runner were SIGKILLed
    its nodes would be orphans. roslaunch looks ``os.setsid`` up in its module when it
    forks, so handing that module an ``os`` whose ``setsid`` also sets the death
    signal changes nothing else. roslaunch forks from its main thread (which lives as
    long as the runner) and respawns from its process monitor thread (likewise).
    """
    import roslaunch.nodeprocess

    libc = ctypes.CDLL(None, use_errno=True)
    runner = os.getpid()

    class _OsWithDeathSignal:
        def __getattr__(self, name: str) -> Any:
            return getattr(os, name)

        @staticmethod
        def setsid() -> int:
            sid = os.setsid()
            libc.prctl(_PR_SET_PDEATHSIG, signal.SIGTERM)
            if os.getppid() != runner:  # the runner died before prctl took effect
                os._exit(1)
            return sid

    roslaunch.nodeprocess.os = _OsWithDeathSignal()  # type: ignore[assignment]


def _attached_parent(run_id: str, launch: str):
    """A ``ROSLaunchParent`` that attaches to the running master and refuses to start one.

    It also notes the nodes roslaunch could not start (``not_started``): roslaunch
    goes on without them, printing an error, and so does the rest; the session is told.
    """
    from roslaunch.core import RLException
    from roslaunch.parent import ROSLaunchParent


    class AttachedParent(ROSLaunchParent):
        not_started: list[str]

        def _init_runner(self) -> None:
            super()._init_runner()
            self.not_started = []
            runner = self.runner
            launch_master, launch_node = runner._launch_master, runner.launch_node

            def attach_only() -> bool:
                if not self.config.master.is_running():
                    raise RLException(f"no ROS master answers at {self.config.master.uri}; the rest of a launch file "
                                      "runs on the session's master only")
                return launch_master()

            def launch_noting(node: Any, core: bool = False) -> Any:
                proc, success = launch_node(node, core)
                if not success:
                    self.not_started.append(fullname(node))
                return proc, success

            runner._launch_master = attach_only
            runner.launch_node = launch_noting

    return AttachedParent(run_id, [launch], is_core=False, sigint_timeout=NODE_SIGINT_TIMEOUT,
                          sigterm_timeout=NODE_SIGTERM_TIMEOUT)


def run(launch: str, exclude: str, args: Optional[dict[str, str]] = None) -> int:
    """Run ``launch`` (with ``args``) without node ``exclude`` until SIGINT or SIGTERM; print READY once it runs."""
    import roslaunch
    import roslaunch.rlutil
    from roslaunch.core import RLException


    def failed(message: str) -> int:
        print(f"{FAILED} {launchfile.one_line(message)}", flush=True)
        return 2

    try:
        config = launchfile.without(launchfile.load(launch, args), exclude)
    except IpyrosError as error:
        return failed(str(error))
    if not config.master.is_running():  # checked again by the parent, at the moment it matters
        return failed(f"no ROS master answers at {config.master.uri}; the rest of {launch} was not started")
    try:
        config.assign_machines()  # as roslaunch does: the rest may have nodes on other machines
    except RLException as error:
        return failed(f"roslaunch cannot assign the machines of {launch}: {error}")
    _nodes_die_with_runner()
    run_id = roslaunch.rlutil.get_or_generate_uuid(None, False)
    roslaunch.configure_logging(run_id)
    parent = _attached_parent(run_id, str(launchfile.launch_path(launch)))
    parent.config = config  # the loaded file without the wrapped node: the parent does not load it again
    try:
        parent.start(auto_terminate=False)
    except (RLException, OSError) as error:
        parent.shutdown()
        return failed(f"roslaunch could not start the rest of {launch}: {error}")
    if getattr(parent, "not_started", None):  # set once roslaunch's runner exists
        print(f"{NOT_STARTED} {', '.join(parent.not_started)}", flush=True)
    names = ", ".join(sorted(launchfile.fullname(n) for n in config.nodes if n.name)) or "no nodes, params only"
    print(f"{READY} {launch} without {exclude}: {names}", flush=True)
    if not parent.pm.get_active_names():
        # Params only: roslaunch would exit now. Stay until told to stop, so that the
        # session sees the rest "running" as long as the wrapping node runs.
        signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGINT, signal.SIGTERM})
        if not parent.pm.is_shutdown:  # a signal that came before the mask went to roslaunch's handler
            signal.sigwait({signal.SIGINT, signal.SIGTERM})
        parent.shutdown()
        return 0
    parent.spin()  # until SIGINT/SIGTERM (roslaunch's handlers stop the nodes), or a required node dies
    return 0


def main(argv: Optional[list[str]] = None) -> int:
    parser = argparse.ArgumentParser(
        prog="python -m ipyros.ros1.launch_rest",
        description="Run a launch file without one of its nodes, on the running ROS master (ipyros runs that node).")
    parser.add_argument("launch", help="the launch file: a path, or $(find pkg)/launch/x.launch")
    parser.add_argument("--exclude", required=True, help="full name of the node not to start, e.g. /robot1/planner")
    parser.add_argument("args", nargs="*", metavar="NAME:=VALUE", help="the launch file's args, as for roslaunch")
    options = parser.parse_args(argv)
    args = dict(word.split(":=", 1) for word in options.args if ":=" in word)
    return run(options.launch, options.exclude, args)


if __name__ == "__main__":
    sys.exit(main())
