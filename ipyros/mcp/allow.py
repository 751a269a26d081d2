"""What an agent may do beyond reading, name by name, and every spelling of a name as the one name it is.

An agent's server reads freely (the graph, types, messages, the session's nodes) and changes nothing on its own.
A person allows more at ``%mcp start``: topics it may publish on once, services it may call, nodes whose handlers
it may propose. Each name is held in one spelling, the global one, and every name an agent gives is brought to it
before any check, so that ``cmd_vel``, ``/cmd_vel/``, ``//cmd_vel`` and ``/./cmd_vel`` cannot differ from
``/cmd_vel`` (the allow-lists of other ROS agent servers were passed by a name without its slash). A name that is
not a legal ROS name is refused, never guessed at.

Pure: no ROS, no MCP; what the session relays is given as data (:class:`Reach`).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Iterable, Mapping

from ..core import names
from ..core.errors import IpyrosError

__all__ = ["Allowed", "AgentRefused", "Reach", "normal"]


class AgentRefused(IpyrosError, PermissionError):
    """What an agent asked is not allowed: the one line says which name, and what the person would allow."""


def normal(name: object, kind: str = "topic", namespace: str = "/") -> str:
    """``name`` as the one global name it means: relative names in ``namespace``, repeated and trailing ``/`` gone.

    ``~`` (a node's private name) means nothing for an agent outside any node: refused, as is anything that is not
    a legal ROS name.
    """
    if not isinstance(name, str):
        raise AgentRefused(f"a {kind} name is a string, not {type(name).__name__}: give one like '/cmd_vel'")
    text = name.strip()
    if text.startswith("~"):
        raise AgentRefused(f"{kind} {text!r:.80}: a private name (~) belongs to a node; give the global name")
    parts = [part for part in text.split("/") if part not in ("", ".")]
    if not parts:
        raise AgentRefused(f"{kind} name {name!r:.80} names nothing; give one like '/cmd_vel'")
    joined = "/".join(parts)
    return names.resolve(joined if not text.startswith("/") else "/" + joined, namespace, "agent", kind)


@dataclass(frozen=True)
class Reach:
    """What the session's nodes do with names, read from their plans: where a name leads past the session.

    ``relays``: a relayed service or action (its global name) → the basenode that serves it (a call goes to the
    basenode, past the wrapping node and its guard). ``wrapped``: a basenode's full name → the guarded outputs of its
    wrapping node.
    """

    relays: Mapping[str, str] = field(default_factory=dict)
    wrapped: Mapping[str, tuple[str, ...]] = field(default_factory=dict)


@dataclass(frozen=True)
class Allowed:
    """The names a person allowed (global, :func:`normal`), and whether each allowed act still asks them first."""

    publish: frozenset[str] = frozenset()
    call: frozenset[str] = frozenset()
    swap: frozenset[str] = frozenset()  # full node names
    ask: bool = True
    namespace: str = "/"  # where a relative name the agent gives resolves (the session's ROS_NAMESPACE)

    @classmethod
    def of(cls, publish: Iterable[str] = (), call: Iterable[str] = (), swap: Iterable[str] = (), ask: bool = True,
           namespace: str = "/") -> "Allowed":
        """The lists as a person typed them, each name made :func:`normal` (a bad one refused in one line)."""
        return cls(frozenset(normal(n, "topic", namespace) for n in publish),
                   frozenset(normal(n, "service", namespace) for n in call),
                   frozenset(normal(n, "node", namespace) for n in swap), ask, namespace)

    def to_publish(self, topic: object) -> str:
        """The global topic, if the agent may publish on it; else the refusal, in one line."""
        name = normal(topic, "topic", self.namespace)
        if name not in self.publish:
            raise AgentRefused(f"the agent may not publish on {name}: allowed {_listed(self.publish)}; the person "
                               f"allows it with %mcp start --allow-publish {name}")
        return name

    def to_call(self, service: object, reach: Reach) -> str:
        """The global service, if the agent may call it and it does not lead past a guard; else the refusal."""
        name = normal(service, "service", self.namespace)
        if name not in self.call:
            raise AgentRefused(f"the agent may not call {name}: allowed {_listed(self.call)}; the person allows it "
                               f"with %mcp start --allow-call {name}")
        base = reach.relays.get(name)
        outputs = reach.wrapped.get(base, ()) if base is not None else ()
        if outputs:
            raise AgentRefused(f"{name} is relayed to the basenode {base}, whose outputs {', '.join(outputs)} are "
                               "guarded: a call would reach the robot past the guard, so the agent may not make it")
        return name

    def to_swap(self, node: str) -> str:
        """``node`` (a full name), if the agent may propose its handlers; else the refusal."""
        if node not in self.swap:
            raise AgentRefused(f"the agent may not change {node}'s handlers: allowed {_listed(self.swap)}; the "
                               f"person allows it with %mcp start --allow-swap {node}")
        return node

    def describe(self) -> str:
        """One line: what the agent may do besides reading."""
        parts = [f"{what} {', '.join(sorted(names_))}" for what, names_ in
                 (("publish on", self.publish), ("call", self.call), ("propose handlers of", self.swap)) if names_]
        allowed = "; ".join(parts) if parts else "read only"
        return f"{allowed}{'' if self.ask or not parts else ' (without asking)'}"


def _listed(allowed: frozenset[str]) -> str:
    return ", ".join(sorted(allowed)) if allowed else "none"
