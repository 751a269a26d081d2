"""``%services``, ``%call``, ``%params``, ``%param``, ``%nodes``, ``%node``, ``%interface``: what ``rosservice``,
``rosparam``, ``rosnode`` and ``rosmsg`` (``ros2 service/param/node/interface``) do, at the prompt, on either ROS.

    %services /turtle*                      live services, their types and servers
    %services --find std_srvs/SetBool       the names of the services of a type
    %interface geometry_msgs/Twist -r       a type's definition, nested types spelled out
    %call /turtle1/teleport {x: 2.0, y: 1}  a request built field by field; the response as YAML
    %params /turtle_sim                     parameters under a namespace (on ROS 2: of the nodes there)
    %param /turtle_sim/speed 2.0            read or set one
    %nodes                                  live nodes: what each publishes, subscribes, serves
    %node /turtle_sim                       one node's interface, its pid (ROS 1)

The graph comes from the same snapshot as ``%topics`` (read afresh); calls and parameter
reads go out through the session's backend (:mod:`ipyros.ros1.introspect`,
:mod:`ipyros.ros2.introspect`), with timeouts: a node that does not answer is said so.
Names ipyros uses inside a wrapping (``/<wrapper>/base/...``) and its own tool nodes are
marked as such, so they are not mistaken for the robot's.
"""

from __future__ import annotations

import time
from pathlib import Path
from typing import Any

import yaml
from IPython.core.error import UsageError
from IPython.core.magic import line_magic, magics_class, no_var_expand
from IPython.core.magic_arguments import magic_arguments, parse_argstring
from rich.syntax import Syntax
from rich.table import Table

from ...core import msgtypes
from ...core.errors import IpyrosError
from ...core.graph import GraphSnapshot, actions_of, name_matches
from ...core.msgbuild import build_message, definition, parse_data, to_yaml
from ...core.names import is_tool, tool_name
from ...core.userdata import load_yaml
from ...files.atomic import write_atomic
from ...tools import paramwatch
from ..api import global_topic, live_graph, split_head
from ..arguments import MSG_TYPE, NODE, REQUEST_TEMPLATE, SERVICE, SRV_TYPE, TRANSITION, argument
from ..widgets import ParamsForm
from .cell_output import in_kernel
from .common import ExtensionMagics


def internal(name: str, session_nodes: list[Any]) -> str:
    """Why ``name`` (a node or topic) is ipyros's, not the robot's: "" when it is not."""
    if is_tool(name):
        return "ipyros tool"
    for node in session_nodes:
        if name.startswith(node.fullname.rstrip("/") + "/base/"):
            return f"inside the wrapping of {node.name}"
    return ""


