"""A process of its own for the relays a keeper runs beside a session's placed basenode.

The keeper (:mod:`ipyros.processes.keeper`) keeps the leases: when the laptop's link is lost, the robot
must stop within half a second. A camera's images relayed in the keeper's own process would share its
interpreter (one lock for all its threads) and its CPU time with that watch: measured, the keeper's
guard work alone doubled a relay's p99 latency, and a relay's load would as surely delay the stop. So
the relays of each placed wrapping node run in a *relay host*, a child of the keeper (it ends with it),
which the keeper tells what to open and close over its standard input, one JSON object a line:

=====================================================  ============================================
the keeper asks                                        the host answers (``{"n": N, "ok": ...}``)
=====================================================  ============================================
``{"n": N, "op": "add", "rid", "kind", "source",``     the relay opened (``kind``: topic, service,
``"target", "type"}``                                  action), or ``"error"``: one line
``{"n": N, "op": "remove", "rid"}``                    it is closed
``{"n": N, "op": "send", "rid", "data"}``              a message of the session's (hex, serialized)
                                                       sent on the relay's target
=====================================================  ============================================

and unasked, on its standard output: ``{"ready": true}`` once its ROS node runs, ``{"figures": {RID:
[messages, subscribers, dropped]}}`` every :data:`FIGURES` s, ``{"said": TEXT}`` for what a relay finds
wrong (a peer of another type). Its standard error is its log. The keeper never waits on it from its
lease watch: figures come unasked, and a host that ends is told in the keeper's log and the relays'
report.

A relay onto a topic a guard stands on runs in the keeper itself, through the guard's gate (its
stop message, its lease): see :class:`ipyros.processes.keeper.KeptRelays`.
"""

from __future__ import annotations

import json
import os
import sys
import threading
import time
from pathlib import Path
from typing import Any, Callable, Optional, Protocol

from ..core.errors import IpyrosError, first_line
from .process import spawn

__all__ = ["FIGURES", "RelayHost", "Relaying", "opener", "serve", "wrong_type_line"]

#: How often the host tells the keeper what its relays sent (s): seldom enough that the host's other thread
#: hardly ever holds a relay's message up (``%status`` counts lag by as much).
FIGURES = 1.0
#: How long a host may take to start its ROS node (s).
START = 30.0
#: How long it may take to answer (s): opening a relay subscribes and advertises.
ANSWER = 10.0


class Relaying(Protocol):
    """A relay a ROS adapter made (the runtime's own: bytes on, read only when a guard stands on its target)."""

    gate: Any  # the gate its messages pass (a guard's on the robot), or None

    def send(self, msg: Any) -> None: ...  # a message of the session's onto the target, through the gate
    def figures(self) -> Any: ...  # a SendFigures
    def close(self) -> None: ...


def wrong_type_line(source: str, type_name: str, got: str) -> str:
    """What a relay says when ``source`` carries another type than it relays."""
    return f"{source} carries {got}, not {type_name}: its messages are dropped"


