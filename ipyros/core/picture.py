"""The live graph as a picture, drawn as the paper draws wrapping (its figure 1): pure data, then Graphviz or text.

:func:`picture` takes the graph as read (a :class:`~ipyros.core.graph.GraphSnapshot`) and what the session knows of
its own nodes (:class:`Drawn`: the model, each guard's state, the machine) and decides what is drawn: a box a ROS
node, a small node a topic between its publishers and subscribers, and each wrapping node as a frame holding its
basenode, the base's topics passing through the wrapping node each with what happens to it:

* **relayed** (``reuse``): the basenode's topic goes on unchanged under its own name;
* **replaced** by a handler (a ``new`` subscription of a reused output, or of a reused input): named;
* **added** (``new``): the wrapping node's own;
* a **guard** on an output, with its state (passing, clamped, stopping, e-stopped).

The basenode's internal names (``/w/base/cmd_vel``, where the wrapping node remaps it) are not drawn as topics: they
are the wires inside the frame. A large graph is cut down by a pattern, or to the nodes within ``depth`` hops of one
node; what is left out is counted in :attr:`Picture.left_out`. :func:`to_dot` writes Graphviz's language (an SVG is
``dot -Tsvg`` of it) and :func:`to_text` a tree by node that fits a terminal's width.
"""

from __future__ import annotations

import dataclasses
from collections import Counter, defaultdict
from dataclasses import dataclass, field
from typing import Collection, Mapping, Optional, Sequence

from .graph import GraphSnapshot, name_matches
from .model import NodeModel
from .plan import internal_name
from .remapping import base_fullname

__all__ = ["Box", "Drawn", "Inner", "Picture", "Wire", "picture", "to_dot", "to_text", "MOST_BOXES"]

#: Topics every node has, which say nothing of the robot: never drawn (ROS 1's log, ROS 2's log and parameter events).
HIDDEN = ("/rosout", "/rosout_agg", "/parameter_events")

#: At most this many nodes are drawn unless asked for more: the rest are counted and named in a sentence.
MOST_BOXES = 60


@dataclass(frozen=True)
class Drawn:
    """What the session knows of one of its nodes, beside the graph: its model, its guards' states, its machine."""

    model: NodeModel
    guards: Mapping[str, str] = field(default_factory=dict)  # output → "passing", "clamped 3", "e-stopped", ...
    machine: str = ""  # where its basenode runs ("" here)


@dataclass(frozen=True)
class Box:
    """A ROS node: ``kind`` is "node", "session" (a node of this session), "wrapping" or "basenode"."""

    name: str
    kind: str = "node"
    frame: str = ""  # the wrapping node whose frame holds it (its own name for the wrapping node itself)
    note: str = ""  # "wraps ipyros_demo/move_base", "on robot1"


@dataclass(frozen=True)
class Wire:
    """A topic, with who publishes and who subscribes it (as drawn), and what a wrapping node does to it."""

    topic: str
    type: str
    publishers: tuple[str, ...]
    subscribers: tuple[str, ...]
    role: str = ""  # "relayed", "replaced by h", "added"
    guard: str = ""  # its guard's state, if guarded
    by: str = ""  # the node of the session whose role and guard those are


@dataclass(frozen=True)
class Inner:
    """A wire inside a wrapping node's frame, between the basenode and the wrapping node (an internal name)."""

    frame: str
    source: str
    target: str
    topic: str  # the outer name it stands for
    role: str  # "relayed", "replaced by h"


@dataclass(frozen=True, repr=False)
class Picture:
    """What is drawn: the nodes, the topics between them, the wires inside wrapping frames, and how to show it (each
    topic's type, its rate). At the prompt it shows as itself: a tree in a terminal, an SVG in Jupyter."""

    boxes: tuple[Box, ...]
    wires: tuple[Wire, ...]
    inner: tuple[Inner, ...] = ()
    left_out: str = ""  # a sentence: what was not drawn, and how to see it
    types: bool = False
    rates: Mapping[str, str] = field(default_factory=dict)

    def __repr__(self) -> str:
        return f"<the ROS graph drawn: {len(self.boxes)} nodes, {len(self.wires)} topics>"

    @property
    def frames(self) -> list[str]:
        return sorted({b.frame for b in self.boxes if b.frame})


