"""How a wrapping node remaps its basenode: pure rules on the model (paper section III, figure 1).

A basenode runs in its own namespace, under its own name, with its own remaps; the
wrapping node sits on the names it would use and hands it internal ones instead
(:func:`~ipyros.core.plan.internal_name`). Here: the basenode's name and namespace, how a
``reuse`` name resolves (as the basenode resolves it, through its own remaps), the
remaps the basenode is started with, and the checks of declarations that only make
sense together.

**One remap per name.** ROS applies at most one remap to a name: no chains. If the
basenode's own remaps (its launch file's ``<remap>``, or ``baseNode(remaps=...)``) send
``cmd_vel`` to ``/robot1/base/cmd_vel`` and that is the topic wrapped, the basenode
must be given ``cmd_vel:=<internal name>`` itself; :func:`basenode_remaps` composes
the two so.
"""

from __future__ import annotations

import re
from typing import Sequence

from . import names
from .errors import DeclarationError
from .model import ActionModel, BaseModel, NodeModel, ServiceModel, TopicModel
from .plan import internal_name, node_fullname

__all__ = ["base_fullname", "base_namespace", "base_node_name", "basenode_remaps", "check_reuse", "check_wrapping",
           "own_remaps", "reresolve", "resolve_for"]


def base_node_name(base: BaseModel) -> str:
    """The basenode's ROS name: the one given, else the one its code gives it (as when it runs by hand), else its
    executable's (``move_base``)."""
    if base.node_name:
        return base.node_name.strip("/")
    if base.own_name:
        return base.own_name
    stem = re.sub(r"\W", "_", (base.executable or "base").rsplit("/", 1)[-1].split(".")[0])
    return stem if stem[:1].isalpha() else "n" + stem


def base_namespace(model: NodeModel) -> str:
    base = model.base
    return names.global_ns(base.namespace) if base and base.namespace else model.namespace


def base_fullname(model: NodeModel) -> str:
    assert model.base is not None
    return names.join(base_namespace(model), base_node_name(model.base))


def resolve_for(model: NodeModel, role: str, name: str, kind: str, rules: names.NameRules = names.ROS1) -> str:
    """``reuse`` names are the basenode's: resolve them as it does; ``new`` ones are the node's own (both as
    ``rules``' ROS allows them).

    A ``new`` declaration spelled like a ``reuse`` one (``~reset`` both times) means the
    basenode's name: that is how a reused topic or service is intercepted.
    """
    if role == "new" and model.base is not None:
        lists: dict[str, Sequence[TopicModel | ServiceModel | ActionModel]] = {
            "topic": model.topics, "service": model.services, "action": model.actions}
        declared = lists[kind]
        if any(d.role == "reuse" and d.name == name for d in declared):
            role = "reuse"
    if role == "reuse" and model.base is not None:
        resolved = names.resolve(name, base_namespace(model), base_node_name(model.base), kind, rules)
        return own_remaps(model).get(resolved, resolved)  # the basenode's remaps apply: it talks there
    return names.resolve(name, model.namespace, model.name, kind, rules)


def own_remaps(model: NodeModel) -> dict[str, str]:
    """The basenode's own remaps (launch file or ``baseNode(remaps=...)``), both sides resolved as it resolves them."""
    if model.base is None:
        return {}
    ns, node = base_namespace(model), base_node_name(model.base)
    return {names.resolve(src, ns, node, "remapped"): names.resolve(dst, ns, node, "remapped")
            for src, dst in model.base.remaps.items() if not src.startswith("__")}


def basenode_remaps(model: NodeModel, action_parts: Sequence[str] = ("",)) -> dict[str, str]:
    """Every ``from:=to`` the basenode is started with: its own remaps composed with the wrapping's.

    A wrapped name ``T`` (resolved through the own remaps already) goes to its internal
    name; an own remap ``S:=T`` becomes ``S:=internal(T)``, because ROS would not follow
    ``S → T → internal(T)``; the other own remaps stay as they are. A wrapped action is
    remapped by the names its ROS gives its parts (``action_parts``, from the backend): ROS 2
    remaps an action by its name (``("",)``), ROS 1 remaps each of its five topics.
    """
    wrapped = {t.resolved: internal_name(model, t.resolved) for t in model.topics if t.role == "reuse"}
    wrapped.update({s.resolved: internal_name(model, s.resolved) for s in model.services if s.role == "reuse"})
    wrapped.update({a.resolved + part: internal_name(model, a.resolved) + part
                    for a in model.actions if a.role == "reuse" for part in action_parts})
    remaps = {src: wrapped.get(dst, dst) for src, dst in own_remaps(model).items()}
    for name, inner in wrapped.items():
        remaps.setdefault(name, inner)
    return remaps


def reresolve(model: NodeModel) -> None:
    """After the basenode changed: base names may resolve elsewhere now."""
    for t in model.topics:
        t.resolved = resolve_for(model, t.role, t.name, "topic")
    for s in model.services:
        s.resolved = resolve_for(model, s.role, s.name, "service")
    for a in model.actions:
        a.resolved = resolve_for(model, a.role, a.name, "action")



# -- checks ----------------------------------------------------------------------------------

def check_reuse(model: NodeModel, resolved: str, direction: str, kind: str = "topic") -> None:
    """A base topic is wrapped once: refuse reuse of it in both directions."""
    if kind != "topic":
        return
    other = "subscribe" if direction == "publish" else "publish"
    if model.topic(resolved, other, "reuse") is not None:  # type: ignore[arg-type]
        raise DeclarationError(f"{resolved} is already wrapped as reuse.{other}; a base topic is wrapped once: "
                               f"remove it first ({model.name}.remove({resolved!r}))")


def check_wrapping(model: NodeModel, others: Sequence[NodeModel] = ()) -> None:
    """Refuse to create a node whose wrapping declarations are incomplete or clash."""
    every: list[TopicModel | ServiceModel | ActionModel] = [*model.topics, *model.services, *model.actions]
    reuses = [d.name for d in every if d.role == "reuse"]
    if model.base is None:
        if reuses:
            raise DeclarationError(f"{model.name} reuses {', '.join(reuses)} but has no basenode; declare it: "
                                   f"{model.name}.baseNode('executable').basePackage('package')")
        return
    executable = model.base.executable
    if not executable:
        raise DeclarationError(f"{model.name}'s basenode is incomplete; add .baseNode('executable')")
    if not model.base.package and not model.base.launch and "/" not in executable and not executable.startswith("~"):
        raise DeclarationError(f"{model.name}'s basenode is incomplete; add .basePackage('package'), or give the "
                               f"path of the file to run: baseNode('./{executable}')")
    mine = base_fullname(model)
    if mine == node_fullname(model):
        whence = ("given it" if model.base.node_name else "its code gives it" if model.base.own_name
                  else "of its executable")
        raise DeclarationError(f"{model.name} and its basenode would both be {mine} (the name {whence}), and two nodes "
                               f"of one name cannot both run; name the wrapping node otherwise, rosNode("
                               f"'{model.name}_wrap'), or the basenode, baseNode(..., name='...')")
    for other in others:
        if other.base is None or base_fullname(other) != mine:
            continue
        raise DeclarationError(f"basenode {mine} is already wrapped by {node_fullname(other)}; "
                               "wrap it once, or give this one another name: baseNode(..., name='other')")