class RelayHost:
    """The keeper's handle on one relay host: ``argv`` runs it (the ROS adapter's command), ``log_path`` is its
    log, ``said`` gets each line it has to say. Started here; a one-line :class:`IpyrosError` if it does not come
    up."""

    def __init__(self, argv: list[str], log_path: Path, said: Callable[[str], None],
                 env: Optional[dict[str, str]] = None) -> None:
        self.log_path, self._said = log_path, said
        self._lock = threading.Lock()
        self._answered = threading.Condition(self._lock)
        self._answers: dict[int, dict[str, Any]] = {}
        self._n = 0
        self._ready = threading.Event()
        self.figures: dict[str, list[int]] = {}
        self.ended: Optional[str] = None  # why it ended, once it did
        self._closing = False
        log_path.parent.mkdir(parents=True, exist_ok=True)
        fd = os.open(log_path, os.O_WRONLY | os.O_CREAT | os.O_TRUNC, 0o600)
        try:
            self._proc = spawn(argv, env=env, log=fd, stdin_pipe=True, stdout_pipe=True)
        finally:
            os.close(fd)
        threading.Thread(target=self._read, name="ipyros-relay-host", daemon=True).start()
        if not self._ready.wait(START) or self.ended is not None:
            self.close()
            raise IpyrosError(f"the relays' process did not start ({self.ended or f'no word in {START:g} s'}; "
                              f"see {log_path})")

    @property
    def pid(self) -> int:
        return self._proc.pid

    def _read(self) -> None:
        assert self._proc.stdout is not None
        for raw in self._proc.stdout:
            try:
                line = json.loads(raw)
            except ValueError:
                continue
            if "n" in line:
                with self._lock:
                    self._answers[line["n"]] = line
                    self._answered.notify_all()
            elif "figures" in line:
                self.figures = line["figures"]
            elif "said" in line:
                self._said(str(line["said"]))
            elif line.get("ready"):
                self._ready.set()
        code = self._proc.wait()
        self.ended = f"killed by signal {-code}" if code < 0 else f"exit code {code}"
        if not self._closing and self._ready.is_set():  # its end nobody asked for: said (the relays' report says it too)
            self._said(f"their process ended ({self.ended}; its log: {self.log_path}): they relay nothing now")
        self._ready.set()
        with self._lock:
            self._answered.notify_all()

    def ask(self, op: str, **fields: Any) -> dict[str, Any]:
        """Ask the host; its answer, or a one-line :class:`IpyrosError` (refused, ended, or no answer)."""
        with self._lock:
            self._n += 1
            n = self._n
        try:
            assert self._proc.stdin is not None
            self._proc.stdin.write((json.dumps({"n": n, "op": op, **fields}) + "\n").encode())
            self._proc.stdin.flush()
        except OSError:
            pass  # it ended: said below
        deadline = time.monotonic() + ANSWER
        with self._lock:
            while n not in self._answers and self.ended is None and time.monotonic() < deadline:
                self._answered.wait(0.05)
            answer = self._answers.pop(n, None)
        if answer is None:
            raise IpyrosError(f"the relays' process {'ended (' + self.ended + ')' if self.ended else 'did not answer'}"
                              f"; see {self.log_path}")
        if not answer.get("ok"):
            raise IpyrosError(str(answer.get("error")))
        return answer

    def close(self) -> None:
        """End it: its standard input closed (it closes its relays and quits), then signals if it does not."""
        self._closing = True
        try:
            if self._proc.stdin is not None:
                self._proc.stdin.close()
        except OSError:
            pass
        for stop in (None, self._proc.terminate, self._proc.kill):
            if stop is not None:
                stop()
            try:
                self._proc.wait(3.0)
                return
            except Exception:  # noqa: BLE001 - subprocess.TimeoutExpired: the next signal
                continue


def opener(ros: Any) -> Callable[[str, str, str, str, Callable[[str], None]], Any]:
    """``make`` for :func:`serve` from a ROS adapter's ``relay``, ``service_relay`` and ``action_relay``."""
    def make(kind: str, source: str, target: str, type_name: str, complain: Callable[[str], None]) -> Any:
        if kind == "service":
            return ros.service_relay(source, target, type_name, complain)
        if kind == "action":
            return ros.action_relay(source, target, type_name, complain)
        return ros.relay(source, target, type_name, None, complain)
    return make


def serve(make: Callable[[str, str, str, str, Callable[[str], None]], Any],
          message: Callable[[str, bytes], Any]) -> None:
    """Be a relay host (in its own process, its ROS node running): open and close relays as the keeper asks on
    standard input until it closes it, tell their figures on standard output. ``make(kind, source, target, type,
    complain)`` opens a relay (``kind``: topic, service or action); ``message(type, data)`` reads a serialized
    message."""
    out_lock = threading.Lock()
    out = sys.stdout
    relays: dict[str, Any] = {}
    ended = threading.Event()

    def tell(line: dict[str, Any]) -> None:
        with out_lock:
            out.write(json.dumps(line) + "\n")
            out.flush()

    def figures() -> None:
        while not ended.wait(FIGURES):
            found = {}
            for rid, relay in list(relays.items()):
                f = relay.figures() if hasattr(relay, "figures") else None  # a service's relay has none
                found[rid] = [f.messages, f.connections, f.dropped] if f is not None else [0, 0, 0]
            tell({"figures": found})

    def answer(request: dict[str, Any]) -> dict[str, Any]:
        op, rid = request.get("op"), str(request.get("rid"))
        if op == "add":
            kind, source, target, type_name = (str(request.get(k, "topic")) for k in ("kind", "source", "target", "type"))
            relays[rid] = make(kind, source, target, type_name, lambda text: tell({"said": text}))
            types[rid] = type_name
        elif op == "remove":
            relay = relays.pop(rid, None)
            if relay is not None:
                relay.close()
        elif op == "send":
            relays[rid].send(message(types[rid], bytes.fromhex(str(request["data"]))))
        else:
            raise ValueError(f"unknown request {op!r}")
        return {}

    types: dict[str, str] = {}
    threading.Thread(target=figures, name="ipyros-relay-figures", daemon=True).start()
    tell({"ready": True})
    try:
        for raw in sys.stdin:
            try:
                request = json.loads(raw)
            except ValueError:
                continue
            try:
                tell({"n": request.get("n"), "ok": True, **answer(request)})
            except Exception as error:  # noqa: BLE001 - a request never ends the host: said in one line
                tell({"n": request.get("n"), "ok": False, "error": first_line(error)})
    finally:
        ended.set()
        for relay in relays.values():
            relay.close()
