"""Keeping a node's work by the kind of file: what ``nd.save``, ``rosNode.load`` and ``nd.export`` do.

``.py``: runnable DSL code (:mod:`.savefile`); ``.yaml``/``.json``: the node model with its
handlers' sources (:mod:`.modelfile`); an export: a script or package that needs no ipyros
(:mod:`.export`). The DSL's methods come here (the node layer reaches up once, for these).
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any, Optional

from ..core.errors import DeclarationError
from . import export as exporting, modelfile, savefile

__all__ = ["export", "load", "save"]


def save(node: Any, path: "str | os.PathLike[str]", namespace: Optional[dict] = None) -> Path:
    """Save ``node`` to ``path``; the suffix says how (see :meth:`ipyros.node.dsl.rosNode.save`)."""
    suffix = str(path).rsplit(".", 1)[-1].lower() if "." in str(path) else ""
    if suffix == "py":
        return savefile.save_nodes([node], path, namespace)
    if suffix in modelfile.MODEL_SUFFIXES:
        return modelfile.save(node, path)
    raise DeclarationError(f"{path}: say what to save by the suffix: .py (runnable code) "
                           "or .yaml / .json (the node model)")


def load(path: Any, namespace: Optional[dict] = None, *, create: bool = False, session: Any = None,
         trust: bool = False) -> Any:
    """Bring back a node saved by :func:`save` (see :meth:`ipyros.node.dsl.rosNode.load`)."""
    if str(path).endswith(".py"):
        nodes = savefile.restore(path, namespace)
        if len(nodes) != 1:
            raise DeclarationError(f"{path} holds {len(nodes)} nodes ({', '.join(n.name for n in nodes)}); "
                                   "ipyros.restore(path) brings them all back")
        node = nodes[0]
    else:
        node = modelfile.load(path, namespace, session=session, trust=trust)
    return node.create() if create else node


def export(node: Any, path: "str | os.PathLike[str]", namespace: Optional[dict] = None) -> Path:
    """Export ``node`` to run without ipyros (see :func:`ipyros.files.export.export`)."""
    return exporting.export(node, path, namespace)
