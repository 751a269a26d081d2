"""The session's tools over the Model Context Protocol: an MCP server inside the session, on a thread of its own.

Built with the official SDK (``mcp`` 2.x): each tool is a thin call of :class:`~ipyros.mcp.desk.Desk`, answering
a short text and the same as structured data; a refusal or an error is the tool's error, in one line. Served over
Streamable HTTP on 127.0.0.1 only (the SDK refuses a Host header that is not the loopback's: DNS rebinding), each
request holding the bearer token printed once at ``%mcp start`` and kept in a file only its owner reads
(:func:`token_file`); a request without it, or with another, is refused before the MCP layer sees it. Bodies over
:data:`LARGEST_BODY` bytes are refused.

    >>> agent = AgentServer(desk).start()        # %mcp start does this
    >>> agent.url, agent.token
    ('http://127.0.0.1:43117/mcp', '...')
    >>> agent.stop()                             # %mcp stop, the extension unloaded, the session closed
"""

from __future__ import annotations

import hmac
import json
import logging
import os
import secrets
import socket
import threading
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Callable, Optional

from ..core.errors import IpyrosError
from .address import token_file
from .desk import Answer, Desk

__all__ = ["AgentServer", "Started", "LARGEST_BODY", "TOOLS", "token_file", "build_server"]

#: The largest request body the server reads (bytes): a candidate handler's source is at most 20,000 characters.
LARGEST_BODY = 256 * 1024

#: The tools, in the order an agent sees them.
TOOLS = ("graph", "interface", "echo", "nodes", "history", "bag_info", "rehearse", "propose", "revert", "publish",
         "call", "estop", "request")

_INSTRUCTIONS = (
    "You work in a person's ipyros session (ROS nodes at an IPython prompt). Read freely: graph, interface, echo, "
    "nodes, history, bag_info. Try a handler with rehearse (it runs over a bag or recent messages; nothing is sent). "
    "Every change (propose, revert, publish, call) is a request the person approves at their prompt; request N "
    "says where it stands. estop stops every guarded output at once; only the person releases it.")


@dataclass(frozen=True)
class Started:
    """What ``%mcp start`` returns: where the server listens and the token each request must hold."""

    url: str
    token: str
    allowed: str  # what the agent may do besides reading, in words
    file: str  # where url and token are kept for the stdio bridge

    def __repr__(self) -> str:  # the token is shown once, by %mcp start, not in every repr
        return f"<ipyros MCP server at {self.url}: {self.allowed}; token in {self.file}>"


def build_server(desk: Desk) -> Any:
    """The MCP server of ``desk``'s tools (not yet listening): what the SDK's in-memory client connects to."""
    root = logging.getLogger()
    before = (list(root.handlers), root.level)
    from mcp.server.mcpserver import MCPServer  # the SDK is the agent's extra: imported only when asked for

    server = MCPServer("ipyros", instructions=_INSTRUCTIONS, log_level="WARNING")
    root.handlers[:] = before[0]  # the SDK's logging setup is not the session's
    root.setLevel(before[1])
    logging.getLogger("mcp").setLevel(logging.WARNING)
    for name in TOOLS:
        server.add_tool(_tool(getattr(_Tools, name), desk), name=name, description=_describe(getattr(_Tools, name)))
    return server


