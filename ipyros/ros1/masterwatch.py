"""Watching the ROS master: noticing when it goes away and when it comes back.

A ROS 1 node registers its topics and services with the master once, at start. When the
master is restarted (same URI, a new process) it knows nothing: ``rostopic list`` and
``rosnode info`` no longer show the node, and a new subscriber never finds its publisher,
although the connections made before keep working. rospy and roscpp nodes do not notice.

:class:`MasterWatch` asks the master for its pid every ``period`` seconds (one short XML-RPC
call with a timeout): no answer means down, an answer from another pid means restarted.
It calls ``on_down`` once when the master stops answering and ``on_back`` once when it
answers again; the session then registers everything of its own again
(:meth:`ipyros.ros1.connection.MasterConnection.back`). :meth:`check_now` probes in the caller's
thread, for a magic that must not show a graph the session has not registered in yet.
"""

from __future__ import annotations

import threading
import xmlrpc.client
from typing import Callable, Optional

from .master import master_proxy


def master_pid(uri: str, timeout: float = 1.0) -> Optional[int]:
    """The pid of the master at ``uri``, or None if it does not answer within ``timeout`` seconds."""
    try:
        code, _, pid = master_proxy(uri, timeout).getPid("/ipyros_watch")
    except (OSError, xmlrpc.client.Error):
        return None
    return pid if code == 1 else None


class MasterWatch:
    """Calls ``on_down()`` when the master stops answering, ``on_back(restarted)`` when it answers again."""

    def __init__(self, uri: str, on_down: Callable[[], None], on_back: Callable[[bool], None],
                 period: float = 0.5, timeout: float = 1.0) -> None:
        self.uri, self.period, self.timeout = uri, period, timeout
        self._on_down, self._on_back = on_down, on_back
        self.up = True
        self.pid: Optional[int] = master_pid(uri, timeout)
        self._lock = threading.Lock()  # one probe's transition at a time
        self._settled = threading.Event()  # cleared while a change is acted on
        self._settled.set()
        self._stop = threading.Event()
        self._thread: Optional[threading.Thread] = None

    def start(self) -> "MasterWatch":
        self._thread = threading.Thread(target=self._loop, name="ipyros-master-watch", daemon=True)
        self._thread.start()
        return self

    def stop(self) -> None:
        self._stop.set()
        if self._thread is not None and self._thread is not threading.current_thread():
            self._thread.join(self.timeout + self.period + 1.0)

    def _loop(self) -> None:
        while not self._stop.wait(self.period):
            try:
                self.check_now()
            except Exception:  # noqa: BLE001 - the watch must outlive a failing callback
                pass

    def check_now(self) -> bool:
        """Probe the master now, act on any change; whether it is up.

        The state changes under a lock, so each change is acted on once; the callbacks run
        outside it (they take the nodes' locks, which a caller of this may hold). A caller
        arriving while another thread acts on a change waits for it (a few seconds at most):
        what it reads next is the graph after the session registered again.
        """
        with self._lock:
            pid = master_pid(self.uri, self.timeout)
            was_up, last = self.up, self.pid
            self.up = pid is not None
            if pid is not None:
                self.pid = pid
            changed = (was_up and pid is None) or (pid is not None and (not was_up or pid != last))
            if changed:
                self._settled.clear()
        if not changed:
            self._settled.wait(5.0)
            return pid is not None
        try:
            if pid is None:
                self._on_down()
            else:
                self._on_back(last is not None and pid != last)
        finally:
            self._settled.set()
        return pid is not None
