"""What ``rosservice``, ``rosparam`` and ``rosnode`` ask of ROS 1, for ``%services``, ``%call``, ``%params``
and ``%node``: a service's type, a call, the parameter server, a node's pid.

A service's type is not on the master: ``rosservice type`` asks the service itself, with a
TCPROS *probe* header (the server answers with its header, type included, and closes).
That is what :func:`service_type` does, with a timeout, so a hung server cannot hang the
prompt.
"""

from __future__ import annotations

import io
import socket
import struct
import time
import xmlrpc.client
from typing import Any, Optional
from urllib.parse import urlparse

from ..core.errors import IpyrosError
from .master import master_proxy

__all__ = ["call", "cleanup_nodes", "kill_node", "node_connections", "node_pid", "params_under", "ping_node",
           "probe_type", "service_type", "service_uri", "topic_endpoints"]

CALLER_ID = "/ipyros_introspect"


def service_type(master_uri: str, name: str, timeout: float = 2.0) -> str:
    """The type (``pkg/Service``) of the live service ``name``, asked of its server."""
    return probe_type(service_uri(master_uri, name, timeout), name, timeout)


def service_uri(master_uri: str, name: str, timeout: float = 2.0) -> str:
    """Where the live service ``name`` is served (``rosrpc://host:port``), as the master says."""
    code, message, uri = master_proxy(master_uri, timeout).lookupService(CALLER_ID, name)
    if code != 1:
        raise IpyrosError(f"no live service {name} ({message}); %services lists them")
    return uri


def probe_type(uri: str, name: str, timeout: float = 2.0) -> str:
    """The type the server of ``name`` at ``uri`` says in answer to a probe."""
    where = urlparse(uri)  # rosrpc://host:port
    fields = {"probe": "1", "md5sum": "*", "callerid": CALLER_ID, "service": name}
    try:
        with socket.create_connection((where.hostname, where.port), timeout=timeout) as sock:
            sock.sendall(_header(fields))
            header = _read_header(sock)
    except OSError as error:
        raise IpyrosError(f"the server of {name} at {uri} does not answer ({error}); is its node alive?") from None
    if "type" not in header:
        raise IpyrosError(f"the server of {name} did not say its type ({header.get('error', 'no error given')})")
    return header["type"]


def _header(fields: dict[str, str]) -> bytes:
    body = b"".join(struct.pack("<I", len(item)) + item for item in (f"{k}={v}".encode() for k, v in fields.items()))
    return struct.pack("<I", len(body)) + body


def _read_header(sock: socket.socket) -> dict[str, str]:
    (size,) = struct.unpack("<I", _read(sock, 4))
    body, fields, at = _read(sock, size), {}, 0
    while at < size:
        (length,) = struct.unpack("<I", body[at:at + 4])
        key, _, value = body[at + 4:at + 4 + length].decode(errors="replace").partition("=")
        fields[key] = value
        at += 4 + length
    return fields


def _read(sock: socket.socket, count: int) -> bytes:
    data = b""
    while len(data) < count:
        chunk = sock.recv(count - len(data))
        if not chunk:
            raise OSError("the connection closed")
        data += chunk
    return data