class _Tools:
    """The tools' signatures and descriptions (what the SDK makes each tool's schema of); each calls the desk."""

    @staticmethod
    def graph(desk: Desk, pattern: str = "", node: Optional[str] = None, rates: bool = False,
              parameters: bool = False) -> Answer:
        """The live ROS graph: topics (type, publishers, subscribers), nodes, services, actions. pattern: a glob
        (/turtle*) or a part of the name; node: only its topics; rates: each topic's rate, measured for a second;
        parameters: the parameters and their values (the node's, if node is given)."""
        return desk.graph_now(pattern, node, rates, parameters)

    @staticmethod
    def interface(desk: Desk, type: str) -> Answer:  # noqa: A002 - the word ROS uses
        """A message, service or action type's definition (pkg/Type), nested types spelled out."""
        return desk.interface(type)

    @staticmethod
    def echo(desk: Desk, topic: str, count: int = 1, timeout: float = 5.0) -> Answer:
        """The next COUNT messages of a live topic, as data; a message path selects from each
        (/odom.pose.pose.position, /scan.ranges[0:10], /cmd_vel{linear.x>0})."""
        return desk.echo(topic, count, timeout)

    @staticmethod
    def nodes(desk: Desk) -> Answer:
        """The session's nodes: declarations, each handler's name, source and versions, guards' states and
        figures, whether you may propose its handlers."""
        return desk.nodes()

    @staticmethod
    def history(desk: Desk, node: Optional[str] = None, last: int = 50) -> Answer:
        """The session's changes, newest last (who made each), your requests with their answers, and what the session
        told the person on its own since the server started (a basenode died, a guard tripped)."""
        return desk.history(node, last)

    @staticmethod
    def bag_info(desk: Desk, path: str) -> Answer:
        """What a bag (ROS 1 .bag, rosbag2 folder, MCAP) holds: topics, types, counts, start, end."""
        return desk.bag_info(path)

    @staticmethod
    def rehearse(desk: Desk, node: str, topic: str, source: str, bag: Optional[str] = None,
                 last: Optional[int] = None) -> Answer:
        """Run a candidate handler (source: one def taking the message) beside the live one of TOPIC on NODE, over
        a bag or the node's last messages: what each writes, where they differ, what the guard would do. Nothing is
        swapped or sent. Only on a node the person allowed you to propose handlers for."""
        return desk.rehearse(node, topic, source, bag, last)

    @staticmethod
    def propose(desk: Desk, node: str, topic: str, source: str, bag: Optional[str] = None) -> Answer:
        """Ask the person to make SOURCE the handler of TOPIC on NODE (rehearsed first, over BAG if given). They
        approve it at their prompt; the request tool says when."""
        return desk.propose(node, topic, source, bag)

    @staticmethod
    def revert(desk: Desk, node: str, topic: str, version: int) -> Answer:
        """Ask the person to bring back VERSION of the handler of TOPIC on NODE (nodes lists how many there are)."""
        return desk.revert(node, topic, version)

    @staticmethod
    def publish(desk: Desk, topic: str, message: dict[str, Any] | str,
                type: Optional[str] = None) -> Answer:  # noqa: A002 - the word ROS uses
        """Ask to publish one message (a mapping of fields, or YAML) on an allowed topic; a guarded output's guard
        clamps or stops it as any command."""
        return desk.publish(topic, message, type)

    @staticmethod
    def call(desk: Desk, service: str, request: dict[str, Any] | str = "{}",
             type: Optional[str] = None) -> Answer:  # noqa: A002 - the word ROS uses
        """Ask to call an allowed service once with REQUEST (a mapping of fields, or YAML)."""
        return desk.call(service, request, type)

    @staticmethod
    def estop(desk: Desk, node: Optional[str] = None) -> Answer:
        """Stop every guarded output (of NODE, or of the session) now and hold it: no approval needed; only the
        person releases it."""
        return desk.estop(node)

    @staticmethod
    def request(desk: Desk, number: int) -> Answer:
        """Where your request NUMBER stands: pending, approved (and what it did), denied or failed."""
        return desk.request(number)


def _describe(method: Callable[..., Any]) -> str:
    return " ".join((method.__doc__ or "").split())


def _tool(method: Callable[..., Any], desk: Desk) -> Callable[..., Any]:
    """``method`` with the desk bound, its answer as MCP's result, any error as the tool's one-line error."""
    import functools
    import inspect

    from mcp.server.mcpserver.exceptions import ToolError
    from mcp_types import CallToolResult, TextContent

    @functools.wraps(method)
    def call(**arguments: Any) -> Any:
        try:
            answer = method(desk, **arguments)
        except IpyrosError as error:
            raise ToolError(str(error)) from None
        except Exception as error:  # noqa: BLE001 - one line for the agent; the session goes on
            raise ToolError(f"{type(error).__name__}: {error}") from None
        data = json.loads(json.dumps(answer.data, default=str))  # JSON as the wire carries it
        return CallToolResult(content=[TextContent(type="text", text=answer.text)], structured_content=data)

    signature = inspect.signature(method, eval_str=True)
    bound = signature.replace(parameters=list(signature.parameters.values())[1:],
                              return_annotation=inspect.Signature.empty)
    call.__signature__ = bound  # type: ignore[attr-defined]
    call.__annotations__ = {k: v.annotation for k, v in list(signature.parameters.items())[1:]}
    del call.__wrapped__  # the SDK reads the signature above, not the method's with its desk
    return call