@magics_class
class IntrospectMagics(ExtensionMagics):
    """Services, parameters and nodes of the live graph."""

    def _ready(self) -> Any:
        """The backend, with the session's ROS node up (calls and reads go out from it)."""
        session = self.ext.session
        if not session.process.started:
            session.start_process_node("/" + tool_name("tools"))
        return session.backend

    # -- %services / %call ------------------------------------------------------------------
    @magic_arguments()
    @argument("pattern", nargs="?", default="", complete=SERVICE, help="only services matching this glob or containing this text")
    @argument("--find", metavar="TYPE", complete=SRV_TYPE,
              help="only the names of the services of this type, one per line (as rosservice find)")
    @line_magic
    def services(self, line: str) -> None:
        """List the live services: name, type and the nodes that serve them."""
        args = parse_argstring(self.services, line)
        snap = live_graph(self.ext)
        backend = self._ready()
        found = [s for s in snap.services if name_matches(s, args.pattern)]
        if args.find:
            wanted = msgtypes.resolve_service(args.find)[0]
            found = [s for s in found if _same_type(_type_or_none(backend, s), wanted)]
            print("\n".join(found) if found else f"no live service of type {wanted}")
            return
        if not found:
            print(f"no live services matching {args.pattern!r}" if args.pattern else "no live services")
            return
        table = Table(title=f"{len(found)} live service{'s' * (len(found) != 1)} at {self.ext.graph.where}",
                      title_justify="left")
        for column in ("service", "type", "served by"):
            table.add_column(column, overflow="fold")
        for name in found:
            try:
                type_name = backend.service_type(name)
            except Exception as error:  # noqa: BLE001 - one dead server must not hide the others
                type_name = f"? ({error})"
            table.add_row(name, type_name, ", ".join(snap.services[name]))
        self.ext.printer.show(table)

    @magic_arguments()
    @argument("service", complete=SERVICE, help="the live service to call")
    @argument("type", nargs="?", complete=SRV_TYPE, help="its type, pkg/Service; may be left out: asked of the live service")
    @argument("request", nargs="*", complete=REQUEST_TEMPLATE, help="the request, the rest of the line: a dict or YAML mapping, "
              "fields left out keep their defaults")
    @argument("-t", "--timeout", type=float, default=5.0, help="seconds to wait for the answer (default 5)")
    @no_var_expand
    @line_magic
    def call(self, line: str) -> None:
        """Call SERVICE with a request built field by field (as %pub builds a message) and show the response
        as YAML. Unknown or mistyped fields are errors naming the field; a server that does not answer
        within the timeout is said so."""
        head, data = split_head(line, self.call.parser, lambda index, word: index < 1 or (
            index == 1 and "/" in word and not word.startswith(("{", "[", "/"))))
        args = parse_argstring(self.call, head)
        if not 0 < args.timeout < float("inf"):
            raise UsageError(f"-t {args.timeout:g}: give the seconds to wait for the answer, more than 0 (e.g. -t 5)")
        name = global_topic(args.service)
        backend = self._ready()
        if name not in live_graph(self.ext).services:
            raise UsageError(f"no live service {name}; %services lists them")
        type_name, cls = msgtypes.resolve_service(args.type or backend.service_type(name))
        request_class = cls._request_class if hasattr(cls, "_request_class") else cls.Request
        request = build_message(request_class, parse_data(data))
        response = backend.call(name, cls, request, args.timeout)
        self.ext.printer.show(Syntax(to_yaml(response) or "{}", "yaml", background_color="default"))

    # -- %interface ---------------------------------------------------------------------------
    @magic_arguments()
    @argument("type", complete=MSG_TYPE, help="a message, service or action type, pkg/Type")
    @argument("-r", "--expand", action="store_true", help="spell out nested message types below their field")
    @line_magic
    def interface(self, line: str) -> None:
        """Show a message, service or action type's definition (as rosmsg show, ros2 interface show):
        its constants and fields; --- between a service's request and response, an action's goal,
        result and feedback."""
        args = parse_argstring(self.interface, line)
        try:
            print(definition(args.type, args.expand))
        except IpyrosError as error:
            raise UsageError(str(error)) from None

    # -- %params / %param -------------------------------------------------------------------
    @magic_arguments()
    @argument("namespace", nargs="?", default="/", complete=NODE, help="only parameters under this namespace (default: all)")
    @argument("-a", "--all", action="store_true", help="also the parameters every node has (ROS 2: use_sim_time, "
              "start_type_description_service)")
    @argument("--dump", metavar="FILE", help="write them to a YAML file, {global name: value}, instead of showing "
              "them (as rosparam dump / ros2 param dump)")
    @argument("--load", metavar="FILE", help="set every parameter a --dump file holds (as rosparam load)")
    @argument("-w", "--watch", action="store_true", help="show each change as it happens (a parameter set, added "
              "or deleted, by anyone) until Ctrl-C")
    @argument("-n", type=int, metavar="N", help="with --watch: stop after N changes")
    @argument("--widget", action="store_true", help="Jupyter: sliders (toggles, text) for the parameters, within "
              "the ranges their nodes give, each set as it moves; returns the form")
    @line_magic
    def params(self, line: str) -> Any:
        """List the parameters under NAMESPACE with their values (ROS 2: the parameters of the nodes there)."""
        args = parse_argstring(self.params, line)
        namespace = global_topic(args.namespace)
        if args.widget and not in_kernel(self.shell):
            raise UsageError(f"widgets need Jupyter: %params --widget draws sliders in a notebook; here set one with "
                             f"%param NAME VALUE (%params {namespace} lists them)")
        backend = self._ready()
        if args.widget:
            values = backend.params_under(namespace)
            values = values if args.all else {k: v for k, v in values.items()
                                              if k.rsplit("/", 1)[-1] not in backend.standard_params}
            if not values:
                raise UsageError(f"no parameters under {namespace} to draw (%params {namespace} --all lists every one)")
            return ParamsForm(values, backend.describe_param, backend.write_param)
        if args.load:
            self._load_params(backend, args.load, namespace)
            return

        def read() -> dict[str, Any]:
            found = backend.params_under(namespace)
            return found if args.all else {k: v for k, v in found.items()
                                           if k.rsplit("/", 1)[-1] not in backend.standard_params}

        if args.watch:
            print(f"watching the parameters under {namespace}" + (f" for {args.n} change{'s' * (args.n != 1)}" if args.n else "")
                  + " (Ctrl-C stops)", flush=True)
            try:
                paramwatch.watch(read, lambda name, old, new: print(
                    f"{time.strftime('%H:%M:%S')} {name}: {_short(old)} → {_short(new)}", flush=True), count=args.n)
            except KeyboardInterrupt:
                print("stopped")
            return
        values = backend.params_under(namespace)
        standard = {name for name in values if name.rsplit("/", 1)[-1] in backend.standard_params}
        if not args.all:
            values = {name: value for name, value in values.items() if name not in standard}
        if args.dump:
            text = yaml.safe_dump(values, default_flow_style=False, sort_keys=True)
            written = write_atomic(Path(args.dump).expanduser(), text)
            print(f"ipyros: {len(values)} parameter{'s' * (len(values) != 1)} under {namespace} written to {written}")
            return
        if not values:
            print(f"no parameters under {namespace}" + (f" but the {len(standard)} every node has (--all shows them)"
                                                         if standard else ""))
            return
        ranges = backend.param_ranges(namespace)
        table = Table(title=f"{len(values)} parameter{'s' * (len(values) != 1)} under {namespace}",
                      title_justify="left")
        table.add_column("parameter", overflow="fold")
        table.add_column("value", overflow="fold")
        if ranges:  # set through their dynamic_reconfigure server by %param, within these
            table.add_column("dynamic_reconfigure", overflow="fold")
        for name, value in values.items():
            table.add_row(name, _short(value), *([ranges.get(name, "")] if ranges else []))
        self.ext.printer.show(table)

    def _load_params(self, backend: Any, path: str, namespace: str) -> None:
        """Set the parameters of a --dump file (those under ``namespace``); all are checked before any is set."""
        try:
            values = load_yaml(Path(path).expanduser().read_text(), path)
        except OSError as error:
            raise UsageError(f"--load {path}: {error.strerror or error}") from None
        if not isinstance(values, dict) or not all(isinstance(k, str) and k.startswith("/") for k in values):
            raise UsageError(f"--load {path}: expected a mapping of global parameter names to values, as --dump "
                             "writes it (/node/key: value)")
        chosen = {k: v for k, v in values.items() if k.startswith(namespace.rstrip("/") + "/") or namespace == "/"}
        for name, value in chosen.items():
            backend.write_param(name, value)
        print(f"ipyros: {len(chosen)} parameter{'s' * (len(chosen) != 1)} set from {path}")

    @magic_arguments()
    @argument("name", complete=NODE, help="the parameter's global name (ROS 2: /node/key)")
    @argument("value", nargs="*", help="a new value, the rest of the line (a Python literal or YAML); "
              "none: show the value")
    @argument("--describe", action="store_true", help="its type, and on ROS 2 its description, range and "
              "whether it is read-only (ros2 param describe)")
    @no_var_expand
    @line_magic
    def param(self, line: str) -> None:
        """Show the parameter NAME, or set it to VALUE (as rosparam get/set; ros2 param get/set)."""
        head, data = split_head(line, self.param.parser, lambda index, word: index < 1)
        args = parse_argstring(self.param, head)
        name = global_topic(args.name)
        backend = self._ready()
        if args.describe:
            described = backend.describe_param(name)
            print(f"{name}: " + ", ".join(f"{k} {v}" if v is not True else k for k, v in described.items()))
            return
        if not data.strip():
            value = backend.read_param(name)
            print(f"{name}: {_short(value)}")
            return
        value = backend.write_param(name, parse_data(data))
        print(f"ipyros: {name} = {_short(value)}")

    # -- %nodes / %node ---------------------------------------------------------------------
    @magic_arguments()
    @argument("pattern", nargs="?", default="", complete=NODE, help="only nodes matching this glob or containing this text")
    @argument("--cleanup", action="store_true", help="forget the registrations of nodes that no longer answer "
              "(ROS 1, as rosnode cleanup; ROS 2 discovery forgets them by itself)")
    @line_magic
    def nodes(self, line: str) -> None:
        """List the live nodes with how many topics each publishes and subscribes to and services it serves."""
        args = parse_argstring(self.nodes, line)
        if args.cleanup:
            gone = self._ready().cleanup_nodes()
            print(f"ipyros: forgot {', '.join(gone)}, which no longer answered" if gone else
                  "ipyros: every registered node answers; nothing to clean up")
            return
        snap = live_graph(self.ext)
        found = [n for n in snap.nodes if name_matches(n, args.pattern)]
        if not found:
            print(f"no live nodes matching {args.pattern!r}" if args.pattern else "no live nodes")
            return
        mine = list(self.ext.session.nodes.values())
        table = Table(title=f"{len(found)} live node{'s' * (len(found) != 1)} at {self.ext.graph.where}",
                      title_justify="left")
        for column, justify in (("node", "left"), ("publishes", "right"), ("subscribes", "right"),
                                ("serves", "right"), ("note", "left")):
            table.add_column(column, justify=justify, overflow="fold")  # type: ignore[arg-type]
        for node in found:
            pubs, subs, srvs = _interface(snap, node)
            note = internal(node, mine) or ("this session" if node == self.ext.session.process.name else "")
            table.add_row(node, str(len(pubs)), str(len(subs)), str(len(srvs)), note)
        self.ext.printer.show(table)

    @magic_arguments()
    @argument("name", complete=NODE, help="the live node")
    @argument("--ping", action="store_true", help="how long it takes to answer (as rosnode ping)")
    @argument("--kill", action="store_true", help="ask it to end (ROS 1, as rosnode kill)")
    @line_magic
    def node(self, line: str) -> None:
        """One live node: what it publishes, subscribes to and serves (with types), its actions, and its pid (ROS 1)."""
        args = parse_argstring(self.node, line)
        name = global_topic(args.name)
        snap = live_graph(self.ext)
        if name not in snap.nodes:
            raise UsageError(f"no live node {name}; %nodes lists them")
        backend = self._ready()
        mine = list(self.ext.session.nodes.values())
        if args.ping or args.kill:
            self._ping_or_kill(backend, name, args.kill, mine)
            return
        pid = backend.node_pid(name)
        actions = [a for a in actions_of(snap) if name in a.servers or name in a.clients]
        parts = tuple(a.name + "/" for a in actions)  # an action's topics and services: one row, its own
        pubs, subs, srvs = ([n for n in names if not n.startswith(parts)] for names in _interface(snap, name))
        why = internal(name, mine)
        title = f"node {name}" + (f" (pid {pid})" if pid else "") + (f" ({why})" if why else "")
        table = Table(title=title, title_justify="left")
        for column in ("", "name", "type", "note"):
            table.add_column(column, overflow="fold")
        for kind, names in (("publishes", pubs), ("subscribes", subs)):
            for topic in names:
                table.add_row(kind, topic, snap.topics.get(topic) or "?", internal(topic, mine))
        for service in srvs:
            table.add_row("serves", service, _type_or_none(backend, service) or "?", internal(service, mine))
        for action in actions:
            table.add_row("action server" if name in action.servers else "action client", action.name, action.type,
                          internal(action.name, mine))
        for topic, direction, peer, transport in backend.node_connections(name):  # ROS 1: as rosnode info
            table.add_row("connection", topic, f"{direction} {'from' if direction == 'in' else 'to'} {peer}",
                          transport)
        if not table.row_count:
            table.add_row("", "nothing", "", "")
        self.ext.printer.show(table)

    # -- %lifecycle ----------------------------------------------------------------------------
    @magic_arguments()
    @argument("name", complete=NODE, help="the live lifecycle (managed) node")
    @argument("transition", nargs="?", complete=TRANSITION, help="a transition to trigger: configure, activate, "
              "deactivate, cleanup, shutdown")
    @line_magic
    def lifecycle(self, line: str) -> None:
        """A managed node's state and the transitions it offers (ros2 lifecycle get); with TRANSITION, trigger it
        first (ros2 lifecycle set)."""
        args = parse_argstring(self.lifecycle, line)
        name = global_topic(args.name)
        try:
            state, offered = self._ready().lifecycle(name, args.transition)
        except IpyrosError as error:
            raise UsageError(str(error)) from None
        done = f"{args.transition} → " if args.transition else "state "
        print(f"{name}: {done}{state}; it offers {', '.join(offered) or 'nothing'}")

    def _ping_or_kill(self, backend: Any, name: str, kill: bool, mine: list[Any]) -> None:
        try:
            if not kill:
                print(f"{name}: answered in {backend.ping_node(name):.1f} ms")
                return
            ours = next((n for n in mine if n.fullname == name or n.session.process.name == name), None)
            if ours is not None:
                raise UsageError(f"{name} is this session's own; end a node of yours with {ours.called}.shutdown()")
            backend.kill_node(name)
        except IpyrosError as error:
            raise UsageError(str(error)) from None
        print(f"ipyros: asked {name} to shut down")


def _type_or_none(backend: Any, service: str) -> str:
    try:
        return backend.service_type(service)
    except Exception:  # noqa: BLE001 - a server that does not answer is no match
        return ""


def _same_type(have: str, wanted: str) -> bool:
    """``std_srvs/srv/SetBool`` (ROS 2's spelling) is ``std_srvs/SetBool``."""
    return have.replace("/srv/", "/") == wanted


def _interface(snap: GraphSnapshot, node: str) -> tuple[list[str], list[str], list[str]]:
    def of(mapping: Any) -> list[str]:
        return [name for name, nodes in mapping.items() if node in nodes]

    return of(snap.publishers), of(snap.subscribers), of(snap.services)


def _short(value: Any, most: int = 200) -> str:
    text = repr(value) if not isinstance(value, str) else value
    return text if len(text) <= most else text[:most] + f"... ({len(text)} characters)"


__all__ = ["IntrospectMagics", "internal"]
