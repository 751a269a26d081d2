"""Wrapping a node in one call: ``%wrap PACKAGE EXECUTABLE``, and :func:`wrap` for scripts."""

from __future__ import annotations

from typing import Any, Optional

from ..core.model import BaseModel
from ..core.remapping import base_node_name
from ..dsl import rosNode

__all__ = ["wrap"]


def wrap(package: str, executable: str, name: Optional[str] = None, *, node_name: Optional[str] = None,
         namespace: Optional[str] = None, remaps: Optional[dict] = None, params: Optional[dict] = None,
         args: Optional[list] = None, machine: Optional[str] = None, session: Any = None) -> rosNode:
    """Wrap ``package``/``executable`` in one call: discover its interface, reuse it all, create.

    The wrapping node is named ``name`` (default ``<executable>_wrapper``); ``machine`` places the basenode (and
    its relays) on that machine's keeper.
    """
    options = {k: v for k, v in dict(name=node_name, namespace=namespace, remaps=remaps, params=params,
                                     args=args).items() if v}
    node = rosNode(name or f"{base_node_name(BaseModel(executable=executable))}_wrapper", namespace=namespace,
                   session=session)
    node.baseNode(executable, **options).basePackage(package)
    if machine is not None:
        node.machine(machine)
    node.discover()
    node.create()
    return node
