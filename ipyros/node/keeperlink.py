"""The session's link to a machine's keeper, for one thing it places there (a guard, a basenode).

Everything goes over ROS, under the keeper's namespace (see :mod:`ipyros.processes.keeper`): requests
signed with the machine's token and asked until answered, the keeper's answers addressed to this
link alone, a signed heartbeat that keeps the lease of what it placed, and the keeper's reports of
it on a latched topic. Each placed thing has a link of its own (its own sender, counter and lease):
one that ends takes nothing else down with it.
"""

from __future__ import annotations

import json
import secrets
import threading
import time
from typing import Any, Callable, Optional

from ..core import msgtypes
from ..core.qos import PROFILES
from ..core.slots import HandlerSlot
from ..processes.keeper import MachineError, Token, beat_text, beat_topics, namespace, token_path

__all__ = ["ANSWER", "FIND", "GONE", "KeeperLink"]

#: How long the keeper may take to answer a request (s): placing starts a process on the robot.
ANSWER = 40.0
#: How long the session waits for a keeper's first word (s) before it says none is there.
FIND = 10.0
#: A keeper whose reports stopped this long ago (s) is taken for gone (killed, or the link lost): a request then
#: waits a moment for its answer, not its whole time (what this session placed there ends after its grace anyway).
GONE = 2.0
#: The requests that let go of what was placed (a node's shutdown asks them): those that wait a moment only then.
LETTING_GO = frozenset({"stop_base", "unrelay", "remove"})

_STRING = "std_msgs/String"


