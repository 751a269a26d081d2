"""A wrapping node's basenode started: remapped onto the node's internal names, waited for until it shows up in
the graph (said at the prompt when that takes a while, with how to stop waiting), its types checked, what it
does not use of the node's ``reuse`` said; and a bag played as the basenode, its clock the session's.

What a basenode is, as declared, is :mod:`.wrapping`'s; reading its interface from the graph, :mod:`.baseinterface`'s.
"""

from __future__ import annotations

import difflib
import threading
from typing import Any, Optional

from ..core.errors import BaseNodeError, DeclarationError, IpyrosError
from ..core.model import BaseModel, NodeModel
from ..core.remapping import base_fullname, base_namespace, base_node_name, basenode_remaps
from ..processes.basenode import BaseHandle, exit_reason
from .placedbase import PlacedBase, placed_problem
from .baseinterface import check_base_types, report_unused_reuses
from .wrapping import WrappingNode, ended_at_start, interrupted


def start_bag_clock(node: "WrappingNode") -> None:
    """A bag played with ``clock=True``: the session runs on its /clock from now on (said in one line); one bag's
    clock at a time."""
    base = node.model().base
    if base is None or not (base.bag or {}).get("clock"):
        return
    session = node.session
    if session.bag_clock not in (None, node.fullname):
        raise DeclarationError(f"{node.called}'s bag would publish /clock, but the bag of {session.bag_clock} does "
                               "already: one bag's time at a time; shut that node down first, or give "
                               "baseBag(..., clock=False)")
    session.bag_clock = node.fullname
    session.notify(session.backend.bag_time(True))


def stop_bag_clock(node: "WrappingNode") -> None:
    """The node whose bag's clock the session ran on stops: the wall clock again (said in one line)."""
    session = node.session
    if session.bag_clock == node.fullname:
        session.bag_clock = None
        session.notify(session.backend.bag_time(False))


# -- the basenode process ------------------------------------------------------------------

#: How long a running basenode may take to show up in the graph (s); one that ends sooner is told at once. Long,
#: because a start can be slow for good reasons (a map loaded; on ROS 2, discovery in a graph of many processes:
#: the 41st basenode of one session took over 10 s on 2 cores); the wait is said once it takes a while.
REGISTRATION_TIMEOUT = 45.0

#: After how long (s) a basenode still starting is said at the prompt, with how to stop waiting.
SLOW_START_NOTICE = 3.0


