"""The DSL: what the user types (paper section III): ``rosNode``, ``new``/``reuse``, ``subscribe``,
``publish``, ``service``, ``timer``, ``create``, ``write``, the basenode, and keeping the work.

May import: core, files, node (never tools or ipython). A rosNode holds the DSL only; ipyros's
own modules reach the node through :func:`engine_of` (its :class:`~ipyros.node.engine.NodeEngine`).
"""

from .declarations import NodeParams, TopicHandler, end_chains
from .keeping import RestoreError, restoring, save_session, spin
from .messages import build_messages
from .rosnode import engine_of, node_of, restore, rosNode, shutdown

__all__ = ["NodeParams", "RestoreError", "TopicHandler", "build_messages", "end_chains", "engine_of", "node_of",
           "restore", "restoring", "rosNode", "save_session", "shutdown", "spin"]
