"""Wrapping: the DSL side of a node that wraps a basenode (paper section III).

The topology is decided in :mod:`ipyros.plan`; this module checks the declarations
that only make sense together, and starts the basenode process with its remaps.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

from .errors import DeclarationError
from .model import BaseModel, NodeModel

if TYPE_CHECKING:
    from .dsl import rosNode

_BASE_OPTIONS = {"name": "node_name", "namespace": "namespace", "remaps": "remaps", "params": "params", "args": "args"}


def set_base(node: "rosNode", **fields: Any) -> "rosNode":
    """Record basenode fields (``executable``, ``package`` and the options) in the model."""
    unknown = set(fields) - {"executable", "package", *_BASE_OPTIONS}
    if unknown:
        raise DeclarationError(f"baseNode() got unknown option(s) {', '.join(sorted(unknown))}; "
                               f"known: {', '.join(_BASE_OPTIONS)}")
    if node.created:
        raise DeclarationError(f"{node.name} is already running; declare its basenode before create()")
    for key in ("executable", "package"):
        if key in fields and (not isinstance(fields[key], str) or not fields[key].strip()):
            raise DeclarationError(f"base{key.capitalize() if key == 'package' else 'Node'}() needs a non-empty name")

    def edit(model: NodeModel) -> None:
        base = model.base or BaseModel()
        for key, value in fields.items():
            setattr(base, _BASE_OPTIONS.get(key, key), value)
        model.base = base

    node._change(edit)
    return node


def check_wrapping(model: NodeModel) -> None:
    """Refuse to create a node whose wrapping declarations are incomplete."""
    reuses = [t.name for t in model.topics if t.role == "reuse"] + [s.name for s in model.services if s.role == "reuse"]
    if model.base is None:
        if reuses:
            raise DeclarationError(f"{model.name} reuses {', '.join(reuses)} but has no basenode; declare it: "
                                   f"{model.name}.baseNode('executable').basePackage('package')")
        return
    if not model.base.executable or not model.base.package:
        missing = "baseNode('executable')" if not model.base.executable else "basePackage('package')"
        raise DeclarationError(f"{model.name}'s basenode is incomplete; add .{missing}")


def start_base(node: "rosNode") -> None:
    """Launch the basenode of a wrapping node, remapped onto the wrapping node's internal names."""
    if node._model.base is None:
        return
    raise DeclarationError("wrapping a basenode is not available yet")