def picture(snap: GraphSnapshot, ours: Mapping[str, Drawn], pattern: str = "", focus: Optional[str] = None,
            depth: int = 1, most: int = MOST_BOXES, hidden: Sequence[str] = HIDDEN,
            unseen: Collection[str] = (), types: bool = False) -> Picture:
    """What to draw of ``snap``: ``ours`` the session's nodes by full name; ``pattern`` keeps the topics and nodes it
    matches (a glob or a part of a name); ``focus`` only what is within ``depth`` hops of that node (a hop: node to
    topic to node). ``hidden`` topics are never drawn (the log every node publishes), nor the ``unseen`` nodes
    (ipyros's own helpers: a guard's process is drawn as the guard on its output's edge)."""
    roles, inner, internal = _wrapping(ours)
    boxes: dict[str, Box] = {}
    for name in snap.nodes:
        if name not in unseen:
            boxes[name] = Box(name)
    for name, drawn in ours.items():
        model = drawn.model
        kind = "wrapping" if model.base is not None else "session"
        note = f"wraps {model.base.describe()}" if model.base is not None else ""
        boxes[name] = Box(name, kind, name if model.base is not None else "", note)
        if model.base is not None:
            base = base_fullname(model)
            boxes[base] = Box(base, "basenode", name, f"on {drawn.machine}" if drawn.machine else "")
    wires = []
    for topic in sorted(set(snap.topics) - set(hidden)):
        if topic in internal:
            continue
        role, guard, by = roles.get(topic, ("", "", ""))
        wires.append(Wire(topic, snap.topics.get(topic, ""),
                          tuple(n for n in snap.publishers.get(topic, ()) if n not in unseen),
                          tuple(n for n in snap.subscribers.get(topic, ()) if n not in unseen), role, guard, by))
    drawn_topics = {w.topic for w in wires}
    for name, drawn in ours.items():  # a node's declared topics, even before the graph shows them
        for t in drawn.model.topics:
            if t.resolved in internal or t.resolved in drawn_topics:
                continue
            drawn_topics.add(t.resolved)
            role, guard, by = roles.get(t.resolved, ("", "", ""))
            out = t.direction == "publish"
            wires.append(Wire(t.resolved, t.type, (name,) if out else (), () if out else (name,), role, guard, by))
    for wire in wires:
        for end in (*wire.publishers, *wire.subscribers):
            boxes.setdefault(end, Box(end))
    wires.sort(key=lambda w: w.topic)
    kept_boxes, kept_wires = _cut(list(boxes.values()), wires, pattern, focus, depth)
    said = ""
    if len(kept_boxes) > most:  # the session's own first, then the busiest
        busy = Counter(end for w in kept_wires for end in {*w.publishers, *w.subscribers})
        order = sorted(kept_boxes, key=lambda b: (b.kind == "node", -busy[b.name], b.name))
        chosen = {b.name for b in order[:most]} | {b.frame for b in order[:most] if b.frame}
        chosen |= {b.name for b in kept_boxes if b.frame in chosen}  # a frame is drawn whole
        total = len(kept_boxes)
        kept_boxes = [b for b in kept_boxes if b.name in chosen]
        kept_wires = [w for w in kept_wires if any(e in chosen for e in (*w.publishers, *w.subscribers))]
        said = (f"{total - len(kept_boxes)} of {total} nodes not drawn (the session's and the busiest are): give a "
                "pattern, or --node NAME --depth K")
    names = {b.name for b in kept_boxes}
    kept_wires = [dataclasses.replace(w, publishers=tuple(p for p in w.publishers if p in names),
                                      subscribers=tuple(s for s in w.subscribers if s in names)) for w in kept_wires]
    all_topics = len(set(snap.topics) - set(hidden) - internal)
    if len(kept_wires) < all_topics and not said and (pattern or focus):
        said = f"{all_topics - len(kept_wires)} topics and {len(boxes) - len(kept_boxes)} nodes outside " + (
            f"{pattern!r}" if pattern else f"{depth} hop{'s' * (depth != 1)} of {focus}")
    return Picture(tuple(kept_boxes), tuple(kept_wires), tuple(i for i in inner if i.frame in names), said, types)


def _wrapping(ours: Mapping[str, Drawn]) -> tuple[dict[str, tuple[str, str, str]], list[Inner], set[str]]:
    """Per outer topic of the session's nodes, its role, its guard's state and whose they are; the wires inside
    wrapping frames; the internal names those wires are."""
    roles: dict[str, tuple[str, str, str]] = {}
    inner: list[Inner] = []
    internal: set[str] = set()
    for name, drawn in ours.items():
        model = drawn.model
        base = base_fullname(model) if model.base is not None else None
        handlers = {(t.resolved, t.direction): t.handler for t in model.topics if t.role == "new"}
        for t in model.topics:
            guard = drawn.guards.get(t.resolved, "")
            if base is None or t.role == "new" and not _reused(model, t.resolved):
                if base is not None and t.direction == "publish" or guard:  # a plain node's topic has no role
                    roles[t.resolved] = ("added" if base is not None else roles.get(t.resolved, ("",))[0], guard,
                                         name)
                continue
            if t.role != "reuse":
                continue
            handler = handlers.get((t.resolved, "subscribe"))
            role = f"replaced by {handler}" if handler else "relayed"
            internal.add(internal_name(model, t.resolved))
            roles[t.resolved] = (role, guard, name)
            ends = (base, name) if t.direction == "publish" else (name, base)
            inner.append(Inner(name, *ends, t.resolved, role))
    return roles, inner, internal


