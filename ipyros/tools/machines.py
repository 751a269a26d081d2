"""The machines' keepers the session sees (``%machines``), and the names TAB offers for ``.machine("``.

A keeper (``python -m ipyros.machine``, :mod:`ipyros.processes.keeper`) publishes a latched ``info``
under ``/ipyros/machines/NAME``; this reads it through a small DSL node of the session's own (as
``%echo`` listens), and times the link with unsigned pings that the keeper answers at once and
that do nothing else. Without the machine's token a session sees the keeper, nothing more.
"""

from __future__ import annotations

import json
import re
import secrets
import statistics
import threading
import time
from pathlib import Path
from typing import Any, Iterable, Optional

from ..core.names import tool_name
from ..core.records import Machine, Machines
from ..dsl import engine_of, rosNode
from ..node.session import current
from ..processes.keeper import namespace, token_path

__all__ = ["allowed", "keepers_in", "look", "machine_names"]

_INFO = re.compile(r"^/ipyros/machines/([A-Za-z][A-Za-z0-9_]*)/info$")

#: How many pings time the link to each keeper (the median is shown).
PINGS = 5


def keepers_in(topics: Iterable[str]) -> list[str]:
    """The names of the machines whose keepers' topics are among ``topics``, sorted."""
    return sorted({m.group(1) for t in topics if (m := _INFO.match(t))})


def machine_names(topics: Iterable[str]) -> list[str]:
    """What ``.machine("`` and ``machine="`` complete: keepers on the graph, and machines whose token is here."""
    tokens = token_path("x").parent
    held = [p.stem for p in tokens.glob("*.token")] if tokens.is_dir() else []
    return sorted(set(keepers_in(topics)) | set(held))


def allowed(timeout: float = 1.0) -> dict[str, list[str]]:
    """The packages the keepers on the graph allow, with their executables (what TAB offers for ``basePackage("``
    and ``baseNode("``: a placed basenode's package need not be installed on the laptop)."""
    found: dict[str, set[str]] = {}
    for machine in look(timeout, pings=0).rows:
        for package, executables in machine.allows.items():
            found.setdefault(package, set()).update(executables)
    return {package: sorted(executables) for package, executables in found.items()}


def look(timeout: float = 3.0, pings: int = PINGS) -> Machines:
    """The keepers on the graph now: each one's info, and the median round trip of ``pings`` pings (none: no round
    trip shown)."""
    names = keepers_in(current().backend.graph_snapshot().topics)
    if not names:
        return Machines(())
    infos: dict[str, dict[str, Any]] = {}
    pongs: dict[tuple[str, int], float] = {}
    heard = threading.Condition()
    me = f"p{secrets.token_hex(4)}"

    def info_of(name: str) -> Any:
        def got(msg: Any) -> None:
            try:
                found = json.loads(msg.data)
            except ValueError:
                return
            with heard:
                infos[name] = found
                heard.notify_all()
        return got

    def reply_of(name: str) -> Any:
        def got(msg: Any) -> None:
            try:
                answer = json.loads(msg.data)
            except ValueError:
                return
            if answer.get("to") == me and answer.get("pong"):
                with heard:
                    pongs[(name, int(answer["n"]))] = time.monotonic()
                    heard.notify_all()
        return got

    node = rosNode(tool_name("machines"))
    for name in names:
        ns = namespace(name)
        node.new.subscribe(f"{ns}/info", handler=info_of(name), msgType="std_msgs/String")
        node.new.subscribe(f"{ns}/reply", handler=reply_of(name), msgType="std_msgs/String")
        node.new.publish(f"{ns}/request", msgType="std_msgs/String")
    node.create()
    try:
        deadline = time.monotonic() + timeout
        with heard:
            heard.wait_for(lambda: len(infos) == len(names), max(deadline - time.monotonic(), 0))
        rtts = {name: _ping(node, name, me, pongs, heard, deadline, pings) for name in names
                if name in infos and pings}
    finally:
        node.shutdown()
    return Machines(tuple(_machine(name, infos.get(name), rtts.get(name)) for name in names))


def _ping(node: Any, name: str, me: str, pongs: dict[tuple[str, int], float], heard: threading.Condition,
          deadline: float, pings: int) -> Optional[float]:
    """The median round trip of the pings that came back (ms), None when none did."""
    from std_msgs.msg import String

    topic = f"{namespace(name)}/request"
    writer = engine_of(node).writing.writer(topic)[0]
    while writer.connections() < 1 and time.monotonic() < deadline:  # the keeper has not found us yet
        time.sleep(0.02)
    times = []
    for n in range(pings):
        sent = time.monotonic()
        node.write(topic, String(data=json.dumps({"ping": {"from": me, "n": n}})))
        with heard:
            heard.wait_for(lambda: (name, n) in pongs, min(1.0, max(deadline - time.monotonic(), 0)))
        if (name, n) in pongs:
            times.append((pongs[(name, n)] - sent) * 1000.0)
    return statistics.median(times) if times else None


def _machine(name: str, info: Optional[dict[str, Any]], rtt: Optional[float]) -> Machine:
    token = Path(token_path(name)).is_file()
    if info is None:
        return Machine(name, token=token, heard=False)
    allows = info.get("allows") or {}
    if isinstance(allows, list):  # a keeper that names its packages only
        allows = {package: [] for package in allows}
    return Machine(name, str(info.get("host", "")), str(info.get("ros", "")), str(info.get("address", "")),
                   int(info.get("pid") or 0), {str(k): list(v) for k, v in allows.items()},
                   tuple(f"{g.get('topic')}" for g in info.get("guards") or ()),
                   tuple(f"{b.get('base')}" for b in info.get("bases") or ()), rtt, token)
