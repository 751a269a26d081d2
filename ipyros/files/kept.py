"""What the files layer needs of a node: its structure, its handlers and their past, and whether it runs.

The node layer's :class:`~ipyros.node.engine.NodeEngine` is such a node; the files layer
names this protocol instead of importing it, so that it stays below the node layer: the
formats here know plain data and functions, never a session.
"""

from __future__ import annotations

from typing import Any, Callable, Optional, Protocol

from ..core.model import NodeModel
from ..core.versions import HandlerVersion

__all__ = ["KeptNode"]


class KeptNode(Protocol):
    """A node as saving, loading and exporting see it."""

    @property
    def name(self) -> str: ...
    @property
    def fullname(self) -> str: ...
    #: The user's object for this node (a ``rosNode``): what their variables hold (compared, never called).
    owner: object
    created: bool

    def model(self) -> NodeModel: ...
    def handlers(self) -> dict[str, Callable[..., Any]]: ...
    def param_handlers(self) -> dict[str, Callable[..., Any]]: ...
    def slot_versions(self, slot: str) -> tuple[list[HandlerVersion], Optional[int]]: ...