def _reused(model: NodeModel, resolved: str) -> bool:
    return any(t.role == "reuse" and t.resolved == resolved for t in model.topics)


def _cut(boxes: list[Box], wires: list[Wire], pattern: str, focus: Optional[str],
         depth: int) -> tuple[list[Box], list[Wire]]:
    """What a pattern or a focus keeps: the topics matching (or near the focus) and the nodes at their ends."""
    if focus:
        reach = {focus}
        for _ in range(max(0, depth)):
            touching = [w for w in wires if reach & {*w.publishers, *w.subscribers}]
            reach |= {e for w in touching for e in (*w.publishers, *w.subscribers)}
        frames = {b.frame for b in boxes if b.name in reach and b.frame}
        reach |= {b.name for b in boxes if b.frame in frames} | frames
        wires = [w for w in wires if reach & {*w.publishers, *w.subscribers}]
        boxes = [b for b in boxes if b.name in reach]
        return boxes, wires
    if pattern:
        wires = [w for w in wires if name_matches(w.topic, pattern)]
        ends = {e for w in wires for e in (*w.publishers, *w.subscribers)}
        ends |= {b.name for b in boxes if name_matches(b.name, pattern)}
        frames = {b.frame for b in boxes if b.name in ends and b.frame}
        boxes = [b for b in boxes if b.name in ends or b.frame in frames]
        return boxes, wires
    return boxes, wires


# -- Graphviz -----------------------------------------------------------------------------------------------------

_COLOURS = {"session": "#dbeafe", "wrapping": "#dbeafe", "basenode": "#f3f4f6", "node": "#ffffff"}


def _guard_colour(state: str) -> str:
    if state.startswith("passing"):
        return "#15803d"
    if "clamp" in state or "drop" in state:
        return "#b45309"
    return "#b91c1c"  # stopped, stopping, e-stopped, not running


def to_dot(drawn: Picture, fit: Optional[tuple[float, float]] = None) -> str:
    """Graphviz's dot language for ``drawn``: node ids are the names themselves (quoted), so an SVG's text and its
    ``<title>`` elements name every node and topic as ROS does. ``fit`` (inches wide, high): a larger drawing is
    scaled down to it, as a notebook's cell is only so wide; a smaller one is left as it is."""
    types, rates = drawn.types, drawn.rates
    size = f', size="{fit[0]:g},{fit[1]:g}"' if fit else ""
    lines = ["digraph ros {", f'  graph [rankdir=LR, fontname="Helvetica", fontsize=11, newrank=true{size}];',
             '  node [fontname="Helvetica", fontsize=10];', '  edge [fontname="Helvetica", fontsize=9];']
    for frame in drawn.frames:
        boxes = [b for b in drawn.boxes if b.frame == frame]
        wrapper = next((b for b in boxes if b.name == frame), None)
        label = f"{frame} wraps" + (f" {wrapper.note.removeprefix('wraps ')}" if wrapper and wrapper.note else "")
        lines.append(f"  subgraph {_q('cluster_' + frame)} {{")
        lines.append(f'    label={_q(label)}; style="rounded"; color="#2563eb";')
        for box in boxes:
            lines.append("    " + _box(box))
        lines.append("  }")
    for box in drawn.boxes:
        if not box.frame:
            lines.append("  " + _box(box))
    for wire in drawn.wires:
        label = wire.topic + (f"\n{wire.type}" if types and wire.type else "") + (
            f"\n{rates[wire.topic]}" if wire.topic in rates else "")
        fill = "#eef2ff" if wire.role else "#ffffff"
        lines.append(f"  {_q('topic ' + wire.topic)} [label={_q(label)}, shape=box, style=\"rounded,filled\", "
                     f"fillcolor={_q(fill)}, height=0.25, fontsize=9];")
        for publisher in wire.publishers:
            attrs = []
            if wire.role and publisher == wire.by:  # what the session's node does to it, on its own edge
                attrs.append(f"label={_q(wire.role)}")
            if wire.guard and publisher == wire.by:
                attrs += [f"headlabel={_q('guard: ' + wire.guard)}", f"color={_q(_guard_colour(wire.guard))}",
                          f"fontcolor={_q(_guard_colour(wire.guard))}", "penwidth=2"]
            lines.append(f"  {_q(publisher)} -> {_q('topic ' + wire.topic)}" + (f" [{', '.join(attrs)}]" if attrs
                                                                                  else "") + ";")
        for subscriber in wire.subscribers:
            attrs = [f"label={_q(wire.role)}"] if wire.role and subscriber == wire.by else []
            lines.append(f"  {_q('topic ' + wire.topic)} -> {_q(subscriber)}" + (f" [{', '.join(attrs)}]"
                                                                                  if attrs else "") + ";")
    for link in drawn.inner:
        lines.append(f"  {_q(link.source)} -> {_q(link.target)} [label={_q(link.topic + ': ' + link.role)}, "
                     'style=dashed, color="#2563eb", fontcolor="#1d4ed8"];')
    if drawn.left_out:
        lines.append(f"  label={_q(drawn.left_out)}; labelloc=b;")
    lines.append("}")
    return "\n".join(lines) + "\n"


