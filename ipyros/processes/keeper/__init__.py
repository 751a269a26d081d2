"""The keeper: the one process of ipyros on a robot's own machine, which runs there what a session places on it.

A session on a laptop reaches the robot over Wi-Fi; the link is what fails most. So a guard that
must hold when the link is lost runs on the robot (``nd.guard(topic, ..., machine="robot1")``):
the session's writes go to the keeper, whose gate checks them and publishes them on the robot,
and whose stop process (:mod:`ipyros.processes.sentinel`, started on the robot) sends the stop
message on silence, on an e-stop, and for as long as the session is not heard (its *lease*).

Everything the keeper and a session say to each other goes over ROS, under one namespace of the
keeper's own (:func:`namespace`), as ``std_msgs/String`` texts:

====================================  =============================================================
topic (under ``/ipyros/machines/NAME``)  what
====================================  =============================================================
``info`` (latched)                    the keeper: its name, ROS, host, its start
                                      (``epoch``), the guards placed on it
``request``                           a session's request, signed with the machine's token
``reply``                             the keeper's answer, addressed to the request's sender and
                                      counter
``guards/ID/in``                      the session's messages for guard ``ID`` (the guarded type)
``guards/ID/beat``, ``beat2``, ...    the session's heartbeat for that guard, signed (the same beats on
                                      :data:`BEAT_LINES` topics: see there)
``guards/ID/state`` (latched)         what the guard does, as the session's ``%status`` shows it
``bases/ID/beat``, ...                the session's heartbeat for basenode ``ID``, signed
``bases/ID/state`` (latched)          the basenode's process: running, its pid, how it ended
====================================  =============================================================

A basenode placed on the machine (``baseNode(EXE).basePackage(PKG).machine("robot1")``) runs as the
keeper's child, found as rosrun finds it, and only from a package the keeper was started to allow
(``--allow PKG``): by its package and executable names, never a path, never a shell. It ends with
the keeper, and when its session is not heard for its grace.

A request is ``{"body": TEXT, "sig": HMAC}``: the HMAC-SHA256, under the token, of the body's exact
text, which names the keeper's ``epoch`` (a request for an earlier start of the keeper is refused),
its sender and a counter that only grows (a request replayed is refused). The token is a file made
at the keeper's first start (mode 0600); a session reads it from the same place (:func:`token_path`),
copied there by the user as an SSH key is. Nothing sent runs as code: a request names settings and
numbers, never a path, a shell line or source text.

This package is ROS-free; what subscribes and publishes is :class:`KeeperRos`, one small adapter a ROS
(``ipyros.ros1.machine``, ``ipyros.ros2.machine``). Its modules, one concern each: ``lease`` (the token,
signed requests and heartbeats, the lease), ``ros`` (what the keeper asks of its ROS, its reports),
``guards``, ``bases`` and ``relays`` (what sessions place on it), ``serving`` (the keeper itself, and
how it runs in its process).
"""

from __future__ import annotations

from .bases import KeptBase
from .guards import GUARD_START, KeptGuard
from .lease import (BEAT_LINES, Lease, MachineError, Refused, Token, Verifier, beat_text, beat_topics,
                    check_machine_name, namespace, token_path)
from .relays import KeptRelay, KeptRelays
from .ros import REPORT, Closing, KeeperRos, Keeping, Lookup, Outlet, Reporter, child_env
from .serving import LOOK, Keeper, log_line, serve, unknown_packages

__all__ = ["BEAT_LINES", "GUARD_START", "LOOK", "REPORT", "Closing", "Keeper", "KeeperRos", "Keeping", "KeptBase", "KeptGuard",
           "KeptRelay", "KeptRelays", "Lease", "Lookup", "MachineError", "Outlet", "Refused", "Reporter", "Token",
           "Verifier", "beat_text", "beat_topics", "check_machine_name", "child_env", "log_line", "namespace", "serve",
           "token_path", "unknown_packages"]
