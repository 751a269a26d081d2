"""What an agent may ask of the session, each a thin call of what the magics do, answered as data and a short text.

The :class:`Desk` is the agent's whole reach into the session: the MCP server (:mod:`ipyros.mcp.server`) only turns
its methods into tools. Reading (the graph, a type, a topic's messages, the session's nodes, their history, a bag)
is free. Rehearsing a candidate handler runs it over recorded or recent messages with its writes kept, never sent,
within a time budget. Every change (a proposed handler, a revert, one message, one service call) becomes a request
the person answers at the prompt (:mod:`ipyros.mcp.approvals`), and only names the person allowed
(:mod:`ipyros.mcp.allow`) can become one. ``estop`` alone acts at once: stopping is always allowed, releasing never.
"""

from __future__ import annotations

import ctypes
import dataclasses
import difflib
import inspect
import threading
import time
from collections import deque
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Callable, Optional, cast

from ..core import msgpath, msgtypes, plan as planning
from ..core.errors import IpyrosError
from ..core.graph import GraphSnapshot, actions_of
from ..core.msgbuild import as_data, build_message, definition, parse_data
from ..core.names import is_tool
from ..core.remapping import base_fullname
from ..dsl import engine_of, node_of, rosNode
from ..node.engine import NodeEngine
from ..node.session import Session, made_by
from ..tools.estop import estop_each
from ..tools.graph import GraphCache, as_dsl_nodes, live_graph
from ..tools.probe import Echo, PromptPublisher, measure_rates
from ..tools.record import bag_module
from ..tools.tryout import one_line, try_bag, try_candidate
from .allow import AgentRefused, Allowed, Reach, normal
from .approvals import Request, Requests
from .candidate import make_candidate

__all__ = ["Answer", "Desk", "REHEARSAL_SECONDS", "MOST_SHOWN"]

#: How long a rehearsal may run before it is stopped (what ran until then is its answer).
REHEARSAL_SECONDS = 20.0
#: At most this many topics (nodes, services) in one answer of ``graph``: the rest counted, not listed.
MOST_SHOWN = 500
#: The session's notices kept for the agent.
NOTICES_KEPT = 50
#: At most this many topics measured for ``graph(rates=True)`` (one second, all at once).
MOST_MEASURED = 100
#: At most this many messages in one answer of ``echo``, and this long a wait for them.
MOST_MESSAGES, LONGEST_WAIT = 100, 30.0


@dataclass(frozen=True)
class Answer:
    """What a tool gives back: a short text for the model to read and the same as data."""

    text: str
    data: dict[str, Any]


