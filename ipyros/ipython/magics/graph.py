"""``%topics``, ``%echo``, ``%pub``: what ``rostopic list/echo/pub`` do, at the prompt.

They read the graph from the master afresh (:meth:`GraphCache.refresh_now`, bounded by a
short timeout), listen and publish through the small DSL nodes of :mod:`ipyros.tools.probe`,
and print with rich (tables in a terminal or a notebook, plain text in a pipe).
"""

from __future__ import annotations

import re
import time
from typing import Any, Optional

from IPython.core.error import UsageError
from IPython.core.magic import line_cell_magic, line_magic, magics_class, no_var_expand
from IPython.core.magic_arguments import magic_arguments, parse_argstring
from rich.syntax import Syntax
from rich.table import Table

from ...core import msgpath, msgtypes
from ...core.msgbuild import build_message, fields_of, flat_fields, parse_data, to_yaml
from ...tools.probe import Echo, measure_rates
from ..api import (
    as_dsl_nodes,
    close_names,
    compile_filter,
    global_topic,
    live_graph,
    live_type,
    node_name,
    split_head,
    topic_and_field,
    type_once_live,
)
from ..arguments import MSG_PATH, MSG_TEMPLATE, MSG_TYPE, NODE, TOPIC, argument
from ..display import endpoints_table, topics_table
from ..widgets import PublisherForm
from .cell_output import OutputArea, in_kernel
from .common import ExtensionMagics


class Messages(list):
    """What ``%echo`` heard: a list of messages that shows as one line, not as all of them again."""

    def __init__(self, topic: str) -> None:
        super().__init__()
        self.topic = topic

    def __repr__(self) -> str:
        return f"<{len(self)} message{'s' * (len(self) != 1)} from {self.topic}: a list>"


def _fields_yaml(msg: Any, fields: list[str], type_name: str) -> str:
    """The chosen fields of ``msg`` as YAML lines, ``linear.x: 1.0``, each read by its dotted path."""
    lines = []
    for path in fields:
        value = msg
        for part in path.split("."):
            if part not in fields_of(value):
                have = ", ".join(fields_of(value)) or "no fields"
                raise UsageError(f"--field {path}: no field {part!r} in {getattr(value, '_type', type_name)} "
                                 f"(it has {have})")
            value = getattr(value, part)
        text = to_yaml(value)
        lines.append(f"{path}: {text}" if "\n" not in text else f"{path}:\n  " + text.replace("\n", "\n  "))
    return "\n".join(lines)


def _message_path(snap: Any, text: str) -> Optional[msgpath.MessagePath]:
    """``text`` as a message path into a topic, or None for a topic (or rostopic's slash path, ``/pose/position``).
    rostopic's spelling mixed with dots (``/turtle1/pose/position.x``) is read as ``/turtle1/pose.position.x``."""
    if len(text) > 1 and text[0] == text[-1] and text[0] in "'\"":
        text = text[1:-1]  # IPython's argument split keeps the quotes a path with braces needs
    if not msgpath.is_path(text):
        return None
    path = msgpath.parse(text)
    head, slash_field = topic_and_field(snap, global_topic(path.topic))
    if slash_field:
        path = msgpath.parse(head + "." + slash_field + text[len(path.topic):])
    return msgpath.MessagePath(path.text, global_topic(path.topic), path.steps)


def _path_yaml(field: str, values: list[Any]) -> str:
    """What a message path selected in one message, as YAML: ``x: 1.0``, or a list when a slice selected several."""
    if len(values) == 1 and not any(mark in field for mark in ":{"):
        text = to_yaml(values[0])
        return f"{field}: {text}" if "\n" not in text else f"{field}:\n  " + text.replace("\n", "\n  ")
    items = [to_yaml(value) for value in values]
    return f"{field}:\n" + "\n".join("- " + item.replace("\n", "\n  ") for item in items)


# "pkg/Type" or "pkg/msg/Type": how %pub tells a type from the message data after the topic.
_TYPE_WORD = re.compile(r"[A-Za-z]\w*/(msg/)?[A-Za-z]\w*")


