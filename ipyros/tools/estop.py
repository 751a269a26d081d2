"""The session's e-stop over several nodes: each node asked, whatever another one did.

One node's guards are e-stopped together by :meth:`NodeGuards.estop <ipyros.node.guards.NodeGuards.estop>` (every
guard asked, then the first failure raised); here the same holds across nodes, for ``%estop`` and an agent's
``estop``: a node whose guard cannot be reached (a keeper gone) never keeps the next node's outputs running.
"""

from __future__ import annotations

from typing import Sequence

from ..core.errors import IpyrosError
from ..dsl import rosNode

__all__ = ["estop_each"]


def estop_each(nodes: Sequence[rosNode], on: bool = True) -> list[tuple[rosNode, list[str]]]:
    """E-stop (``on``) or release every node's guards; each node with the topics it held. If any failed, every node
    was asked first, and then one error says which failed and which were held all the same."""
    done: list[tuple[rosNode, list[str]]] = []
    failed: list[str] = []
    for node in nodes:
        try:
            done.append((node, node.estop() if on else node.release()))
        except Exception as error:  # noqa: BLE001 - said below, once every node was asked
            failed.append(f"{node.name}: {error}")
    if failed:
        held = ", ".join(f"{topic} ({node.name})" for node, topics in done for topic in topics) or "nothing"
        verb = "e-stopped" if on else "released"
        raise IpyrosError(f"could not be {verb}: {'; '.join(failed)}; {verb} all the same: {held}")
    return done
