"""The ROS 1 master a session uses: found or started, required before anything registers, watched, and told
everything again after a restart.

ROS 2 has no master; on ROS 1 these are the session's duties, kept here so that the
session (:mod:`ipyros.node.session`) is the same on both: the ROS 1 backend does them
when the session asks it to start, to check the graph, and to close.

* :meth:`MasterConnection.attach` finds the master at ``ROS_MASTER_URI`` (or the URI
  configured), or starts one on this machine when allowed (:mod:`.master`).
* :meth:`MasterConnection.require` fails in a moment when the master does not answer:
  rospy would retry registering a new endpoint with an absent master forever, freezing
  the prompt.
* a :class:`~ipyros.ros1.masterwatch.MasterWatch` tells when the master goes and comes
  back; then every endpoint and parameter of the session is registered again, and the
  basenodes that do not register again by themselves (ROS 1 nodes do not) are restarted
  or reported.
"""

from __future__ import annotations

import threading
from typing import Optional

from ..core.errors import MasterError
from ..core.sessionlink import SessionLink, restart_unregistered
from . import master as master_mod
from .masterwatch import MasterWatch
from .runtime import ProcessNode

__all__ = ["MasterConnection"]


class MasterConnection:
    """A session's ROS master and its watch; the session is known by its link (:mod:`ipyros.core.sessionlink`): its
    settings, its notices, and what its nodes do again when the master comes back."""

    def __init__(self, process: ProcessNode) -> None:
        self.process = process  # the process node, registered again after a restart
        self.master: Optional[master_mod.MasterHandle] = None
        self.watch: Optional[MasterWatch] = None
        self._session: Optional[SessionLink] = None
        self._lock = threading.RLock()

    @property
    def uri(self) -> str:
        """The master's URI: the one in use, else the one configured."""
        if self.master is not None:
            return self.master.uri
        configured = self._session.config.master_uri if self._session is not None else None
        return _slashed(configured or master_mod.configured_uri())

    def attach(self, session: SessionLink) -> master_mod.MasterHandle:
        """The master in use, found or started (if the session's settings allow) on first call."""
        with self._lock:
            self._session = session
            if self.master is None:
                self.master = master_mod.attach(session.config.master_uri, session.config.start_master)
                if self.master.started:
                    session.config.announce(f"ipyros: {self.master.describe()}")
                advice = master_mod.callback_advice(self.master.uri)
                if advice is not None:
                    session.config.announce(advice)
            return self.master

    def check_config(self, session: SessionLink, master_uri: Optional[str]) -> None:
        """Refuse, in one line, another master than the one in use."""
        self._session = session
        if self.master is not None and master_uri not in (None, self.master.uri):
            raise MasterError(f"this session already uses the master at {self.master.uri}; "
                              "restart the interpreter to use another one")

    def start_watch(self, session: SessionLink) -> None:
        if self.watch is None and self.master is not None:
            self.watch = MasterWatch(self.master.uri, self._down, self.back).start()

    def require(self, doing: str) -> None:
        """Fail in a moment when the master does not answer, rather than hang (see the module's docstring)."""
        if self.master is None:
            return
        up = self.watch.check_now() if self.watch is not None else master_mod.answers(self.master.uri, 2.0)
        if not up:
            raise MasterError(f"the ROS master at {self.master.uri} does not answer, so {doing} was not done "
                              "(nothing changed); do it again when the master is back (ipyros registers "
                              "your running nodes with it again by itself)")

    def check_now(self) -> None:
        """If the master just restarted, register again now (before a magic reads the graph)."""
        if self.watch is not None:
            self.watch.check_now()

    def closing(self) -> None:
        """The session closes: stop watching; with the master gone, rospy's "could not unregister" is no news."""
        if self.watch is not None:
            self.watch.stop()
        if self.master is not None and self.process.started and not master_mod.answers(self.master.uri, 0.3):
            self.process.master_gone()

    def stop(self) -> None:
        """Stop the master if ipyros started it (after the session's nodes are gone)."""
        if self.master is not None:
            self.master.stop()

    # -- the master going away and coming back ------------------------------------------
    def _down(self) -> None:
        if self._session is not None:
            self._session.notify(f"ipyros: the ROS master at {self.uri} does not answer; your nodes keep the "
                                 "connections they have, new declarations fail until it is back")

    def back(self, restarted: bool) -> None:
        """The master answers again: register every endpoint and parameter of the session with it again.

        Basenodes (rospy and roscpp nodes do not register again by themselves) are checked a
        moment later: restarted if ``restart_basenodes`` is set, else reported with the line
        that restarts them.
        """
        session, uri = self._session, self.uri
        assert session is not None  # watched only once attached
        try:
            publications, subscriptions, services = self.process.register_again()
            params = session.register_params_again()
        except Exception as error:  # noqa: BLE001 - told, not raised: this runs on the watch thread
            session.notify(f"ipyros: the ROS master at {uri} is back, but registering this session with it failed "
                           f"({error}); restart the interpreter if topics stay missing")
            return
        session.notify(f"ipyros: the ROS master at {uri} is back{' (restarted)' if restarted else ''}: "
                       f"registered {publications} publications, {subscriptions} subscriptions, {services} services "
                       f"and {params} parameters of this session again")
        check = threading.Timer(2.0, self._check_basenodes)
        check.daemon = True
        check.start()

    def _check_basenodes(self) -> None:
        """After a master restart: the basenodes that did not register again, restarted or reported."""
        session = self._session
        if self.master is None or session is None or session.closed:
            return
        uri = self.master.uri
        for line in restart_unregistered(session.running_basenodes(), lambda name: master_mod.is_registered(uri, name),
                                         session.config.restart_basenodes):
            session.notify(line)


def _slashed(uri: str) -> str:
    return uri if uri.endswith("/") else uri + "/"