def call(master_uri: str, name: str, cls: type, request: Any, timeout: float) -> Any:
    """Call the service ``name`` with ``request``; its response, or a one-line error within ``timeout`` s.

    rospy's ServiceProxy has no timeout once connected (a server that takes 8 s holds the
    prompt for 8 s whatever was asked), so the call is made here, over TCPROS on a socket
    whose every read and write has the time that is left.
    """
    deadline = time.monotonic() + timeout
    code, message, uri = master_proxy(master_uri, min(timeout, 2.0)).lookupService(CALLER_ID, name)
    if code != 1:
        raise IpyrosError(f"no live service {name} ({message}); %services lists them")
    where = urlparse(uri)
    buffer = io.BytesIO()
    request.serialize(buffer)
    body = buffer.getvalue()
    fields = {"callerid": CALLER_ID, "service": name, "md5sum": cls._md5sum, "persistent": "0"}  # type: ignore[attr-defined]
    try:
        with socket.create_connection((where.hostname, where.port), timeout=_left(deadline, name, timeout)) as sock:
            sock.sendall(_header(fields))
            sock.settimeout(_left(deadline, name, timeout))
            header = _read_header(sock)
            if "error" in header:
                raise IpyrosError(f"the server of {name} refused the call: {header['error']}")
            sock.sendall(struct.pack("<I", len(body)) + body)
            sock.settimeout(_left(deadline, name, timeout))
            ok = _read(sock, 1)
            (size,) = struct.unpack("<I", _read(sock, 4))
            payload = _read(sock, size)
    except socket.timeout:
        raise IpyrosError(f"{name} did not answer within {timeout:g} s (-t SECONDS waits longer)") from None
    except OSError as error:
        raise IpyrosError(f"the server of {name} at {uri} does not answer ({error}); is its node alive?") from None
    if ok != b"\x01":
        raise IpyrosError(f"{name} failed: {payload.decode(errors='replace') or 'the server gave no reason'}")
    response = cls._response_class()  # type: ignore[attr-defined]
    response.deserialize(payload)
    return response


def _left(deadline: float, name: str, timeout: float) -> float:
    left = deadline - time.monotonic()
    if left <= 0:
        raise socket.timeout()
    return left


def params_under(master_uri: str, namespace: str, timeout: float = 2.0) -> dict[str, Any]:
    """The parameter server's values under ``namespace`` (``/`` for all), by global name, sorted."""
    master = master_proxy(master_uri, timeout)
    code, message, names = master.getParamNames(CALLER_ID)
    if code != 1:
        raise IpyrosError(f"the master would not list its parameters: {message}")
    prefix = namespace.rstrip("/") + "/"
    wanted = sorted(n for n in names if n.startswith(prefix) or n == namespace.rstrip("/"))
    values = {}
    for name in wanted:
        code, _, value = master.getParam(CALLER_ID, name)
        if code == 1:  # else deleted meanwhile
            values[name] = value
    return values


def forget_params(master_uri: str, names: list[str], timeout: float = 2.0) -> None:
    """Delete the parameters ``names`` from the master (those not there are no matter)."""
    proxy = master_proxy(master_uri, timeout)
    for name in names:
        try:
            proxy.deleteParam("/ipyros", name)
        except (OSError, xmlrpc.client.Error):
            return  # the master is gone: so are its parameters


def node_pid(master_uri: str, node: str, timeout: float = 2.0) -> Optional[int]:
    """The process id of the live node ``node`` (None if it does not answer)."""
    try:
        code, _, uri = master_proxy(master_uri, timeout).lookupNode(CALLER_ID, node)
        if code != 1:
            return None
        code, _, pid = master_proxy(uri, timeout).getPid(CALLER_ID)
        return int(pid) if code == 1 else None
    except (OSError, ValueError):
        return None


def topic_endpoints(master_uri: str, topic: str, timeout: float = 2.0) -> list[tuple[str, str, str, str]]:
    """Who publishes and subscribes to ``topic``, each with the type it uses there (asked of the node itself,
    as the master keeps one type per topic): ``(node, "publisher" | "subscriber", type, "TCP")``."""
    master = master_proxy(master_uri, timeout)
    _, _, (publishers, subscribers, _) = master.getSystemState(CALLER_ID)
    found = []
    for kind, listed, ask in (("publisher", publishers, "getPublications"), ("subscriber", subscribers,
                                                                              "getSubscriptions")):
        for node in dict(listed).get(topic, ()):
            type_name = "?"
            try:
                code, _, uri = master.lookupNode(CALLER_ID, node)
                if code == 1:
                    _, _, topics = getattr(master_proxy(uri, timeout), ask)(CALLER_ID)
                    type_name = next((t for name, t in topics if name == topic), "?")
            except (OSError, ValueError):
                type_name = "? (does not answer)"
            found.append((node, kind, type_name, "TCP"))
    return sorted(found)


def _node_api(master_uri: str, node: str, timeout: float) -> Any:
    """The XML-RPC API of the live node ``node``, as the master lists it."""
    code, _, uri = master_proxy(master_uri, timeout).lookupNode(CALLER_ID, node)
    if code != 1:
        raise IpyrosError(f"the master knows no node {node}; %nodes lists them")
    return master_proxy(uri, timeout)