class Desk:
    """The session as an agent may use it (see the module's docstring); ``namespace`` is the person's (IPython's
    ``user_ns``): an approved handler is made there, under a name of its own, as a ``%%handler`` cell would be."""

    def __init__(self, session: Session, graph: GraphCache, publisher: PromptPublisher, namespace: dict[str, Any],
                 allowed: Allowed, requests: Requests) -> None:
        self.session, self.graph, self.publisher = session, graph, publisher
        self.namespace, self.allowed, self.requests = namespace, allowed, requests
        #: What the session told the person on its own since the server started (a basenode died, a guard
        #: tripped, ...), the last :data:`NOTICES_KEPT`, with their times: the agent reads them with ``history``.
        self.notices: deque[tuple[float, str]] = deque(maxlen=NOTICES_KEPT)

    def heard(self, text: str) -> None:
        """A notice of the session's (:meth:`Session.listen <ipyros.node.session.Session.listen>` calls it)."""
        self.notices.append((time.time(), text))

    # -- reading -------------------------------------------------------------------------------------------
    def graph_now(self, pattern: str = "", node: Optional[str] = None, rates: bool = False,
                  parameters: bool = False) -> Answer:
        """Topics (type, publishers, subscribers), nodes, services and actions; ``pattern`` a glob or a part; with
        ``rates`` each listed topic's rate, measured for a second (the first :data:`MOST_MEASURED`); with
        ``parameters`` the parameters and their values (under ``node`` if given, else all but those every node has)."""
        snap = as_dsl_nodes(self._snapshot(), self.session)  # the session's own nodes by their DSL names
        topics = snap.topics_matching(pattern or "", node=node and normal(node, "node", self.allowed.namespace))
        shown = topics[:MOST_SHOWN]
        data: dict[str, Any] = {
            "topics": [{"name": t, "type": snap.topics.get(t, ""), "publishers": list(snap.publishers.get(t, ())),
                        "subscribers": list(snap.subscribers.get(t, ()))} for t in shown],
            "nodes": list(snap.nodes[:MOST_SHOWN]),
            "services": [{"name": s, "nodes": list(n)} for s, n in list(snap.services.items())[:MOST_SHOWN]],
            "actions": [{"name": a.name, "type": a.type} for a in actions_of(snap)][:MOST_SHOWN],
            "left_out": {"topics": len(topics) - len(shown), "nodes": max(0, len(snap.nodes) - MOST_SHOWN),
                         "services": max(0, len(snap.services) - MOST_SHOWN)}}
        if rates:
            measured = measure_rates({t: snap.topics[t] for t in shown[:MOST_MEASURED] if snap.topics.get(t)}, 1.0)
            for entry in data["topics"]:
                rate = measured.get(entry["name"])
                entry["hz"] = None if rate is None else rate.hz
        if parameters:
            backend = self.session.backend
            found = backend.params_under(normal(node, "node", self.allowed.namespace) if node else "/")
            data["parameters"] = {k: v for k, v in list(found.items())[:MOST_SHOWN]
                                  if k.rsplit("/", 1)[-1] not in backend.standard_params}
        more = f" (the first {MOST_SHOWN} listed; give a pattern)" if len(topics) > MOST_SHOWN else ""
        text = (f"{len(topics)} topics{f' matching {pattern!r}' if pattern else ''}{more}, {len(snap.nodes)} nodes, "
                f"{len(snap.services)} services, {len(data['actions'])} actions")
        return Answer(text, data)

    def interface(self, type_name: str) -> Answer:
        """A message, service or action type's definition, nested types spelled out."""
        text = definition(type_name, expand=True)
        return Answer(text, {"type": type_name, "definition": text})

    def echo(self, topic: str, count: int = 1, timeout: float = 5.0) -> Answer:
        """The next ``count`` messages of ``topic`` (a message path selects from each: ``/odom.pose.pose``)."""
        if not 1 <= count <= MOST_MESSAGES:
            raise AgentRefused(f"count must be 1 to {MOST_MESSAGES}, not {count}")
        if not 0 < timeout <= LONGEST_WAIT:
            raise AgentRefused(f"timeout must be more than 0 and at most {LONGEST_WAIT:g} s, not {timeout}")
        snap = self._snapshot()
        path = msgpath.parse(topic) if any(c in topic for c in ".[{") else None
        name = path.topic if path is not None else normal(topic, "topic", self.allowed.namespace)
        type_name = snap.topics.get(name)
        if not type_name or type_name == "*":
            raise IpyrosError(f"no live topic {name} with a known type; the graph tool lists them")
        if path is not None:
            path.check(msgtypes.message_class_or_none(type_name))
        seen: list[Any] = []
        with Echo(name, type_name) as echo:
            waited = 0.0
            while len(seen) < count and waited < timeout:
                msg = echo.get(0.1)
                waited += 0.1
                if msg is not None:
                    chosen = path.values(msg, {}) if path is not None else [msg]
                    if chosen:
                        seen.append(as_data(chosen[0]) if len(chosen) == 1 else [as_data(c) for c in chosen])
        text = f"{len(seen)} message{'s' * (len(seen) != 1)} of {name} ({type_name})" + (
            f"; none more within {timeout:g} s" if len(seen) < count else "")
        return Answer(text, {"topic": name, "type": type_name, "messages": seen})

    def nodes(self) -> Answer:
        """The session's nodes: declarations, handlers (name, source, versions), guards' states, figures."""
        found: list[dict[str, Any]] = []
        for node in self._nodes():
            model = node.model()
            handlers = []
            for topic in model.topics:
                if topic.direction == "subscribe" and topic.role == "new":
                    handler = node.handler(topic.resolved)
                    versions = node.versions(topic.resolved)
                    handlers.append({"topic": topic.resolved, "handler": getattr(handler, "__name__", repr(handler)),
                                     "source": _source(handler), "versions": len(versions.rows),
                                     "current": versions.current})
            status = node.status()
            found.append({
                "name": node.fullname, "running": node.created,
                "basenode": model.base.describe() if model.base else None,
                "topics": [{"name": t.resolved, "direction": t.direction, "role": t.role, "type": t.type}
                           for t in model.topics],
                "services": [s.resolved for s in model.services], "handlers": handlers,
                "guards": [{"topic": g.topic, "state": g.state, **dataclasses.asdict(g.figures), "rules": list(g.rules)}
                           for g in status.guards],
                "may_propose": node.fullname in self.allowed.swap, "status": str(status)})
        text = "; ".join(f"{n['name']} ({'running' if n['running'] else 'not running'}, {len(n['handlers'])} handlers"
                         + "".join(f", guard {g['topic']}: {g['state']}" for g in n['guards']) + ")"
                         for n in found) or "no node of the session"
        return Answer(text, {"nodes": found})

    def history(self, node: Optional[str] = None, last: int = 50) -> Answer:
        """The session's changes, newest last (who made each, when not the person), and the agent's requests."""
        names = (None,) if node is None else (self._node(node).name, self._node(node).fullname)
        changes = [c for c in self.session.history if node is None or c.node in names][-last:]
        rows = [{"time": c.time, "node": c.node, "change": c.change, "version": c.version, "by": c.by}
                for c in changes]
        asked = [r.as_data() for r in self.requests.latest()]
        told = [{"time": when, "notice": text} for when, text in self.notices]
        return Answer(f"{len(rows)} changes, {len(asked)} requests of the agent, {len(told)} notices",
                      {"changes": rows, "requests": asked, "notices": told})

    def bag_info(self, path: str) -> Answer:
        """What a bag holds: each topic, its type and message count; start, end, storage."""
        where = Path(path).expanduser()
        if not where.exists():
            raise IpyrosError(f"no bag at {where}: give a bag file or a rosbag2 folder")
        info = bag_module().bag_info(where)
        return Answer(info.table().title, {"path": info.path, "storage": info.storage, "start": info.start,
                                           "end": info.end, "topics": [dataclasses.asdict(r) for r in info.rows]})

    # -- rehearsing and proposing ----------------------------------------------------------------------------
    def rehearse(self, node: str, topic: str, source: str, bag: Optional[str] = None,
                 last: Optional[int] = None) -> Answer:
        """``source`` (one def) beside the live handler of ``topic`` on ``node``, over ``bag`` or the node's recent
        messages: nothing swapped, nothing sent; with a bag each write passes the node's guard as it would live."""
        target = self._node(node)
        self.allowed.to_swap(target.fullname)  # a rehearsal runs the agent's code: only where the person allowed it
        live = target.handler(topic)
        scope = dict(getattr(live, "__globals__", None) or self.namespace)  # a copy: the person's stays as it is
        candidate = make_candidate(source, scope)
        report = _within(REHEARSAL_SECONDS, lambda: try_bag(target, topic, candidate, bag) if bag is not None
                         else try_candidate(target, topic, candidate, last))
        return Answer(_report_text(report), _report_data(report))

    def propose(self, node: str, topic: str, source: str, bag: Optional[str] = None) -> Answer:
        """Ask the person to make ``source`` the handler of ``topic`` on ``node``: rehearsed first (over ``bag``, else
        the node's recent messages), shown at the prompt with a diff against the running handler."""
        target = self._node(node)
        self.allowed.to_swap(target.fullname)
        resolved = target.resolve(topic)
        live = target.handler(resolved)
        if live is None:
            raise IpyrosError(f"{target.fullname} has no handler of {resolved}; the nodes tool lists its handlers")
        make_candidate(source, {})  # refused now, in one line, if it is not one plain def
        try:
            rehearsal = self.rehearse(node, resolved, source, bag)
            summary = rehearsal.text.splitlines()[0]
        except IpyrosError as error:
            rehearsal, summary = None, f"not rehearsed: {error}"
        diff = "".join(difflib.unified_diff((_source(live) or "").splitlines(True), _ended(source).splitlines(True),
                                            f"running: {getattr(live, '__name__', '?')}", "proposed"))
        namespace = self.namespace

        def swap() -> str:
            fresh = _fresh(namespace, f"agent_{_last_part(resolved)}")
            handler = make_candidate(source, namespace, fresh)
            with made_by(f"the agent, request #{request.number}"):
                engine_of(target).handlers_of.redeclare(engine_of(target).handlers_of.find_target(resolved), handler)
            return f"{target.fullname} {resolved} is now handled by {fresh} (in your namespace)"

        request = self.requests.ask("swap", f"make this the handler of {resolved} on {target.fullname}",
                                    f"rehearsal: {summary}\n{diff}", swap)
        data = {"request": request.number, "state": request.state, "rehearsal": rehearsal.data if rehearsal else None}
        return Answer(f"asked the person (request #{request.number}); {summary}", data)

    def revert(self, node: str, topic: str, version: int) -> Answer:
        """Ask the person to bring version ``version`` of the handler of ``topic`` on ``node`` back."""
        target = self._node(node)
        self.allowed.to_swap(target.fullname)
        versions = target.versions(topic)
        if not 1 <= version <= len(versions.rows):
            raise IpyrosError(f"{versions.label} has versions 1 to {len(versions.rows)}, not {version}")
        chosen = versions.rows[version - 1]

        def back() -> str:
            with made_by(f"the agent, request #{request.number}"):
                target.revert(topic, version)
            return f"{versions.label} is handled by version {version} ({chosen.name}) again"

        request = self.requests.ask("revert", f"bring back version {version} ({chosen.name}) of {versions.label}",
                                    chosen.source or "", back)
        return self._asked(request)

    # -- acting ----------------------------------------------------------------------------------------------------
    def publish(self, topic: str, message: Any, type_name: Optional[str] = None) -> Answer:
        """One message on an allowed topic (through the guard of a guarded output), once the person approves."""
        name = self.allowed.to_publish(topic)
        declared = type_name or self._snapshot().topics.get(name)
        if not declared or declared == "*":
            raise IpyrosError(f"the type of {name} is not known: give type, e.g. geometry_msgs/Twist")
        resolved = msgtypes.resolve_message(declared)[0]
        msg = build_message(resolved, parse_data(message) if isinstance(message, str) else message)
        guarded = self.publisher.guard(name, resolved)
        through = f" through the guard of {guarded[0]}" if guarded else ""

        def send() -> str:
            sender, reached = self.publisher.publish(name, resolved, msg)
            return f"published a {resolved} on {name}{through} (from {sender}) to {reached} subscribers"

        what = f"publish {one_line(msg, 200)} on {name}{through}"
        if not self.allowed.ask:
            return Answer(send(), {"published": name, "guarded": bool(guarded)})
        return self._asked(self.requests.ask("publish", what, "", send))

    def call(self, service: str, request: Any, type_name: Optional[str] = None, timeout: float = 5.0) -> Answer:
        """One call of an allowed service, not relayed past a guard, once the person approves; its response."""
        name = self.allowed.to_call(service, self.reach())
        backend = self.session.backend
        if name not in self._snapshot().services:
            raise IpyrosError(f"no live service {name}; the graph tool lists them")
        resolved, cls = msgtypes.resolve_service(type_name or backend.service_type(name))
        request_class = getattr(cls, "_request_class", None) or getattr(cls, "Request")  # ROS 1, ROS 2
        built = build_message(request_class, parse_data(request) if isinstance(request, str) else request)
        answered: dict[str, Any] = {}

        def make() -> str:
            answered["response"] = as_data(backend.call(name, cls, built, timeout))
            return f"called {name} ({resolved}): {answered['response']}"

        if not self.allowed.ask:
            return Answer(make(), {"service": name, **answered})
        return self._asked(self.requests.ask("call", f"call {name} with {one_line(built, 200)}", "", make))

    def estop(self, node: Optional[str] = None) -> Answer:
        """Every guarded output (of ``node``, or of the session) to its stop message now, held until the person
        releases it at the prompt (``%estop --release``): the one act that needs no approval."""
        nodes = [self._node(node)] if node else [n for n in self._nodes() if n.created and n.model().guards]
        if not nodes:
            raise IpyrosError("no running node of the session has a guard: there is nothing to e-stop from here")
        stopped = [f"{topic} ({n.fullname})" for n, topics in estop_each(nodes) for topic in topics]
        self.session.notify(f"ipyros: the agent e-stopped {', '.join(stopped) or 'nothing'}; %estop --release "
                            "lets commands through again")
        return Answer(f"e-stopped {', '.join(stopped)}; only the person can release it", {"estopped": stopped})

    def request(self, number: int) -> Answer:
        """Where request ``number`` stands: pending, approved (and what it did), denied or failed."""
        found = self.requests.get(number)
        return Answer(f"request #{number}: {found.state}{': ' + found.answer if found.answer else ''}",
                      found.as_data())

    # -- what the session relays --------------------------------------------------------------------------
    def reach(self) -> Reach:
        """Where the session's relayed services and actions lead, and which outputs guard the basenodes there."""
        relays, wrapped = {}, {}
        for node in self._nodes():
            model = node.model()
            outputs = tuple(g.resolved for g in model.guards)
            if model.base is None:
                continue
            base = base_fullname(model)
            wrapped[base] = outputs
            for spec in planning.plan(model):
                if isinstance(spec, (planning.ServiceRelaySpec, planning.ActionRelaySpec)):
                    relays[spec.target] = relays[spec.source] = base  # its outer name, and the basenode's own
                elif isinstance(spec, planning.ActionServerSpec) and spec.forward:
                    relays[spec.name] = relays[spec.forward] = base
        return Reach(relays, wrapped)

    # -- helpers ----------------------------------------------------------------------------------------------
    def _asked(self, request: Request) -> Answer:
        return Answer(f"asked the person (request #{request.number}): {request.what}; the request tool says when "
                      "they answer", request.as_data())

    def _snapshot(self) -> GraphSnapshot:
        return live_graph(self.session.backend, self.graph)

    def _nodes(self) -> list[rosNode]:
        return [node_of(cast(NodeEngine, e)) for e in list(self.session.nodes.values()) if not is_tool(e.name)]

    def _node(self, name: str) -> rosNode:
        wanted = normal(name, "node", self.allowed.namespace) if "/" in name else None
        for node in self._nodes():
            if node.fullname == wanted or node.name == name:
                return node
        names = ", ".join(n.fullname for n in self._nodes()) or "none"
        raise IpyrosError(f"no node {name!r} in the session (its nodes: {names})")


