"""``%mcp``: an AI coding agent in the session, behind the guard and the person's approval.

    %mcp start [--port N] [--allow-publish TOPIC ...] [--allow-call SERVICE ...] [--allow-swap NODE ...] [--no-ask]
    %mcp status          where it listens, what it allows, the requests pending
    %mcp approve N       make the change the agent asked for in request N (here, now)
    %mcp deny N          refuse it
    %mcp stop            stop the server (pending requests are denied)

The server speaks the Model Context Protocol over HTTP on 127.0.0.1 (Claude Code, Cursor, VS Code connect to it;
``python -m ipyros.mcp`` bridges clients that start a command). It reads freely and changes nothing on its own:
see :mod:`ipyros.mcp.desk` and the guide's "An AI agent in the session".
"""

from __future__ import annotations

import importlib.util
from typing import Any, Optional

from IPython.core.error import UsageError
from IPython.core.magic import line_magic, magics_class
from IPython.core.magic_arguments import magic_arguments, parse_argstring

from ...core.errors import IpyrosError
from ...core.names import default_namespace
from ..arguments import DSL_NODE, SERVICE, TOPIC, argument
from .cell_output import in_kernel
from .common import ExtensionMagics


@magics_class
class AgentMagics(ExtensionMagics):
    """The agent's server: started, asked, answered, stopped."""

    def __init__(self, shell: Any, ext: Any) -> None:
        super().__init__(shell, ext)
        self.server: Optional[Any] = None  # ipyros.mcp.server.AgentServer, while one runs
        self.desk: Optional[Any] = None
        self._unlisten: Optional[Any] = None

    @magic_arguments()
    @argument("action", choices=("start", "stop", "status", "approve", "deny"),
              help="start the server, stop it, show it, or answer an agent's request")
    @argument("number", nargs="?", type=int, help="approve / deny: the request's number")
    @argument("--port", type=int, default=0, help="start: the port on 127.0.0.1 (default: a free one)")
    @argument("--allow-publish", nargs="+", default=[], metavar="TOPIC", complete=TOPIC,
              help="start: topics the agent may ask to publish one message on")
    @argument("--allow-call", nargs="+", default=[], metavar="SERVICE", complete=SERVICE,
              help="start: services the agent may ask to call")
    @argument("--allow-swap", nargs="+", default=[], metavar="NODE", complete=DSL_NODE,
              help="start: the session's nodes whose handlers the agent may rehearse, propose and revert")
    @argument("--no-ask", action="store_true", help="start: an allowed publish or call is made without asking "
              "(a handler is always asked for)")
    @line_magic
    def mcp(self, line: str) -> Any:
        """An MCP server for an AI agent: it reads the graph, types, messages, the session's nodes and their
        history; rehearses candidate handlers over bags; asks you (here, one notice each) before any handler is
        swapped and any allowed message is published or service called. %mcp start returns its url and token."""
        args = parse_argstring(self.mcp, line)
        if args.action != "start" and (args.allow_publish or args.allow_call or args.allow_swap or args.no_ask
                                        or args.port):
            raise UsageError("--port, --allow-* and --no-ask are for %mcp start")
        if args.action in ("approve", "deny") and args.number is None:
            raise UsageError(f"give the request's number: %mcp {args.action} N (%mcp status lists them)")
        return getattr(self, f"_{args.action}")(args)

    # -- the actions ----------------------------------------------------------------------------------------
    def _start(self, args: Any) -> Any:
        if self.server is not None and self.server.running:
            raise UsageError(f"the agent's server already runs at {self.server.url}; %mcp stop first")
        if importlib.util.find_spec("mcp") is None:  # the SDK is an extra
            raise UsageError("the MCP SDK is not installed: pip install 'mcp>=2' (or pip install 'ipyros[agent]')")
        from ...mcp.allow import Allowed
        from ...mcp.approvals import Requests
        from ...mcp.desk import Desk
        from ...mcp.server import AgentServer, Started

        session = self.ext.session
        swap = [self._node_name(name) for name in args.allow_swap]
        allowed = Allowed.of(args.allow_publish, args.allow_call, swap, ask=not args.no_ask,
                             namespace=default_namespace())
        requests = Requests(session.notify)
        desk = Desk(session, self.ext.graph, self.ext.publisher, self.shell.user_ns, allowed, requests)
        server = AgentServer(desk, args.port).start()
        try:
            path = server.write_file()
        except OSError as error:
            server.stop()
            raise IpyrosError(f"cannot write the token file ({error.strerror}); set IPYROS_MCP_FILE to a "
                              "writable path") from None
        self.server, self.desk = server, desk
        self._unlisten = session.listen(desk.heard)  # the agent reads what the session tells the person
        session.on_close(self.stop)
        where = (f"ipyros: the agent's MCP server listens at {server.url} ({allowed.describe()}); its token is kept "
                 f"in {path}")
        if in_kernel(self.shell):  # a notebook keeps its outputs in its file: the token stays out of it
            print(f"{where} (yours alone); give it to the client from there (s = %mcp start: s.token)")
        else:
            header = f"Authorization: Bearer {server.token}"
            print(f"{where} (yours alone) and shown here once. Claude Code:\n"
                  f"claude mcp add --transport http ipyros {server.url} --header \"{header}\"")
        return Started(server.url, server.token, allowed.describe(), str(path))

    def _stop(self, args: Any) -> None:
        if self.server is None:
            print("ipyros: no agent's server runs")
            return
        url = self.server.url
        denied = self.stop()
        print(f"ipyros: the agent's server at {url} stopped"
              + (f"; {denied} pending requests denied" if denied else ""))

    def _status(self, args: Any) -> None:
        if self.server is None or self.desk is None:
            print("ipyros: no agent's server runs; %mcp start starts one")
            return
        pending = self.desk.requests.pending()
        lines = [f"ipyros: the agent's server listens at {self.server.url} ({self.desk.allowed.describe()})"]
        lines += [f"  #{r.number} {r.kind}: {r.what}" for r in pending] or ["  no request pending"]
        print("\n".join(lines))

    def _approve(self, args: Any) -> Any:
        request = self._requests().approve(args.number)
        if request.state == "failed":
            raise IpyrosError(f"request #{request.number} failed: {request.answer}")
        print(f"ipyros: approved #{request.number}: {request.answer}")

    def _deny(self, args: Any) -> None:
        request = self._requests().deny(args.number)
        print(f"ipyros: denied #{request.number}: {request.what}")

    # -- helpers --------------------------------------------------------------------------------------------
    def stop(self) -> int:
        """Stop the server, if one runs; how many pending requests were denied."""
        server, desk, self.server, self.desk = self.server, self.desk, None, None
        if self._unlisten is not None:
            self._unlisten()
            self._unlisten = None
        denied = desk.requests.deny_all("the server stopped") if desk is not None else 0
        if server is not None:
            server.stop()
        return denied

    def _requests(self) -> Any:
        if self.desk is None:
            raise UsageError("no agent's server runs, so no request waits; %mcp start starts one")
        return self.desk.requests

    def _node_name(self, name: str) -> str:
        """A node the person names at --allow-swap (a variable, or a node's name) as its full name."""
        from ..api import find_node

        try:
            return find_node(self.shell, name).fullname
        except UsageError:
            raise UsageError(f"--allow-swap {name}: no rosNode of the session by that variable or name") from None