@magics_class
class TopicMagics(ExtensionMagics):
    """Magics about the live topics of the ROS graph."""

    # -- %topics -------------------------------------------------------------------------
    @magic_arguments()
    @argument("pattern", nargs="?", default="", complete=TOPIC,
              help="only topics matching this glob (/turtle*/pose) or containing this text (cmd)")
    @argument("-t", "--type", complete=MSG_TYPE, help="only topics of this message type (a glob works: geometry_msgs/*)")
    @argument("-n", "--node", complete=NODE, help="only topics this node publishes or subscribes to")
    @argument("--hz", action="store_true",
              help="also measure each topic's message rate, listening for c.RosMagics.hz_window seconds")
    @argument("-v", "--verbose", action="store_true",
              help="one row per publisher and subscription, with the type each uses and (ROS 2) the QoS each "
                   "offers or asks for")
    @argument("--find", metavar="TYPE", complete=MSG_TYPE,
              help="only the names of the topics of this type, one per line (as rostopic find)")
    @line_magic
    def topics(self, line: str) -> None:
        """List the live topics: name, type, publishers and subscribers."""
        args = parse_argstring(self.topics, line)
        snap = live_graph(self.ext)
        if args.find:
            found = snap.topics_matching(args.pattern, type=msgtypes.resolve_message(args.find)[0])
            print("\n".join(found) if found else f"no live topic of type {args.find}")
            return
        node = node_name(args.node) if args.node else None
        if node and node not in snap.nodes:
            raise UsageError(f"no node {node} in the ROS graph{close_names(node, snap.nodes)}")
        found = snap.topics_matching(args.pattern, type=args.type, node=node)
        if not found:
            if args.type and not any(c in args.type for c in "*?[") and args.type not in snap.topics.values():
                msgtypes.resolve_message(args.type)  # a misspelt type: its error says so
            what = " and ".join(filter(None, [
                f"matching {args.pattern!r}" if args.pattern else "", f"of type {args.type}" if args.type else "",
                f"of node {node}" if node else ""]))
            print(f"no live topics {what}".rstrip() + (" (the master knows none)" if not snap.topics else ""))
            return
        if args.verbose:
            self.ext.printer.show(endpoints_table(snap, found, self.ext.session.backend.topic_endpoints,
                                                   self.ext.graph.where))
            return
        window = self.ext.settings.hz_window
        rates = measure_rates({t: snap.topics[t] for t in found}, window) if args.hz else None
        self.ext.printer.show(topics_table(as_dsl_nodes(snap, self.ext.session), found, rates, window,
                                            self.ext.graph.where))
        missing = msgtypes.not_installed(snap.topics[t] for t in found)
        if missing:  # listed all the same: the graph has them; what cannot be read here is said, with the cure
            print("ipyros: types not installed here (their topics cannot be echoed or handled in this session): "
                  + "; ".join(f"{name} ({how})" for name, how in missing.items()))

    # -- %echo ---------------------------------------------------------------------------
    @magic_arguments()
    @argument("topic", complete=MSG_PATH, help="the live topic to listen to, or a message path into it: "
              "/odom.pose.pose.position.x, /scan.ranges[:3], '/poses.poses[:]{position.x>0}.position.x'")
    @argument("-n", "--count", type=int, default=None,
              help="stop after this many messages (default c.RosMagics.echo_count; 0: until Ctrl-C)")
    @argument("--field", action="extend", nargs="+", metavar="A.B",
              help="print only these fields, e.g. --field linear.x angular.z (or --field repeated)")
    @argument("--filter", metavar="EXPR",
              help="only messages for which this Python expression over m is true, e.g. 'm.linear.x > 0'; "
                   "it sees your namespace")
    @argument("--csv", action="store_true", help="one line per message, comma-separated, a header line first")
    @argument("--table", action="store_true", help="a table of the messages when the listening ends")
    @argument("--once", action="store_true", help="one message, then stop (-n 1)")
    @argument("--noarr", action="store_true", help="show arrays as <array of N type>, not their items")
    @argument("--offset", action="store_true", help="show times as seconds from now (how old a stamp is)")
    @no_var_expand
    @line_magic
    def echo(self, line: str) -> "Messages":
        """Print the messages arriving on TOPIC until Ctrl-C (or -n of them); return them.

        The output is YAML that ``%pub`` takes back. ``msgs = %echo /x -n 20`` keeps the
        messages (a list). Ctrl-C stops only the listening: nodes keep running. The
        subscription made for listening is removed when it stops.
        """
        args = parse_argstring(self.echo, line)
        count = 1 if args.once else self.ext.settings.echo_count if args.count is None else args.count
        if count < 0:
            raise UsageError(f"-n must be 0 (until Ctrl-C) or more, not {count}")
        path = _message_path(self.ext.graph.snapshot, args.topic)
        if path is not None:  # /odom.pose.pose.position.x, /scan.ranges[:5], /poses.poses[:]{position.x>0}
            if args.csv or args.table or args.field:
                raise UsageError("a message path prints the values it selects, as YAML: give the topic alone with "
                                 "--field for --csv or --table")
            topic, field = path.topic, ""
        else:
            topic, field = topic_and_field(self.ext.graph.snapshot, global_topic(args.topic))
        keep = compile_filter(args.filter, self.shell.user_ns) if args.filter else None
        fields = [f.strip("'\"") for f in args.field or []] + ([field] if field else [])
        seen = Messages(topic)
        type_name = type_once_live(self.ext, topic)
        if type_name is None:  # Ctrl-C while waiting for it
            return seen
        if path is not None:  # a field its type lacks: said now, not after the first message
            path.check(msgtypes.message_class_or_none(type_name))
        if args.csv and args.table:
            raise UsageError("give --csv or --table, not both (without either: YAML, which %pub takes back)")
        printer = self.ext.printer
        # In Jupyter, listening until interrupted would print past the front end's output limit:
        # the last messages in one area redrawn in place instead.
        endless = not count and not (args.csv or args.table)
        rolling = OutputArea(lines=400) if endless and in_kernel(self.shell) else None
        rows = _Rows(fields, type_name, csv=args.csv) if args.csv or args.table else None
        with Echo(topic, type_name) as echo:
            try:
                while not count or len(seen) < count:
                    msg = echo.get(timeout=0.1)  # short waits: Ctrl-C gets through between them
                    # (no `continue` here: CPython 3.11 can raise Ctrl-C at that jump, outside this try)
                    selected = path.values(msg, self.shell.user_ns) if path is not None and msg is not None else None
                    if msg is not None and (keep is None or keep(msg, len(seen) + 1)) and selected != []:
                        seen.append(msg)
                        if rows is not None:
                            rows.add(msg)
                        else:
                            text = _path_yaml(path.field, selected) if path is not None and selected is not None \
                                else _fields_yaml(msg, fields, type_name) if fields else \
                                to_yaml(msg, noarr=args.noarr, offset=args.offset)
                            if rolling is not None:
                                rolling.write(f"{text}\n---\n")
                            else:
                                printer.show(Syntax(text, "yaml", background_color="default"), "---")
            except KeyboardInterrupt:
                print(f"stopped listening to {topic} after {len(seen)} message{'s' * (len(seen) != 1)}")
            finally:
                if rolling is not None:
                    rolling.flush()
        if rows is not None and args.table:
            printer.show(rows.table(f"{len(seen)} message{'s' * (len(seen) != 1)} from {topic}"))
        return seen

    # -- %pub / %%pub ----------------------------------------------------------------------
    @magic_arguments()
    @argument("topic", complete=TOPIC, help="the topic to publish on")
    @argument("type", nargs="?", complete=MSG_TYPE, help="its message type, pkg/Type; may be left out for a live topic")
    @argument("data", nargs="*", complete=MSG_TEMPLATE, help="the message, the rest of the line (or the cell of %%%%pub): a Python "
              "dict, a YAML mapping, a list of all fields in order, or one value for a one-field message; "
              "fields left out keep their defaults, unknown or mistyped fields are errors")
    @argument("-t", "--type", dest="type_option", metavar="TYPE", complete=MSG_TYPE, help="the message type, as an option")
    @argument("-r", "--rate", type=float, help="publish again at this rate (Hz) until Ctrl-C")
    @argument("--latch", action="store_true", help="keep the message for subscribers that come later too "
              "(ROS 1 latched, ROS 2 transient local), until the extension is unloaded")
    @argument("--nonfinite", action="store_true", help="let NaN and infinities through (refused otherwise: "
              "typed by mistake they reach a controller as a command)")
    @argument("--widget", action="store_true", help="Jupyter: a form of the message's fields (sliders, toggles, "
              "text) that publishes as they move, or at a rate; a guarded topic's sliders span the guard's limits; "
              "returns it (form.fields['linear.x'].value = 0.3)")
    @no_var_expand
    @line_cell_magic
    def pub(self, line: str, cell: Optional[str] = None) -> Any:
        """Publish one message on TOPIC, built and checked field by field.

            %pub /chatter std_msgs/String hello
            %pub /turtle1/cmd_vel geometry_msgs/Twist {linear: {x: 1.0}, angular: {z: 0.5}}
            %pub /turtle1/cmd_vel {'linear': {'x': 1.0}}      # type taken from the live topic

            %%pub /turtle1/cmd_vel geometry_msgs/Twist
            linear: {x: 1.0}
            angular: {z: 0.5}

        Options may go before or after the message: everything else after TOPIC and TYPE is the message.
        The message waits a moment for the subscribers the graph knows to connect, then goes
        out once (as rostopic pub -1 / ros2 topic pub --once); --latch keeps it for later ones
        too. A topic that one of your nodes already publishes is published through that node.
        """
        head, data = split_head(line, self.pub.parser,
                                lambda index, word: index == 0 or (index == 1 and bool(_TYPE_WORD.fullmatch(word))))
        args = parse_argstring(self.pub, head)
        if cell is not None:
            if data:
                raise UsageError("give the message either on the line or in the cell of %%pub, not both")
            data = cell
        if args.type and args.type_option and args.type != args.type_option:
            raise UsageError(f"two message types given ({args.type} and {args.type_option}); give one")
        if args.rate is not None and not args.rate > 0:
            raise UsageError(f"--rate must be a positive number of messages per second, not {args.rate}")
        topic = global_topic(args.topic)
        given = args.type or args.type_option
        type_name = msgtypes.resolve_message(given)[0] if given else live_type(self.ext, topic, for_pub=True)
        msg = build_message(type_name, parse_data(data), nonfinite=args.nonfinite)
        if args.widget:
            return self._form(topic, type_name, msg, args.latch)
        if args.rate is None:
            sender, reached = self.ext.publisher.publish(topic, type_name, msg, latch=args.latch)
            later = "; latched: subscribers that come later get it too" if args.latch else ""
            print(f"published a {type_name} on {topic} (from {sender}) to {reached} subscriber"
                  f"{'s' * (reached != 1)}{later}")
            return
        self._publish_at(args.rate, topic, type_name, msg, args.latch)

    def _form(self, topic: str, type_name: str, initial: Any, latch: bool) -> PublisherForm:
        """``%pub --widget``: the form, in Jupyter; in a terminal, one line saying what to do instead."""
        if not in_kernel(self.shell):
            raise UsageError(f"widgets need Jupyter: %pub --widget draws a form in a notebook; here give the message: "
                             f"%pub {topic} {type_name} {{...}} (-r RATE to repeat it)")
        first = [True]

        def send(msg: Any) -> None:
            self.ext.publisher.publish(topic, type_name, msg, latch=latch, wait=first[0])
            first[0] = False

        guarded = self.ext.publisher.guard(topic, type_name)  # its sliders then span the guard's limits
        return PublisherForm(topic, type(initial), send, initial,
                             guarded and (guarded[0], guarded[1].limits))

    def _publish_at(self, rate: float, topic: str, type_name: str, msg: Any, latch: bool) -> None:
        period, sent = 1.0 / rate, 0
        print(f"publishing a {type_name} on {topic} at {rate:g} Hz; Ctrl-C to stop", flush=True)
        start = time.monotonic()
        try:
            while True:
                self.ext.publisher.publish(topic, type_name, msg, latch=latch, wait=sent == 0)
                sent += 1
                time.sleep(max(0.0, start + sent * period - time.monotonic()))
        except KeyboardInterrupt:
            print(f"published {sent} {type_name} message{'s' * (sent != 1)} on {topic} at {rate:g} Hz")

