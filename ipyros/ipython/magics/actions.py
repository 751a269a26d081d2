"""``%actions`` and ``%action``: what ``rostopic``/``axclient`` and ``ros2 action list/send_goal`` do, at the prompt.

    %actions                              live actions: type, servers, clients
    %action /fibonacci {order: 5}         a goal; its feedback live on one line; then the result
    %action /fibonacci test_msgs/Fibonacci {order: 5}   the type given (else read from the graph)
    %action --watch /fibonacci            the goals others send: each goal, feedback and end

Ctrl-C while a goal runs cancels it, and the cancel reaches the server (unlike a client
that is simply stopped): the line then says whether the server took it and how the goal
ended. The goal goes out from the session's own ROS node, as ``%call``'s requests do.
"""

from __future__ import annotations

import threading
import time
from typing import Any

from IPython.core.error import UsageError
from IPython.core.magic import line_magic, magics_class, no_var_expand
from IPython.core.magic_arguments import magic_arguments, parse_argstring
from rich.syntax import Syntax
from rich.table import Table
from rich.text import Text

from ...core import msgtypes
from ...core.errors import IpyrosError
from ...core.graph import actions_of, name_matches
from ...core.msgbuild import flow_yaml, parse_data, to_yaml
from ...core.names import tool_name
from ..api import global_topic, live_graph, split_head
from ..arguments import ACTION, ACTION_TYPE, GOAL_TEMPLATE, argument
from .common import ExtensionMagics

__all__ = ["ActionMagics"]

#: How often the feedback line is redrawn (s).
REDRAW_PERIOD = 0.1


def _short(text: str, most: int = 100) -> str:
    return text if len(text) <= most else text[: most - 1] + "…"


@magics_class
class ActionMagics(ExtensionMagics):
    """Actions of the live graph: list them, send goals with live feedback, watch others' goals."""

    def _ready(self) -> Any:
        """The session, with its ROS node up (goals go out from it)."""
        session = self.ext.session
        if not session.process.started:
            session.start_process_node("/" + tool_name("tools"))
        return session

    @magic_arguments()
    @argument("pattern", nargs="?", default="", complete=ACTION, help="only actions matching this glob or containing "
              "this text")
    @line_magic
    def actions(self, line: str) -> None:
        """List the live actions: name, type, the nodes serving them and the nodes calling them."""
        args = parse_argstring(self.actions, line)
        found = [a for a in actions_of(live_graph(self.ext)) if name_matches(a.name, args.pattern)]
        if not found:
            print(f"no live actions matching {args.pattern!r}" if args.pattern else "no live actions")
            return
        table = Table(title=f"{len(found)} live action{'s' * (len(found) != 1)} at {self.ext.graph.where}",
                      title_justify="left")
        for column in ("action", "type", "served by", "clients"):
            table.add_column(column, overflow="fold")
        for action in found:
            table.add_row(action.name, action.type, ", ".join(action.servers) or "[yellow]none[/]",
                          ", ".join(action.clients))
        self.ext.printer.show(table)

    @magic_arguments()
    @argument("name", complete=ACTION, help="the live action")
    @argument("type", nargs="?", complete=ACTION_TYPE, help="its type, pkg/Action; may be left out: read from the "
              "graph")
    @argument("goal", nargs="*", complete=GOAL_TEMPLATE, help="the goal, the rest of the line: a dict or YAML "
              "mapping, fields left out keep their defaults")
    @argument("-t", "--timeout", type=float, default=10.0, help="seconds the server may take to show up and "
              "accept the goal (default 10); the goal itself may take as long as it takes")
    @argument("-w", "--watch", action="store_true", help="send nothing: show the goals others send, their "
              "feedback and how they end, until Ctrl-C")
    @argument("-n", "--count", type=int, default=0, help="with --watch: stop after this many goals have ended")
    @no_var_expand
    @line_magic
    def action(self, line: str) -> None:
        """Send a goal to action NAME and show its feedback live, then its result; Ctrl-C cancels the goal
        (the cancel reaches the server). With --watch, show the goals others send instead."""
        head, data = split_head(line, self.action.parser, lambda index, word: index < 1 or (
            index == 1 and "/" in word and not word.startswith(("{", "[", "/"))))
        args = parse_argstring(self.action, head)
        name = global_topic(args.name)
        session = self._ready()
        live = {a.name: a for a in actions_of(live_graph(self.ext))}
        if not args.type and name not in live:
            raise UsageError(f"no live action {name}; %actions lists them (or give its type to wait for its server)")
        type_name, cls = msgtypes.resolve_action(args.type or live[name].type)
        if args.watch:
            self._watch(session, name, type_name, cls, args.count)
            return
        try:
            goal = session.send_goal(name, parse_data(data), type_name, None, args.timeout)
        except IpyrosError as error:
            raise UsageError(str(error)) from None
        started = time.monotonic()

        def line_now(_: float) -> Text:
            feedback = goal.feedback
            said = f"; feedback: {_short(flow_yaml(feedback))}" if feedback is not None else ""
            return Text(f"{name}: {goal.status}, {time.monotonic() - started:.1f} s{said}")

        interrupted = self.ext.printer.repeat(line_now, REDRAW_PERIOD, until=goal.done)
        if interrupted:
            took = goal.cancel()
            print(f"{name}: Ctrl-C: cancel sent; " + ("the server took it" if took else
                                                      "the server did not take it (yet)"), flush=True)
            try:
                goal.result(timeout=5.0)
            except TimeoutError:
                print(f"{name}: the goal has not ended 5 s after the cancel; it is {goal.status}")
                return
        result = goal.result(timeout=0)
        print(f"{name}: {goal.status} after {time.monotonic() - started:.1f} s", flush=True)
        if result is not None:
            self.ext.printer.show(Syntax(to_yaml(result) or "{}", "yaml", background_color="default"))

    def _watch(self, session: Any, name: str, type_name: str, cls: type, count: int) -> None:
        ended = threading.Semaphore(0)

        def tell(event: str, goal_id: str, message: Any) -> None:
            said = f": {_short(flow_yaml(message), 200)}" if message is not None else ""
            print(f"{name} [{goal_id[:8]}] {event}{said}", flush=True)
            if event in ("succeeded", "cancelled", "aborted", "rejected"):
                ended.release()

        print(f"watching {name} ({type_name}) until Ctrl-C" + (f" or {count} goals end" if count else ""),
              flush=True)
        watch = session.backend.watch_action(name, cls, tell)
        try:
            for _ in range(count) if count else iter(int, 1):
                while not ended.acquire(timeout=0.2):
                    pass
        except KeyboardInterrupt:
            pass
        finally:
            watch.close()