def _within(seconds: float, work: Callable[[], Any]) -> Any:
    """``work()`` on a thread of its own, stopped after ``seconds`` as Ctrl-C stops it (a rehearsal then answers
    with what ran so far). A body stuck in C code (a sleep) is stopped when it returns to Python."""
    done: dict[str, Any] = {}

    def run() -> None:
        try:
            done["value"] = work()
        except BaseException as error:  # noqa: BLE001 - handed to the caller's thread
            done["error"] = error

    thread = threading.Thread(target=run, name="ipyros-rehearsal", daemon=True)
    thread.start()
    thread.join(seconds)
    if thread.is_alive():
        ctypes.pythonapi.PyThreadState_SetAsyncExc(ctypes.c_ulong(thread.ident or 0),
                                                   ctypes.py_object(KeyboardInterrupt))
        thread.join(5.0)
        if thread.is_alive():
            raise IpyrosError(f"the rehearsal ran {seconds:g} s and did not stop (the candidate is stuck outside "
                              "Python); it runs on, its writes kept, never sent")
    if "error" in done:
        error = done["error"]
        if isinstance(error, KeyboardInterrupt):
            raise IpyrosError(f"the rehearsal was stopped after {seconds:g} s before a message was tried: the "
                              f"candidate must return within {seconds:g} s of each message (does it loop?)")
        raise error
    return done["value"]