class _Rows:
    """``%echo --csv`` (a line per message, as it arrives) and ``--table`` (a table when done)."""

    def __init__(self, fields: list[str], type_name: str, csv: bool) -> None:
        self.fields, self.type_name, self.csv = fields, type_name, csv
        self.columns: Optional[list[str]] = None
        self.rows: list[list[str]] = []

    def add(self, msg: Any) -> None:
        flat = flat_fields(msg)
        if self.columns is None:
            for path in self.fields:  # a wrong field: the same one-line error as --field's
                _fields_yaml(msg, [path], self.type_name)
            self.columns = [c for c in flat if not self.fields or any(
                c == f or c.startswith(f + ".") for f in self.fields)]
            if self.csv:
                print(",".join(self.columns), flush=True)
        if self.csv:  # a file for a spreadsheet: every digit
            print(",".join(_csv_quoted(_cell(flat.get(c))) for c in self.columns), flush=True)
        else:  # a table to read: floats rounded (the messages returned keep every digit)
            self.rows.append([_cell(flat.get(c), rounded=True) for c in self.columns])

    def table(self, title: str) -> Table:
        table = Table(title=title, title_justify="left")
        for column in self.columns or []:
            table.add_column(column, justify="right")
        for row in self.rows:
            table.add_row(*row)
        return table


def _cell(value: Any, rounded: bool = False) -> str:
    if isinstance(value, list):
        return " ".join(_cell(item, rounded) for item in value)
    if rounded and isinstance(value, float):
        return f"{value:.6g}"
    return "" if value is None else str(value)


def _csv_quoted(text: str) -> str:
    return '"' + text.replace('"', '""') + '"' if any(c in text for c in ',"\n') else text


