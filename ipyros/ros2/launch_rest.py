"""The rest of a ROS 2 launch file: every node it starts except the one ipyros wraps, as children of the session.

``nd.baseLaunch("robot.launch.xml", "/robot1/planner")`` followed by ``nd.create()``
starts, held by one handle, :class:`LaunchBase` (``nd.base``):

1. **the rest**: each other node of the file (:mod:`.launchfile` reads it again, so an
   edit made since the declaration counts), started as ``ros2 launch`` would start it:
   its executable found in the ament index, its name, namespace, remaps and params on
   the command line, its environment; each a managed child process of the session with a
   log of its own (``nd.base.rest.tail()``), stopped with the wrapping node and at exit;
2. **the basenode**, remapped as for ``baseNode``, at the name it has in the file, its
   params from the file on its command line.

``stop()`` stops the basenode, then the rest. A node of the rest that cannot start (its
executable is not installed) is said once, and the others run without it, as ``ros2
launch`` goes on; one that ends later is told to the session.
"""

from __future__ import annotations

from typing import Optional

from ..core.errors import BaseNodeError
from ..core.model import BaseModel
from ..processes.basenode import BaseProcess, OnExit, stop_together, temp_log
from ..processes.launched import LaunchedBase
from . import launchfile, nodes

__all__ = ["LaunchBase", "Rest"]


class Rest:
    """The other nodes of a launch file, each a :class:`BaseProcess`, by full name (``processes``)."""

    def __init__(self, launched: list[BaseModel], on_exit: OnExit) -> None:
        self.processes: dict[str, BaseProcess] = {}
        self.why: dict[str, str] = {}  # why a node did not start (its executable not found): the rest runs without
        for node in launched:
            name = node.launch_node or node.executable or "?"
            try:
                argv = nodes.command(node)
            except BaseNodeError as error:
                self.why[name] = str(error)
                continue
            self.processes[name] = BaseProcess(argv, node_name=node.node_name, env=node.env, on_exit=on_exit,
                                               log_path=temp_log(f"launched-{name}"))

    @property
    def not_started(self) -> list[str]:
        """The nodes that could not start (said once; the others run without them)."""
        return list(self.why)

    def start(self) -> None:
        for process in self.processes.values():
            process.start()

    def stop(self, timeout: float = 5.0) -> None:
        """Stop every node of the rest, together (a file of many nodes slow to stop takes the slowest one's time)."""
        stop_together(list(self.processes.values()), timeout)

    @property
    def running(self) -> bool:
        return any(process.running for process in self.processes.values())

    def tail(self, n: int = 20) -> list[str]:
        """The last ``n`` lines of each node's log, each line after its node's name; why any did not start."""
        lines = [f"{name}: {why}" for name, why in self.why.items()]
        for name, process in self.processes.items():
            lines += [f"{name}: {line}" for line in process.tail(n)]
        return lines

    def __repr__(self) -> str:
        states = ", ".join(f"{name} {'running' if p.running else 'stopped'}" for name, p in self.processes.items())
        return f"<rest of the launch: {states or 'no node'}>"


class LaunchBase(LaunchedBase):
    """A basenode from a ROS 2 launch file together with the other nodes of that file: started and stopped as one.

    ``rest`` is :class:`Rest`; the rest is :class:`~ipyros.processes.launched.LaunchedBase`'s.
    """

    def __init__(self, base: BaseModel, basenode: BaseProcess, *, node: str,
                 on_rest_exit: Optional[OnExit] = None) -> None:
        super().__init__(base, basenode, node=node, on_rest_exit=on_rest_exit)
        others = [n for n in launchfile.read(self.launch, base.launch_args).nodes if n.launch_node != base.launch_node]
        self.rest = Rest(others, self._rest_exited)

    @property
    def not_started(self) -> list[str]:
        return self.rest.not_started

    def start(self, timeout: float = 30.0) -> "LaunchBase":
        """Start the rest, then the basenode; on failure what started runs until :meth:`stop`.

        Nothing waits for the rest (``ros2 launch`` does not either): a node of it that ends,
        even at once, is told through ``on_rest_exit``.
        """
        self._up = True
        self.rest.start()
        self.basenode.start()
        return self

    def __repr__(self) -> str:
        return f"<LaunchBase {self.node} from {self.launch}: {self.basenode!r}; {self.rest!r}>"