def start_base(node: "WrappingNode", settle_timeout: Optional[float] = None) -> None:
    """Launch the basenode remapped onto the wrapping node's internal names, and check its types.

    A basenode from a launch file starts after the rest of its file (the backend's
    ``launch_base``); ``node.base`` holds the one handle whose ``stop()`` stops all of it,
    set before anything starts, so that the node's shutdown after a failure half-way stops
    what did start.
    """
    model = node.model()
    if model.base is None:
        return
    session = node.session
    backend = session.backend
    from_launch = model.base.launch is not None
    base = BaseModel(**{**model.base.__dict__, "node_name": base_node_name(model.base),
                        "namespace": base_namespace(model), "remaps": basenode_remaps(model, backend.action_parts),
                        # from a ROS 1 launch file, the params go on the parameter server as roslaunch puts them
                        "params": {} if from_launch and backend.launch_params_on_server else model.base.params})

    starting = threading.Event()  # while set, an exit is create()'s error to raise, not a notice
    starting.set()

    def died(proc: Any, returncode: int, last_lines: list[str]) -> None:
        if starting.is_set():
            return
        tail = "\n    ".join(last_lines[-8:])
        on = f" on {base.machine}" if base.machine else ""
        session.notify(f"ipyros: basenode {base_fullname(model)} of {node.called}{on} {exit_reason(returncode)}; "
                       f"restart it with {node.called}.base.restart()\n    {tail}")

    process: BaseHandle
    if base.machine is not None:  # its machine's keeper runs it
        problem = placed_problem(base)
        if problem is not None:
            raise BaseNodeError(f"{node.called}.machine({base.machine!r}): {problem}; or leave .machine() out")
        process = PlacedBase(base, backend, node.fullname, session.notify, on_exit=died)
    else:
        process = backend.basenode(base, on_exit=died)
        real = backend.note_link(base, process)
        if real is not None:
            session.notify(f"ipyros: {base.package}/{base.executable} is a link to {real}, outside the package; "
                           "that is what runs (as rosrun would run it)")
    handle: Any = process
    if from_launch:
        launch = model.base.launch

        def rest_died(proc: Any, returncode: int, last_lines: list[str]) -> None:
            tail = "\n    ".join(last_lines[-8:])
            what = f"node {proc.node_name}" if getattr(proc, "node_name", None) else "the rest"  # ROS 2: each node
            session.notify(f"ipyros: {what} of {launch} (run for {node.name}) {exit_reason(returncode)}; "
                           f"run it again with {node.called}.shutdown() and {node.called}.create()\n    {tail}")

        handle = backend.launch_base(model.base, process, base_fullname(model), rest_died)
    node.base = handle
    handle.start()
    if getattr(handle, "not_started", None):
        session.notify(f"ipyros: could not start {', '.join(handle.not_started)} of {model.base.launch} "
                       f"(the rest runs without); why: {node.called}.base.rest.tail()")
    timeout = settle_timeout or REGISTRATION_TIMEOUT

    def slow() -> None:
        if starting.is_set() and process.running:
            session.notify(f"ipyros: basenode {base_fullname(model)} of {node.called} runs but is not in the graph "
                           f"yet; waiting up to {timeout:g} s (Ctrl-C stops it and {node.called})")

    notice = threading.Timer(SLOW_START_NOTICE, slow)
    notice.daemon = True
    notice.start()
    try:
        with session.progress(f"waiting for basenode {base_fullname(model)} to show up in the graph"):
            interface = backend.wait_for_node(base_fullname(model), timeout=timeout, alive=lambda: process.running)
        starting.clear()
        if not process.running:  # it ended after settling, before a notice could be sent
            raise BaseNodeError("ended")
    except BaseNodeError:
        if not process.running:
            raise ended_at_start(model, process, f" (nothing of {node.called} was left running)") from None
        raise _never_seen(node, model, timeout) from None
    except KeyboardInterrupt:  # create() stops the basenode and everything else of the node on its way out
        raise interrupted(f"waiting for basenode {base_fullname(model)} of {node.called} to show up in the graph",
                          f"it and the rest of {node.called} were stopped") from None
    finally:
        notice.cancel()
    check_base_types(model, interface)
    report_unused_reuses(node, model, interface)


def names_like(name: str, seen: list[str]) -> list[str]:
    """Up to three of ``seen`` that look like ``name`` (a typo, a namespace, a suffix a launch added), best first;
    none for names that merely share letters, so a hint never points at an unrelated node."""
    return difflib.get_close_matches(name, seen, n=3, cutoff=0.7)


def _never_seen(node: "WrappingNode", model: NodeModel, timeout: float) -> BaseNodeError:
    """The one line for a basenode that ran but never showed up in the graph (create() then stops it): the
    graph's nodes of a name like the one it was given, in case it took another."""
    backend, name = node.session.backend, base_fullname(model)
    try:
        seen = [n for n in backend.graph_snapshot().nodes if n not in node.session.nodes]  # not its own
    except IpyrosError:
        seen = []
    like = names_like(name, seen)
    return BaseNodeError(f"basenode {name} of {node.called} ran {timeout:g} s without showing up in the graph "
                         f"({backend.where()}), so it was stopped; is it a ROS node that keeps the name it is given?"
                         + (f" nodes of a name like it: {', '.join(like)}" if like else ""))
