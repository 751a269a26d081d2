"""The session: this interpreter's ROS (one backend), the DSL nodes living in it, and their history.

There is one session per interpreter (rospy allows one node per process; on ROS 2 one
context and one executor serve every node); it is created on first use (``current()``) and
closed at interpreter exit, stopping everything ipyros started: nodes, basenodes, and on
ROS 1 the master if ipyros started it. What differs between the two ROS (a master to find,
start and watch) is the backend's: the session reads the same on both.
"""

from __future__ import annotations

import atexit
import contextlib
import contextvars
import ctypes
import difflib
import os
import signal
import sys
import threading
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable, Iterator, Optional, Protocol

from ..core import msgtypes
from ..core.errors import NodeStateError, NotDeclaredError, shorten
from ..core.graph import EMPTY, GraphSnapshot, actions_of
from ..core.journal import Change, Journal
from ..core.progress import Progress, no_progress
from ..core.model import NodeModel
from ..core.sessionlink import RunningBase
from ..core.slots import HandlerFailure, OutputScope
from ..processes.basenode import BaseHandle, stop_together
from .backend import Backend, choose as choose_backend
from .guards import Watch


class SessionNode(Protocol):
    """What the session needs of its nodes (each is a :class:`~ipyros.node.engine.NodeEngine`, which uses the
    session: named here as a protocol, so that the session does not import the engine back)."""

    @property
    def name(self) -> str: ...
    @property
    def fullname(self) -> str: ...
    @property
    def called(self) -> str: ...  # how advice names it (the user's variable)
    created: bool
    def model(self) -> NodeModel: ...  # a copy
    def declared(self) -> NodeModel: ...  # as it stands, for reading alone
    def release_base(self) -> Any: ...  # its running basenode (stop()), handed over to be stopped elsewhere
    @property
    def base(self) -> Optional[BaseHandle]: ...  # its basenode, while it has one
    @property
    def basenode_name(self) -> Optional[str]: ...
    def register_params(self) -> int: ...
    def quieten(self) -> None: ...
    def shutdown(self) -> None: ...


#: Who makes the changes recorded now, when not the person at the prompt (``with made_by("the agent, #3"): ...``).
MADE_BY: contextvars.ContextVar[Optional[str]] = contextvars.ContextVar("made_by", default=None)


@contextlib.contextmanager
def made_by(who: str) -> Iterator[None]:
    """The changes recorded within the block are said to be made by ``who`` (in the history and its file)."""
    token = MADE_BY.set(who)
    try:
        yield
    finally:
        MADE_BY.reset(token)


def print_notice(text: str) -> None:
    """Default report of something that happened on its own: a line on stderr."""
    sys.stderr.write(text.rstrip("\n") + "\n")
    sys.stderr.flush()


def print_failure(failure: HandlerFailure) -> None:
    """Default report of a handler exception: the handler's traceback on stderr."""
    more = f" ({failure.suppressed} more since the last report)" if failure.suppressed else ""
    sys.stderr.write(f"ipyros: handler {failure.handler} failed on {failure.label}{more}; "
                     f"the node keeps running\n{failure.traceback}")
    sys.stderr.flush()


@dataclass
class SessionConfig:
    """How the session finds its master and names its ROS node."""

    master_uri: Optional[str] = None  # None: ROS_MASTER_URI, else http://localhost:11311
    start_master: bool = True  # start one on localhost when none answers
    process_node_name: Optional[str] = None  # None: the first node created names it
    keep_recent: int = 20  # messages each subscription keeps for trying a handler on them
    history_dir: Optional[str] = None  # None: $IPYROS_HISTORY_DIR, else ~/.ipyros/history
    keep_history: bool = True  # write the history to a file of this session's own as it goes
    restart_basenodes: bool = False  # restart basenodes that do not register with a restarted master
    announce: Callable[[str], None] = field(default=lambda text: print(text, file=sys.stderr))


