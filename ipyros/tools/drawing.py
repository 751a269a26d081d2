"""``%graph``'s work: the session's nodes as :func:`~ipyros.core.picture.picture` needs them, and Graphviz's layout.

The picture itself is pure (:mod:`ipyros.core.picture`); here it meets the session (its nodes' models, their guards'
states, on ROS 1 the one process node all of them live in, named back to the DSL nodes) and Graphviz's ``dot``
(Debian's ``graphviz``), run once a picture with a time limit. Why ``dot`` itself and no binding: the maintained
Python bindings (``graphviz``, ``pydot``) only write this text and run the same program; the layout is dot's.
"""

from __future__ import annotations

import shutil
import subprocess
from typing import Optional

from ..core.errors import IpyrosError
from ..core.graph import GraphSnapshot
from ..core.names import is_tool
from ..core.picture import MOST_BOXES, Drawn, Picture, picture
from ..dsl import engine_of, node_of
from ..node.session import Session
from .graph import as_dsl_nodes

__all__ = ["DOT_SECONDS", "layout", "session_picture"]

#: Nodes every graph has, which say nothing of the robot (ROS 1's log collector).
HIDDEN_NODES = ("/rosout",)

#: How long Graphviz may take to lay a picture out (500 nodes: about a second here).
DOT_SECONDS = 30.0


def session_picture(session: Session, snap: GraphSnapshot, pattern: str = "", focus: Optional[str] = None,
                    depth: int = 1, most: int = MOST_BOXES, types: bool = False) -> Picture:
    """The picture of ``snap`` with the session's nodes drawn as the session knows them."""
    ours: dict[str, Drawn] = {}
    for engine in list(session.nodes.values()):
        if is_tool(engine.name) or not engine.created:
            continue
        node = node_of(engine)  # type: ignore[arg-type]
        model = node.model()
        states = {}
        for guard in engine_of(node).guards.states():  # not node.status(): its handlers' figures are not drawn
            clamped = guard.figures.clamped
            states[guard.topic] = guard.state + (f", {clamped} clamped" if clamped and guard.state == "passing"
                                                 else "")
        ours[node.fullname] = Drawn(model, states, (model.base.machine or "") if model.base else "")
    snap = as_dsl_nodes(snap, session)
    shared = session.process.name if session.process.shared and session.process.name not in ours else None
    hidden_nodes = {n for n in snap.nodes if is_tool(n) or n in (shared, *HIDDEN_NODES)}
    return picture(snap, ours, pattern, focus, depth, most, unseen=hidden_nodes, types=types)


def layout(dot_source: str, form: str = "svg", timeout: float = DOT_SECONDS) -> bytes:
    """``dot_source`` laid out by Graphviz as ``form`` (svg, png); a one-line error without Graphviz."""
    program = shutil.which("dot")
    if program is None:
        raise IpyrosError("Graphviz's dot is not installed, so the graph cannot be drawn as a picture: "
                          "apt-get install graphviz (in a terminal, %graph draws text without it)")
    try:
        done = subprocess.run([program, f"-T{form}"], input=dot_source.encode(), capture_output=True,
                              timeout=timeout, check=False)
    except subprocess.TimeoutExpired:
        raise IpyrosError(f"Graphviz took more than {timeout:g} s to lay the graph out: draw less of it (a "
                          "pattern, or --node NAME --depth 1)") from None
    if done.returncode != 0:
        said = done.stderr.decode(errors="replace").strip().splitlines()
        raise IpyrosError(f"Graphviz could not draw the graph: {said[-1] if said else done.returncode}")
    return done.stdout