class AgentServer:
    """The server over HTTP on a thread of its own: :meth:`start`, :meth:`stop` (waits until nothing listens)."""

    def __init__(self, desk: Desk, port: int = 0) -> None:
        self.desk, self.port = desk, port
        self.token = secrets.token_urlsafe(32)
        self.mcp = build_server(desk)
        self._uvicorn: Any = None
        self._thread: Optional[threading.Thread] = None
        self.url = ""

    def start(self, timeout: float = 10.0) -> "AgentServer":
        import uvicorn

        sock = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
        try:
            sock.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
            # answers go out at once, not after the client's delayed ACK (44 ms a call without; accepted sockets
            # inherit it): python -m bench.agent
            sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
            sock.bind(("127.0.0.1", self.port))
        except OSError as error:
            sock.close()
            raise IpyrosError(f"cannot listen on 127.0.0.1:{self.port} ({error.strerror}); give another --port, "
                              "or none (a free one is chosen)") from None
        self.port = sock.getsockname()[1]
        app = self.mcp.streamable_http_app(json_response=True, max_request_body_size=LARGEST_BODY)
        config = uvicorn.Config(_with_token(app, self.token), log_level="warning", lifespan="on",
                                timeout_graceful_shutdown=1)
        self._uvicorn = uvicorn.Server(config)
        self._thread = threading.Thread(target=self._uvicorn.run, kwargs={"sockets": [sock]},
                                        name="ipyros-mcp", daemon=True)
        self._thread.start()
        deadline = time.monotonic() + timeout
        while not self._uvicorn.started:
            if not self._thread.is_alive() or time.monotonic() > deadline:
                self._uvicorn.should_exit = True  # nothing of it is left running
                self._thread.join(timeout)
                sock.close()
                self._uvicorn = self._thread = None
                raise IpyrosError("the MCP server did not start; see the lines above")
            time.sleep(0.01)
        self.url = f"http://127.0.0.1:{self.port}/mcp"
        return self

    def write_file(self) -> Path:
        """The address and token, for ``python -m ipyros.mcp``, in a file only its owner may read."""
        path = token_file()
        path.parent.mkdir(parents=True, exist_ok=True)
        fd = os.open(path, os.O_WRONLY | os.O_CREAT | os.O_TRUNC, 0o600)
        with os.fdopen(fd, "w") as file:
            os.fchmod(file.fileno(), 0o600)
            json.dump({"url": self.url, "token": self.token, "pid": os.getpid()}, file)
        return path

    def stop(self, timeout: float = 5.0) -> None:
        if self._uvicorn is not None:
            self._uvicorn.should_exit = True
        if self._thread is not None:
            self._thread.join(timeout)
        self._uvicorn = self._thread = None
        path = token_file()
        try:
            if json.loads(path.read_text()).get("token") == self.token:  # ours, not a later session's
                path.unlink()
        except (OSError, ValueError):
            pass

    @property
    def running(self) -> bool:
        return self._thread is not None and self._thread.is_alive()


def _with_token(app: Any, token: str) -> Any:
    """``app`` behind a bearer token: an HTTP request without ``Authorization: Bearer <token>`` is refused (401)."""
    expected = f"Bearer {token}".encode()

    async def guarded(scope: dict, receive: Any, send: Any) -> None:
        if scope["type"] == "http":
            given = next((v for k, v in scope.get("headers", ()) if k == b"authorization"), b"")
            if not hmac.compare_digest(given, expected):
                body = b'{"error": "no or wrong bearer token: give the one %mcp start printed (or its file)"}'
                await send({"type": "http.response.start", "status": 401,
                            "headers": [(b"content-type", b"application/json"), (b"www-authenticate", b"Bearer")]})
                await send({"type": "http.response.body", "body": body})
                return
        await app(scope, receive, send)

    return guarded