class Session:
    """Everything ipyros runs in this interpreter: one backend (one ROS), the DSL nodes, the history."""

    def __init__(self, config: Optional[SessionConfig] = None) -> None:
        self.config = config or SessionConfig()
        self.backend: Backend = choose_backend()
        self.process = self.backend.process
        self.nodes: dict[str, SessionNode] = {}  # full name → the engine of a DSL node, in creation order
        self.history: list[Change] = []  # every change of every node, in order
        self._journal: Optional[Journal] = None
        self._on_close: list[Callable[[], None]] = []
        self.report: Callable[[HandlerFailure], None] = print_failure
        self.notice: Callable[[str], None] = print_notice  # a basenode died, a relay got the wrong type, ...
        #: Who else hears each notice (an agent's server, ...): :meth:`listen` adds one, and gives back its removal.
        self._listeners: list[Callable[[str], None]] = []
        #: How advice names a node (``nd.base.restart()``): the extension finds the user's variable.
        self.call_name: Callable[[Any], str] = lambda node: node.name
        #: Where a node created now has its handlers print (the extension gives Jupyter cells an area).
        self.output_scope: Callable[[Any], Optional[OutputScope]] = lambda node: None
        #: The graph as last read, never waited for (the extension's cache): what TAB offers after
        #: ``nd.reuse.publish.``; empty without one.
        self.known_graph: Callable[[], GraphSnapshot] = lambda: EMPTY
        #: How long work shows its progress (``%try --bag``, ``%bag convert``): drawn by the front end, nowhere in a
        #: script (see :mod:`ipyros.core.progress`).
        self.progress: Progress = no_progress
        self._lock = threading.RLock()
        self._closing: Optional[threading.Thread] = None  # the thread that closes the session, once one does
        self._closed = threading.Event()  # set once it closed
        self.closed = False
        self._closes_at_exit = False
        self._guard_watch: Optional[Any] = None
        #: The node whose bag's /clock the session runs on (``baseBag(..., clock=True)``), if any.
        self.bag_clock: Optional[str] = None

    @property
    def guard_watch(self) -> Any:
        """The one thread that tells the prompt what the session's guards' processes did (made on first use)."""
        if self._guard_watch is None:
            self._guard_watch = Watch(self.notify)
        return self._guard_watch

    def record(self, node: str, change: str, **handler: Any) -> Change:
        """Add a change to the session's history, and to its file (see :mod:`ipyros.core.journal`)."""
        entry = Change(time.time(), node, change, **handler, by=MADE_BY.get())
        self.history.append(entry)
        journal = self.journal
        if journal is not None:
            try:
                journal.append(entry)
            except OSError as error:
                self.notify(f"ipyros: cannot write the history file in {journal.directory} ({error.strerror or error}); "
                            "the history is kept in memory only: set SessionConfig.history_dir")
        return entry

    @property
    def journal(self) -> Optional[Journal]:
        """Where the history is written, or None if not kept (``keep_history=False``)."""
        if self._journal is None and self.config.keep_history:
            directory = self.config.history_dir
            self._journal = Journal(Path(directory).expanduser() if directory else None)
        return self._journal

    def register_params_again(self) -> int:
        """Every created node's parameters registered again (a ROS 1 master is back); how many there were."""
        return sum(node.register_params() for node in list(self.nodes.values()) if node.created)

    def running_basenodes(self) -> list[RunningBase]:
        """The basenodes running now, as the backend may need them (see :mod:`ipyros.core.sessionlink`)."""
        found = []
        for node in list(self.nodes.values()):
            base, name = node.base, node.basenode_name
            if base is not None and base.running and name is not None:
                found.append(RunningBase(name, node.name, node.called, base.restart))
        return found

    def notify(self, text: str) -> None:
        """Tell the user something that happened on its own (a basenode died, ...); each line :func:`shorten`-ed.

        The prompt hears it through :attr:`notice`, and every listener added by :meth:`listen` hears it too; a
        listener that raises is taken off, said once, and never stops the others.
        """
        said = "\n".join(shorten(line) for line in text.split("\n"))
        self.notice(said)
        for listener in list(self._listeners):
            try:
                listener(said)
            except Exception as error:  # noqa: BLE001 - one listener's fault is not the session's
                self.unlisten(listener)
                self.notice(f"ipyros: a listener of the session's notices raised {type(error).__name__}: {error}; "
                            "it hears no more")

    def listen(self, listener: Callable[[str], None]) -> Callable[[], None]:
        """``listener(text)`` hears every notice from now on, beside the prompt; the call it returns ends that."""
        self._listeners.append(listener)
        return lambda: self.unlisten(listener)

    def unlisten(self, listener: Callable[[str], None]) -> None:
        if listener in self._listeners:
            self._listeners.remove(listener)

    def start_process_node(self, fullname: str) -> str:
        """Start this process's ROS side (on ROS 1 the master is found or started first) once; its node's name."""
        with self._lock:
            if self.closed:
                raise NodeStateError("this ipyros session was closed; restart the interpreter")
            name = self.backend.start(fullname, self)
            self._close_before_ros_at_exit()
            stop_on_termination()
            return name

    def send_goal(self, name: str, goal: Any, action_type: Any, feedback: Optional[Callable[[Any], None]],
                  timeout: float) -> Any:
        """Send ``goal`` to action ``name`` (a global name) from this process; its type is read from the
        graph when not given. Returns a :class:`~ipyros.core.actions.SentGoal`."""
        self.require_graph(f"send a goal to {name}")
        if action_type is None:
            found = {a.name: a for a in actions_of(self.backend.graph_snapshot())}
            if name not in found:
                close = difflib.get_close_matches(name, list(found), n=3)
                hint = f"; did you mean {', '.join(close)}?" if close else " (%actions lists the actions there are)"
                raise NotDeclaredError(f"no action {name} in the graph; give its type=..., or start its server{hint}")
            action_type = found[name].type
        _, cls = msgtypes.resolve_action(action_type)
        return self.backend.send_goal(name, cls, goal, feedback, timeout)

    def require_graph(self, doing: str) -> None:
        """Fail in a moment when the graph cannot be reached (ROS 1: the master does not answer), rather than hang.

        rospy retries registering a new endpoint with an absent master forever, freezing the
        prompt; so whatever would register something asks here first.
        """
        self.backend.require_graph(doing)

    def _close_before_ros_at_exit(self) -> None:
        """Close the session at exit before the ROS client library shuts itself down.

        rospy (and rclpy) register their own exit hooks when they start, after this module's:
        hooks run last-registered first, so theirs closed every publisher while the nodes'
        timers still ran, and a timer's last write printed a traceback on the way out. This
        hook, registered once the client library has started, runs before theirs.
        """
        if not self._closes_at_exit:
            atexit.register(self.close)
            self._closes_at_exit = True

    def add(self, node: SessionNode) -> None:
        with self._lock:
            other = self.nodes.get(node.fullname)
            if other is not None and other is not node and other.created:
                raise NodeStateError(f"a node named {node.fullname} is already running in this session "
                                     f"({other.called}); shut it down first ({other.called}.shutdown()) or pick "
                                     "another name")
            self.nodes[node.fullname] = node

    def remove(self, node: SessionNode) -> None:
        with self._lock:
            if self.nodes.get(node.fullname) is node:
                del self.nodes[node.fullname]

    def on_close(self, stop: Callable[[], None]) -> None:
        """Have ``stop`` run first when the session closes (things started beside the nodes: the demo robot)."""
        if stop not in self._on_close:
            self._on_close.append(stop)

    def shutdown_nodes(self, nodes: Optional[list[SessionNode]] = None) -> None:
        """Shut ``nodes`` down (default: every node of the session) side by side: their handlers quietened first
        (one node's handler may write through another), their basenodes all asked to stop at once and waited for
        together while the nodes' own endpoints close (one after another, 50 basenodes took most of a minute)."""
        nodes = list(self.nodes.values()) if nodes is None else nodes
        for node in nodes:
            node.quieten()
        self.backend.closing_hosts([node.fullname for node in nodes])
        bases = [base for base in (node.release_base() for node in nodes) if base is not None]
        stopping = threading.Thread(target=stop_together, args=(bases,), name="ipyros-stop-basenodes", daemon=True)
        try:
            stopping.start()
        except RuntimeError:  # at interpreter exit (Python 3.12 on) no thread may start: stopped here
            stop_together(bases)
        for node in reversed(nodes):
            try:
                node.shutdown()
            except Exception as error:  # keep closing the rest
                print(f"ipyros: error while shutting down {node.fullname}: {error}", file=sys.stderr)
        if stopping.ident is not None:
            stopping.join()

    def close(self) -> None:
        """Stop every node and basenode, the ROS side of this process, and the master if ipyros started it.

        The session's lock is held only to mark it closed: a node's own ``create()`` or ``shutdown()``, going on in
        another thread, takes the node's lock and then the session's, and a closing that held the session's while
        waiting for the node's would wait for ever (SIGTERM while a Ctrl-C'd ``create()`` stops its basenode). A
        second caller waits until the first has closed it (the interpreter's exit after a terminating signal)."""
        with self._lock:
            if self.closed:
                closing = self._closing
                if closing is not None and closing is not threading.current_thread():
                    self._closed.wait()
                return
            self.closed, self._closing = True, threading.current_thread()
        try:
            self.backend.closing()
            for stop in reversed(self._on_close):
                try:
                    stop()
                except Exception as error:  # keep closing the rest
                    print(f"ipyros: error while closing: {error}", file=sys.stderr)
            self.shutdown_nodes()
            self.backend.close()
            if self._journal is not None:
                self._journal.close()
        finally:
            self._closed.set()


