"""``%graph``: the live graph as a picture, drawn as the paper draws wrapping.

    %graph                      every node and topic (a tree by node in a terminal, an SVG in Jupyter)
    %graph /turtle1/*           the topics a pattern matches, and the nodes at their ends
    %graph --node w --depth 2   what is within two hops of one node
    %graph --save graph.svg     written to a file (.svg or .png), laid out by Graphviz
    %graph --live               Jupyter: redrawn in place as the graph changes, until %graph --stop

A wrapping node is a frame around its basenode; the base's topics pass through it, each said relayed, replaced by
a handler (named) or added; a guard's edge is coloured by its state. See :mod:`ipyros.core.picture`.
"""

from __future__ import annotations

import dataclasses
import threading
import time
from pathlib import Path
from typing import Any, Optional

from IPython.core.error import UsageError
from IPython.core.magic import line_magic, magics_class
from IPython.core.magic_arguments import magic_arguments, parse_argstring

from ...core.errors import IpyrosError
from ...core.picture import MOST_BOXES, Picture, to_dot
from ...tools.drawing import layout, session_picture
from ...tools.probe import measure_rates
from ..api import live_graph, node_name
from ..arguments import NODE, TOPIC, argument
from ..display import CELL_FIT
from .cell_output import in_kernel
from .common import ExtensionMagics

#: How often ``%graph --live`` looks at the graph again (s); it redraws only when the picture changed.
LIVE_LOOK = 1.0
#: At most this many topics are measured for ``--hz`` (one second, all at once).
MOST_MEASURED = 100


@magics_class
class DrawingMagics(ExtensionMagics):
    """The graph drawn."""

    def __init__(self, shell: Any, ext: Any) -> None:
        super().__init__(shell, ext)
        self._live: Optional[threading.Event] = None  # set to stop the --live redraw

    @magic_arguments()
    @argument("pattern", nargs="?", default="", complete=TOPIC,
              help="only the topics (and nodes) this matches: a glob (/turtle1/*) or a part of the name")
    @argument("--node", complete=NODE, help="only what is within --depth hops of this node (a hop: node, topic, node)")
    @argument("--depth", type=int, default=1, help="with --node: how many hops around it (default 1)")
    @argument("--types", action="store_true", help="each topic's message type under its name")
    @argument("--hz", action="store_true", help="each topic's rate, measured for a second")
    @argument("--most", type=int, default=MOST_BOXES,
              help=f"draw at most this many nodes (default {MOST_BOXES}): the session's first, then the busiest")
    @argument("--save", metavar="FILE", help="write the picture to FILE (.svg or .png) instead of showing it")
    @argument("--live", action="store_true", help="Jupyter: redraw in place as the graph changes, until %%graph --stop")
    @argument("--stop", action="store_true", help="stop a --live picture's redrawing")
    @line_magic
    def graph(self, line: str) -> Optional[Picture]:
        """Draw the live graph: each node, each topic between its publishers and subscribers, each wrapping node of
        the session as a frame around its basenode with the base's topics relayed, replaced (by which handler) or
        added, and each guard with its state. A terminal gets a tree by node that fits its width; Jupyter an SVG
        laid out by Graphviz. Returns the picture (its boxes and wires as data)."""
        args = parse_argstring(self.graph, line)
        if args.stop:
            self.stop_live()
            return None
        if args.depth < 0 or args.most < 1:
            raise UsageError("--depth must be 0 or more and --most 1 or more")
        if args.save and Path(args.save).suffix.lower() not in (".svg", ".png"):
            raise UsageError(f"--save {args.save}: give a .svg or .png file")
        if args.live and not in_kernel(self.shell):
            raise UsageError("--live redraws a picture in a notebook; in a terminal, run %graph again")
        focus = node_name(args.node) if args.node else None
        drawn = self._draw(args.pattern, focus, args.depth, args.most, args.types)
        if focus is not None and not any(b.name == focus for b in drawn.boxes):
            raise UsageError(f"no node {focus} in the graph; %nodes lists them")
        if args.hz:
            drawn = dataclasses.replace(drawn, rates=self._rates(drawn))
        if args.save:
            data = layout(to_dot(drawn), Path(args.save).suffix.lower().lstrip("."))
            try:
                Path(args.save).expanduser().write_bytes(data)
            except OSError as error:
                raise UsageError(f"cannot write {args.save}: {error.strerror or error}") from None
            print(f"ipyros: the graph ({len(drawn.boxes)} nodes, {len(drawn.wires)} topics) drawn to {args.save}")
            return None
        if args.live:
            self._live_svg(drawn, args, focus)
            return None
        return drawn  # shown once, as the cell's result: the tree in a terminal, the SVG in Jupyter

    # -- helpers ---------------------------------------------------------------------------------------------
    def _draw(self, pattern: str, focus: Optional[str], depth: int, most: int, types: bool) -> Picture:
        return session_picture(self.ext.session, live_graph(self.ext), pattern, focus, depth, most, types)

    def _rates(self, drawn: Picture) -> dict[str, str]:
        topics = {w.topic: w.type for w in drawn.wires[:MOST_MEASURED] if w.type}
        found = measure_rates(topics, 1.0)
        return {topic: (f"{rate.hz:.1f} Hz" if rate is not None and rate.hz is not None else "silent")
                for topic, rate in found.items()}

    def _live_svg(self, drawn: Picture, args: Any, focus: Optional[str]) -> None:
        """One picture in the notebook, replaced (not appended) when the graph changes, until ``%graph --stop``."""
        from IPython.display import SVG, display

        source = to_dot(drawn, CELL_FIT)
        handle = display(SVG(layout(source)), display_id=True)
        self.stop_live()
        stop = self._live = threading.Event()

        def redraw() -> None:
            last = source
            while not stop.wait(LIVE_LOOK):
                try:
                    fresh = self._draw(args.pattern, focus, args.depth, args.most, args.types)
                    now = to_dot(dataclasses.replace(fresh, rates=drawn.rates), CELL_FIT)
                    if now != last:
                        handle.update(SVG(layout(now)))
                        last = now
                except IpyrosError:
                    continue  # the master went away for a moment: the picture stays as it was
                except Exception:  # noqa: BLE001 - a redraw thread never raises into the kernel
                    time.sleep(LIVE_LOOK)

        threading.Thread(target=redraw, name="ipyros-graph-live", daemon=True).start()

    def stop_live(self) -> None:
        if self._live is not None:
            self._live.set()
            self._live = None