class KeeperLink:
    """One placed thing's link to the keeper of ``machine``: ``kind`` is ``guards`` or ``bases`` (where its topics
    are), ``label`` how its errors name it. The token is read here, before anything opens (a one-line
    :class:`MachineError` when it is missing)."""

    def __init__(self, backend: Any, host: str, machine: str, kind: str, label: str,
                 say: Callable[[str], None]) -> None:
        self.machine, self.kind, self.label = machine, kind, label
        self._token = Token.read(token_path(machine), machine)
        self._backend, self._host, self._say = backend, host, say
        self.id = f"p{secrets.token_hex(6)}"  # a ROS 2 name's token starts with a letter
        self.ns = namespace(machine)
        self.topics = f"{self.ns}/{kind}/{self.id}"  # this thing's own topics: beat, state (a guard's in)
        self._sender = f"s{secrets.token_hex(6)}"
        self._n = time.time_ns()  # grows across this link's requests and beats, never repeats
        self._lock = threading.Lock()
        self._answered = threading.Condition(self._lock)
        self._epoch: Optional[str] = None
        self._answers: dict[int, dict[str, Any]] = {}
        self.report: dict[str, Any] = {}  # the keeper's last report of it
        self.heard_at = 0.0  # when that came (monotonic; 0: never)
        self._ending = threading.Event()
        self._endpoints: list[Any] = []
        self._string = msgtypes.resolve_message(_STRING)[1]

    # -- endpoints ----------------------------------------------------------------------------------
    def open(self, on_report: Callable[[dict[str, Any]], None] = lambda report: None) -> None:
        """Hear the keeper (its info, its answers, its reports of this thing) and open the request's and the
        heartbeat's publications. ``on_report`` is told each report."""
        string, ns = self._string, self.ns

        def report(msg: Any) -> None:
            try:
                found = json.loads(msg.data)
            except ValueError:
                return
            self.report, self.heard_at = found, time.monotonic()
            on_report(found)

        self.subscription("info", f"{ns}/info", string, self._info, latched=True)
        self.subscription("reply", f"{ns}/reply", string, self._reply)
        self.subscription("state", f"{self.topics}/state", string, report, latched=True)
        self._request = self.publication(f"{ns}/request", string)
        self._beats = [self.publication(topic, string, lossy=True) for topic in beat_topics(self.topics)]

    def subscription(self, label: str, topic: str, cls: type, handler: Callable[[Any], None],
                     latched: bool = False) -> Any:
        slot = HandlerSlot(f"{self.label} on {self.machine} {label}", handler,
                           lambda failure: self._say(f"{self.label}: {failure.error}"))
        endpoint = self._backend.subscription(self._host, topic, cls, slot,
                                              PROFILES["latched" if latched else "default"], _quiet)
        self._endpoints.append(endpoint)
        return endpoint

    def publication(self, topic: str, cls: type, lossy: bool = False) -> Any:
        """``lossy``: best effort on ROS 2 (a heartbeat's: a newer one makes a lost one moot)."""
        endpoint = self._backend.publication(self._host, topic, cls, PROFILES["best_effort" if lossy else "default"],
                                             _quiet)
        self._endpoints.append(endpoint)
        return endpoint

    def _info(self, msg: Any) -> None:
        try:
            epoch = json.loads(msg.data)["epoch"]
        except (ValueError, KeyError, TypeError):
            return
        with self._lock:
            self._epoch = epoch
            self._answered.notify_all()

    def _reply(self, msg: Any) -> None:
        try:
            answer = json.loads(msg.data)
        except ValueError:
            return
        if answer.get("to") != self._sender or not isinstance(answer.get("n"), int):
            return
        with self._lock:
            self._answers[answer["n"]] = answer
            self._answered.notify_all()

    def _next(self) -> int:
        with self._lock:
            self._n += 1
            return self._n

    # -- requests and the heartbeat -------------------------------------------------------------------
    def ask(self, op: str, timeout: float = ANSWER, again: bool = False, **fields: Any) -> dict[str, Any]:
        """A signed request to the keeper; its answer, or a one-line :class:`MachineError`. ``again``: asked again
        each second until it answers (a request may go out before the keeper's subscriber has found this link's
        publisher): only for what may be done twice (placing a guard)."""
        if op in LETTING_GO and self.heard_at and time.monotonic() - self.heard_at > GONE:
            timeout = min(timeout, 1.0)  # a node shut down with its robot gone is not held up for seconds a thing
        deadline = time.monotonic() + timeout
        found_by = min(deadline, time.monotonic() + FIND)
        with self._lock:
            while self._epoch is None and time.monotonic() < found_by:
                self._answered.wait(0.05)
            epoch = self._epoch
        if epoch is None:
            same = ("in the same ROS_DOMAIN_ID, found from here (ROS_AUTOMATIC_DISCOVERY_RANGE=SUBNET on both; where "
                    "the network drops multicast, start it with --discovery-server 11811 and set ROS_DISCOVERY_SERVER="
                    "ROBOT:11811 here)") if getattr(self._backend, "name", "") == "ROS 2" else \
                "with the same ROS_MASTER_URI"
            raise MachineError(f"no keeper of machine {self.machine} answers on this ROS graph within {FIND:g} s: "
                               f"start it on the robot (python -m ipyros.machine --name {self.machine}) {same}")
        if not again:  # once only: wait until the keeper hears this link's requests
            self._reached(min(deadline, time.monotonic() + FIND))
        while time.monotonic() < deadline:
            n = self._next()
            body = {"epoch": epoch, "from": self._sender, "n": n, "op": op, "id": self.id, **fields}
            self._request.write(self._string(data=self._token.signed(body)))
            with self._lock:
                until = deadline if not again else min(deadline, time.monotonic() + 1.0)
                while n not in self._answers and time.monotonic() < until:
                    self._answered.wait(0.02)
                answer = self._answers.pop(n, None)
            if answer is not None:
                if not answer.get("ok"):
                    raise MachineError(f"machine {self.machine} refused: {answer.get('error')}")
                return answer
            if not again:
                break
        raise MachineError(f"machine {self.machine} did not answer {op!r} within {timeout:g} s: the link to it may be "
                           "lost")

    def _reached(self, until: float) -> None:
        """Wait (until ``until``) for the keeper's subscriber to have found this link's request publisher, so that a
        request asked once is not lost to discovery."""
        count = getattr(self._request, "connections", None)
        while callable(count) and count() < 1 and time.monotonic() < until:
            time.sleep(0.02)

    def beat(self, period: float) -> None:
        """Send the signed heartbeat every ``period`` s from now until :meth:`close`."""
        def beats() -> None:
            while not self._ending.wait(period):
                epoch = self._epoch
                if epoch is None:
                    continue
                beat = self._string(data=beat_text(self._token, epoch, self._sender, self._next()))
                for line in self._beats:  # the same beat on each (see BEAT_LINES)
                    try:
                        line.write(beat)
                    except Exception:  # noqa: BLE001 - the link or the node ending: the reports' silence says it
                        continue

        threading.Thread(target=beats, name=f"ipyros-lease-{self.id}", daemon=True).start()

    def close(self) -> None:
        self._ending.set()
        for endpoint in self._endpoints:
            try:
                endpoint.close()
            except Exception:  # noqa: BLE001 - ending anyway
                pass
        self._endpoints = []


def _quiet(text: str) -> None:
    """A complaint of the link's endpoints: said by whoever tends the placed thing (the reports' silence)."""