_current: Optional[Session] = None
_current_lock = threading.Lock()


def current() -> Session:
    """The session of this interpreter, created on first use."""
    global _current
    with _current_lock:
        if _current is None or _current.closed:
            _current = Session()
        return _current


def started() -> bool:
    """Whether this interpreter's session exists (it picks its ROS when it is made)."""
    return _current is not None and not _current.closed


def configure(config: SessionConfig) -> Session:
    """Set how the session attaches, before anything has started (another master than the one in use is refused)."""
    session = current()
    session.backend.check_config(session, config.master_uri)
    session.config = config
    return session


@atexit.register
def _close_at_exit() -> None:
    if _current is not None:
        _current.close()


#: Signals that end the process without Python's exit: ``kill PID``, ``timeout``, a service
#: manager (SIGTERM), the terminal closing (SIGHUP).
TERMINATING = (signal.SIGTERM, signal.SIGHUP)


def stop_on_termination() -> None:
    """Make SIGTERM and SIGHUP stop the session as cleanly as Ctrl-C at exit does.

    By default these signals end the process at once: no atexit, so the master keeps the
    session's node and its basenodes as dead entries (``rosnode list`` shows them, ``rosnode
    ping`` fails) and a C++ basenode, which dies on SIGTERM without unregistering, stays
    listed too. Installed only from the main thread, and only over the default action: a
    handler the program set itself is left alone.
    """
    if threading.current_thread() is not threading.main_thread():
        return
    for signum in TERMINATING:
        if signal.getsignal(signum) is signal.SIG_DFL:
            signal.signal(signum, _terminated)


