"""ROS graph names: checked and resolved the way ROS resolves them, in plain Python.

A DSL node resolves every name itself (relative names in its namespace, ``~name``
under the node), so that the names in the model are global and do not depend on the
process node a ROS client library happens to be running as. The rules checked everywhere
are the ones ROS 1 and ROS 2 share (``/`` separates, ``~`` is the node's own, a name
starts with a letter); what one ROS adds is a :class:`NameRules` (:data:`ROS1`,
:data:`ROS2`), which the session's backend names and the DSL passes in. Nothing here
imports a ROS package, so the model, the plan and the wrapping rules stay the same
whichever ROS runs them.
"""

from __future__ import annotations

import os
import re
from dataclasses import dataclass
from typing import Optional

from .errors import TopicNameError, cut


@dataclass(frozen=True)
class NameRules:
    """What one ROS allows in its graph names beyond the rules both share."""

    ros: str
    #: ROS 2 reserves ``__`` for its own keys (``__node``, ``__ns``): no name may hold it (design.ros2.org,
    #: "Topic and Service name design"); ROS 1 names may.
    reserved_underscores: bool = False
    #: ROS 2: no part of a name may start with a digit (``/a/1b``); ROS 1 allows it after the first part.
    digit_parts: bool = True
    longest_name: Optional[int] = None  # a topic's or service's full name (ROS 2: 255 - 8, what rmw allows)
    longest_node: Optional[int] = None  # a node's base name
    longest_namespace: Optional[int] = None

    def check(self, name: str, kind: str) -> str:
        """``name`` (a resolved global name) as this ROS allows it, else a one-line error naming the rule."""
        longest = self.longest_namespace if kind == "namespace" else self.longest_name
        if longest is not None and len(name) > longest:
            raise TopicNameError(f"{kind} name {cut(name)} is {len(name):,} characters; {self.ros} allows "
                                 f"{longest}: give a shorter one")
        if self.reserved_underscores and "__" in name:
            raise TopicNameError(f"invalid {kind} name {cut(name)}: {self.ros} reserves '__' (for __node, __ns, ...) "
                                 "and allows no name holding it; use a single _")
        if not self.digit_parts and re.search(r"(^|/)\d", name):
            raise TopicNameError(f"invalid {kind} name {cut(name)}: in {self.ros} no part of a name may start with "
                                 "a digit; start it with a letter")
        return name


#: ROS 1's names (ros_comm's rosgraph.names): the shared rules alone.
ROS1 = NameRules("ROS 1")
#: ROS 2's names (rmw's validate_full_topic_name, validate_node_name, validate_namespace, and the design's reserved
#: ``__``).
ROS2 = NameRules("ROS 2", reserved_underscores=True, digit_parts=False, longest_name=247, longest_node=255,
                 longest_namespace=245)

SEP = "/"
_LEGAL_NAME = re.compile(r"[~/A-Za-z][\w/]*")
_LEGAL_BASE_NAME = re.compile(r"[A-Za-z]\w*")


def tool_name(purpose: str) -> str:
    """The name of one of ipyros's own helper nodes (``%echo``, ``%pub``, ...): ``ipyros_<purpose>_<pid>``,
    unique on the graph and recognisable in ``rosnode list``."""
    return f"ipyros_{purpose}_{os.getpid()}"


def is_tool(name: str) -> bool:
    """Whether ``name`` (base or global) is a helper node's, of any ipyros session: not a node the user made (a
    guard's own process is ``ipyros_guard_<pid>_<n>``)."""
    return re.fullmatch(r"ipyros_[a-z]+_\d+(?:_\d+)?", name.rsplit(SEP, 1)[-1]) is not None


def is_legal_name(name: str) -> bool:
    """A graph name as ROS allows it: ``cmd_vel``, ``/a/b``, ``~status`` (no ``//``; empty is the namespace)."""
    return name == "" or (_LEGAL_NAME.fullmatch(name) is not None and "//" not in name)


def is_legal_base_name(name: str) -> bool:
    """A name without namespace: a letter, then letters, digits and ``_``."""
    return _LEGAL_BASE_NAME.fullmatch(name) is not None


def global_ns(name: str) -> str:
    """``robot1`` → ``/robot1/``: a namespace as a global name with its trailing ``/``."""
    if name.startswith("~"):
        raise ValueError(f"cannot turn {name!r} into a global namespace")
    name = name if name.startswith(SEP) else SEP + name
    return name if name.endswith(SEP) else name + SEP


def join(namespace: str, name: str) -> str:
    """``name`` inside ``namespace``, unless it is global or private already."""
    if name.startswith((SEP, "~")) or not namespace:
        return name
    if namespace == "~":
        return "~" + name
    return namespace + name if namespace.endswith(SEP) else namespace + SEP + name


def _canonical(name: str) -> str:
    """No repeated and no trailing ``/``: ``/a//b/`` → ``/a/b``."""
    parts = SEP.join(part for part in name.split(SEP) if part)
    return SEP + parts if name.startswith(SEP) else parts


def namespace_of(name: str) -> str:
    """The namespace containing a name (``/a/b`` → ``/a/``; ``/a`` → ``/``)."""
    name = name.rstrip(SEP)
    return name[:name.rfind(SEP) + 1] or SEP