def ping_node(master_uri: str, node: str, timeout: float = 2.0) -> float:
    """How long ``node`` takes to answer over XML-RPC, in ms (as ``rosnode ping``); a one-line error if it does
    not answer within ``timeout``."""
    api = _node_api(master_uri, node, timeout)
    started = time.perf_counter()
    try:
        api.getPid(CALLER_ID)
    except (OSError, xmlrpc.client.Error) as error:
        raise IpyrosError(f"{node} does not answer ({error}); if it is gone, %nodes --cleanup forgets it") from None
    return (time.perf_counter() - started) * 1e3


def kill_node(master_uri: str, node: str, timeout: float = 2.0) -> None:
    """Ask ``node`` to shut down (as ``rosnode kill``); return once it no longer answers."""
    api = _node_api(master_uri, node, timeout)
    try:
        api.getPid(CALLER_ID)
    except (OSError, xmlrpc.client.Error) as error:
        raise IpyrosError(f"{node} does not answer ({error}); if it is gone, %nodes --cleanup forgets it") from None
    try:
        code, message, _ = api.shutdown(CALLER_ID, "%node --kill from ipyros")
        if code != 1:
            raise IpyrosError(f"{node} refused to shut down: {message}")
    except (OSError, xmlrpc.client.Error):
        pass  # rospy closes its server as it ends, before the answer goes out
    deadline = time.monotonic() + 5.0
    while time.monotonic() < deadline:
        try:
            api.getPid(CALLER_ID)
        except (OSError, xmlrpc.client.Error):
            return  # ended
        time.sleep(0.05)
    raise IpyrosError(f"{node} was asked to shut down and still answers after 5 s")


def cleanup_nodes(master_uri: str, timeout: float = 1.0) -> list[str]:
    """Forget the registrations of nodes that no longer answer (as ``rosnode cleanup``); their names."""
    master = master_proxy(master_uri, timeout)
    _, _, (publishers, subscribers, services) = master.getSystemState(CALLER_ID)
    nodes = {n for part in (publishers, subscribers, services) for _, listed in part for n in listed}
    gone = []
    for node in sorted(nodes):
        code, _, uri = master.lookupNode(CALLER_ID, node)
        if code != 1:
            continue
        try:
            master_proxy(uri, timeout).getPid(CALLER_ID)
            continue
        except (OSError, xmlrpc.client.Error):
            gone.append(node)
        for topic, listed in publishers:
            if node in listed:
                master.unregisterPublisher(node, topic, uri)
        for topic, listed in subscribers:
            if node in listed:
                master.unregisterSubscriber(node, topic, uri)
        for service, listed in services:
            if node in listed:
                code, _, service_uri = master.lookupService(CALLER_ID, service)
                if code == 1:
                    master.unregisterService(node, service, service_uri)
    return gone


def node_connections(master_uri: str, node: str, timeout: float = 2.0) -> list[tuple[str, str, str, str]]:
    """The live connections of ``node`` (as ``rosnode info`` lists them): ``(topic, "in" | "out", peer node,
    transport)``; a peer the master cannot name is shown by its address."""
    master = master_proxy(master_uri, timeout)
    try:
        _, _, bus = _node_api(master_uri, node, timeout).getBusInfo(CALLER_ID)
        _, _, state = master.getSystemState(CALLER_ID)
    except (OSError, xmlrpc.client.Error) as error:
        raise IpyrosError(f"{node} does not answer ({error})") from None
    names = {}  # a node's URI → its name: inbound connections name their publisher by URI
    for peer in {n for part in state for _, listed in part for n in listed}:
        code, _, uri = master.lookupNode(CALLER_ID, peer)
        if code == 1:
            names[uri] = peer
    found = []
    for entry in bus:
        _, destination, direction, transport, topic, connected = entry[:6]
        if connected:
            found.append((topic, {"i": "in", "o": "out"}.get(direction, "both"), names.get(destination, destination),
                          transport))
    return sorted(found)