def _box(box: Box) -> str:
    kind = {"session": "this session", "wrapping": "this session", "basenode": "basenode"}.get(box.kind, "")
    label = box.name + (f"\n({kind})" if kind else "") + (f"\n{box.note}" if box.note and box.kind != "wrapping"
                                                          else "")
    shape = "box" if box.kind != "basenode" else "component"
    return (f"{_q(box.name)} [label={_q(label)}, shape={shape}, style=\"filled,rounded\", "
            f"fillcolor={_q(_COLOURS[box.kind])}];")


def _q(text: str) -> str:
    return '"' + text.replace("\\", "\\\\").replace('"', '\\"').replace("\n", "\\n") + '"'


# -- text ---------------------------------------------------------------------------------------------------------

def to_text(drawn: Picture, width: int = 80) -> str:
    """A tree by node that fits ``width`` columns: each node, then each topic it publishes (→ who hears it) and
    subscribes (← who sends it), a wrapping node's basenode and inner wires under it, guards and roles said."""
    out: list[str] = []
    order = sorted(drawn.boxes, key=lambda b: (b.kind not in ("session", "wrapping"), b.frame or b.name,
                                               b.kind == "basenode", b.name))
    ends: dict[str, list[Wire]] = defaultdict(list)  # each node's wires, in the picture's order, found once
    for wire in drawn.wires:
        for end in dict.fromkeys((*wire.publishers, *wire.subscribers)):
            ends[end].append(wire)
    for box in order:
        if box.kind == "basenode":
            continue  # under its wrapping node
        kind = {"session": " (this session)", "wrapping": f" (this session, {box.note})"}.get(box.kind, "")
        out.append(_fit(f"{box.name}{kind}", width))
        lines: list[str] = []
        if box.kind == "wrapping":
            base = next((b for b in drawn.boxes if b.kind == "basenode" and b.frame == box.name), None)
            if base is not None:
                lines.append(f"basenode {base.name}" + (f" ({base.note})" if base.note else ""))
            for link in [w for w in drawn.inner if w.frame == box.name]:
                way = "out" if link.source != box.name else "in"
                lines.append(f"  its {link.topic} {way}: {link.role}")
        for wire in ends.get(box.name, ()):
            typed = f" [{wire.type}]" if drawn.types and wire.type else ""
            ours = box.name == wire.by  # what a node of the session does to a topic is said on its own lines
            extra = (f" ({wire.role})" if wire.role and ours else "") + (
                f" guard: {wire.guard}" if wire.guard and ours and box.name in wire.publishers else "")
            if box.name in wire.publishers:
                heard = ", ".join(wire.subscribers) or "nobody"
                lines.append(f"out {wire.topic}{typed}{extra} → {heard}")
            if box.name in wire.subscribers:
                sent = ", ".join(wire.publishers) or "nobody"
                lines.append(f"in  {wire.topic}{typed}{extra} ← {sent}")
        for number, line in enumerate(lines):
            out.append(_fit(("└─ " if number == len(lines) - 1 else "├─ ") + line, width))
    if drawn.left_out:
        out.append(_fit(drawn.left_out, width))
    return "\n".join(out) if out else "nothing to draw: no node matches"


def _fit(line: str, width: int) -> str:
    return line if len(line) <= width else line[: width - 1] + "…"