def resolve_in(name: str, caller: str) -> str:
    """``name`` resolved for the node ``caller`` (a global node name): ROS's rule, with no remapping."""
    if not name:
        return namespace_of(caller)
    name = _canonical(name)
    if name.startswith(SEP):
        return name
    if name.startswith("~"):
        return _canonical(caller + SEP + name[1:])
    return _canonical(namespace_of(caller) + name)


def default_namespace() -> str:
    """The namespace nodes start in: ``ROS_NAMESPACE`` if set, else ``/``."""
    return global_ns(os.environ.get("ROS_NAMESPACE", "/") or "/")


def check_namespace(namespace: str, rules: NameRules = ROS1) -> str:
    """A namespace as a global one (``robot1`` → ``/robot1/``), refused unless a legal name of ``rules``' ROS."""
    if not isinstance(namespace, str):
        raise TopicNameError(f"namespace {cut(namespace)} is a {type(namespace).__name__}, not a string; "
                             "give one like '/robot1'")
    if namespace.strip("/") and not is_legal_name(namespace.strip("/")) or "~" in namespace:
        raise TopicNameError(f"invalid namespace {cut(namespace)}: use letters, digits, _ and / (each part "
                             "starting with a letter), e.g. '/robot1'")
    found = global_ns(namespace or "/")
    rules.check(found.rstrip("/") or "/", "namespace")
    return found


def check_node_name(name: str, rules: NameRules = ROS1) -> str:
    """A node's base name: a legal ROS name without namespace separators or ``~`` (and as ``rules``' ROS allows)."""
    if not isinstance(name, str) or not name:
        raise TopicNameError(f"node name {cut(name)} is not a string; give a name like 'turtle_control_node'")
    if "/" in name.strip("/") or name.startswith("~") or not is_legal_base_name(name.strip("/")):
        raise TopicNameError(
            f"invalid node name {cut(name)}: use letters, digits and _ (start with a letter), "
            "and put a namespace in namespace=... instead"
        )
    base = name.strip("/")
    if rules.longest_node is not None and len(base) > rules.longest_node:
        raise TopicNameError(f"node name {cut(base)} is {len(base):,} characters; {rules.ros} allows "
                             f"{rules.longest_node}: give a shorter one")
    if rules.reserved_underscores and "__" in base:
        raise TopicNameError(f"invalid node name {cut(base)}: {rules.ros} reserves '__' and allows no name "
                             "holding it; use a single _")
    return base


def resolve(name: str, namespace: str, node_name: str, kind: str = "topic", rules: NameRules = ROS1) -> str:
    """The global name of ``name`` for a node ``node_name`` living in ``namespace``, as ``rules``' ROS allows it.

    ``kind`` only words the error ("topic", "service", "parameter").
    """
    if not isinstance(name, str):
        raise TopicNameError(f"{kind} name {cut(name)} is a {type(name).__name__}, not a string; "
                             "give a name like '/turtle1/cmd_vel'")
    if not name.strip():
        raise TopicNameError(f"{kind} name {name!r} is empty; give a name like '/turtle1/cmd_vel'")
    if not is_legal_name(name) or name.endswith("/") and name != "/":
        raise TopicNameError(
            f"invalid {kind} name {cut(name)}: use letters, digits, _ and / (each part starting with a letter), "
            "e.g. '/turtle1/cmd_vel', 'cmd_vel' or '~status'"
        )
    resolved = resolve_in(name, join(global_ns(namespace), node_name))
    return resolved if kind == "parameter" else rules.check(resolved, kind)


# REP 144: letters, digits and underscores, starting with a letter (lower case for new packages;
# upper case is still found in older ones, so it is read, not refused).
_PACKAGE_NAME = re.compile(r"[A-Za-z][A-Za-z0-9_]*")


def check_package_name(package: str) -> str:
    """A ROS package name as it may enter the model (and later a launch file, package.xml, a script)."""
    if not isinstance(package, str) or not _PACKAGE_NAME.fullmatch(package):
        raise TopicNameError(f"invalid package name {package!r:.80}: a ROS package name is letters, digits and _, "
                             "starting with a letter (REP 144), e.g. 'topic_tools'")
    return package


def check_param_key(key: str, where: str) -> str:
    """A parameter name given without ``~`` (``gain``, ``pid/p``): a legal relative ROS name, nothing else.

    A key is written into the parameter server, an exported launch file (``<param name=...>``,
    which roslaunch would read ``$(...)`` in) and the command line (``_key:=value``).
    """
    if not isinstance(key, str) or not key or key.startswith("/") or not is_legal_name(key) or \
            key.endswith("/") or not is_legal_base_name(key.split("/")[0].lstrip("~_") or "x"):
        raise TopicNameError(f"{where}: invalid parameter name {key!r:.80}: give a name like 'gain' or 'pid/p' "
                             "(letters, digits, _ and /, each part starting with a letter)")
    return key


def check_remap(source: str, target: str) -> None:
    """Both sides of a remap ``source:=target``: legal ROS names (``__name``-style special keys allowed on the left)."""
    for side in (source, target):
        special = side is source and isinstance(side, str) and re.fullmatch(r"__[a-z]+", side) is not None
        if not isinstance(side, str) or not special and (not side or not is_legal_name(side)):
            raise TopicNameError(f"invalid remap {source!r:.60}:={target!r:.60}: both sides must be ROS names, "
                                 "e.g. {'scan': '/robot1/scan'}")