def _report_text(report: Any, shown: int = 5) -> str:
    """A %try report in a few lines: the totals, then the first differences, each side's writes and errors."""
    if hasattr(report, "outputs"):  # over a bag: its table, as %try shows it
        return _first_lines(str(report), 40)
    lines = [f"{report.candidate_name} against {report.live_name} on {len(report.rows)} recent messages of "
             f"{report.topic}: {report.differing} differ"]
    for row in [r for r in report.rows if not r.same][:shown]:
        lines.append(f"#{row.index} {one_line(row.message, 80)}")
        for side, outcome in (("live", row.live), ("candidate", row.candidate)):
            said = outcome.lines() or ["(nothing)"]
            kept = said[:4] + ([f"... {len(said) - 5} more", said[-1]] if len(said) > 5 else said[4:])  # its error last
            lines += [f"  {side} {line}" for line in kept]
    return _first_lines("\n".join(lines), 40)


def _report_data(report: Any) -> dict[str, Any]:
    """A %try report as data: totals, and each side's writes counted per output."""
    if hasattr(report, "outputs"):  # over a bag
        return {"messages": report.total, "differing": report.differing, "stopped": report.stopped,
                "seconds": round(report.seconds, 3),
                "writes": {side: {t: len(w) for t, w in outs.items()} for side, outs in report.outputs.items()},
                "guarded": report.guarded,
                "first_differences": [{"at": d.at, "live": d.live.lines(), "candidate": d.candidate.lines()}
                                      for d in report.first]}
    return {"messages": len(report.rows), "differing": report.differing,
            "rows": [{"live": r.live.lines(), "candidate": r.candidate.lines(), "same": r.same} for r in report.rows]}


def _source(handler: Any) -> Optional[str]:
    try:
        return inspect.getsource(handler)
    except (OSError, TypeError):
        return None


def _ended(text: str) -> str:
    return text if text.endswith("\n") else text + "\n"


def _first_lines(text: str, count: int) -> str:
    lines = text.splitlines()
    return "\n".join(lines[:count] + ([f"... ({len(lines) - count} more lines)"] if len(lines) > count else []))


def _last_part(name: str) -> str:
    return "".join(c if c.isalnum() else "_" for c in name.rsplit("/", 1)[-1]) or "handler"


def _fresh(namespace: dict[str, Any], base: str) -> str:
    name, number = base, 2
    while name in namespace:
        name, number = f"{base}_{number}", number + 1
    return name