#: How long the session may take to close once a terminating signal came, before it dies all the same (s).
TERMINATION_DEADLINE = 10.0
_terminating: list[threading.Thread] = []  # the closing thread, once a terminating signal came


def _terminated(signum: int, frame: Any) -> None:
    """Close the session (nodes unregistered, basenodes stopped with SIGINT) on a thread of its own, which then makes
    the process die of ``signum``; a second terminating signal meanwhile dies at once.

    The main thread is not held here: it may be inside ipyros holding a lock the closing needs (a ``create()``
    interrupted by Ctrl-C, stopping its basenode), and it lets go of it only by going on. The closing waits for
    it, and for nothing longer than :data:`TERMINATION_DEADLINE`.
    """
    if _terminating:
        _die(signum)
    closing = threading.Thread(target=_close_then_die, args=(signum,), name="ipyros-terminated", daemon=True)
    _terminating.append(closing)
    closing.start()


def _close_then_die(signum: int) -> None:
    deadline = threading.Timer(TERMINATION_DEADLINE, _die, args=(signum,))
    deadline.daemon = True
    deadline.start()
    try:
        _close_at_exit()
    finally:
        _die(signum)


def _die(signum: int) -> None:
    """End the process of ``signum``, as it would have ended without ipyros (from any thread: Python's signal
    module sets handlers from the main thread only, so the default action is set through libc)."""
    ctypes.CDLL(None).signal(signum, ctypes.c_void_p(0))  # SIG_DFL
    os.kill(os.getpid(), signum)
