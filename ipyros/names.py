"""ROS graph names: checked and resolved the way ROS resolves them, without rospy.

A DSL node resolves every name itself (relative names in its namespace, ``~name``
under the node), so that the names in the model are global and do not depend on the
process node rospy happens to be running as.
"""

from __future__ import annotations

import os

from rosgraph import names as rosnames

from .errors import TopicNameError


def default_namespace() -> str:
    """The namespace nodes start in: ``ROS_NAMESPACE`` if set, else ``/``."""
    return rosnames.make_global_ns(os.environ.get("ROS_NAMESPACE", "/") or "/")


def check_namespace(namespace: str) -> str:
    """A namespace as a global one (``robot1`` → ``/robot1/``), refused unless a legal ROS name."""
    if not isinstance(namespace, str):
        raise TopicNameError(f"namespace {namespace!r} is a {type(namespace).__name__}, not a string; "
                             "give one like '/robot1'")
    if namespace.strip("/") and not rosnames.is_legal_name(namespace.strip("/")) or "~" in namespace:
        raise TopicNameError(f"invalid namespace {namespace!r}: use letters, digits, _ and / (each part "
                             "starting with a letter), e.g. '/robot1'")
    return rosnames.make_global_ns(namespace or "/")


def check_node_name(name: str) -> str:
    """A node's base name: a legal ROS name without namespace separators or ``~``."""
    if not isinstance(name, str) or not name:
        raise TopicNameError(f"node name {name!r} is not a string; give a name like 'turtle_control_node'")
    if "/" in name.strip("/") or name.startswith("~") or not rosnames.is_legal_base_name(name.strip("/")):
        raise TopicNameError(
            f"invalid node name {name!r}: use letters, digits and _ (start with a letter), "
            "and put a namespace in namespace=... instead"
        )
    return name.strip("/")


def resolve(name: str, namespace: str, node_name: str, kind: str = "topic") -> str:
    """The global name of ``name`` for a node ``node_name`` living in ``namespace``.

    ``kind`` only words the error ("topic", "service", "parameter").
    """
    if not isinstance(name, str):
        raise TopicNameError(f"{kind} name {name!r} is a {type(name).__name__}, not a string; "
                             "give a name like '/turtle1/cmd_vel'")
    if not name.strip():
        raise TopicNameError(f"{kind} name {name!r} is empty; give a name like '/turtle1/cmd_vel'")
    if not rosnames.is_legal_name(name) or name.endswith("/") and name != "/":
        raise TopicNameError(
            f"invalid {kind} name {name!r}: use letters, digits, _ and / (each part starting with a letter), "
            "e.g. '/turtle1/cmd_vel', 'cmd_vel' or '~status'"
        )
    caller_id = rosnames.ns_join(rosnames.make_global_ns(namespace), node_name)
    return rosnames.resolve_name(name, caller_id)


def namespace_of(name: str) -> str:
    """The namespace containing a global name (``/a/b`` → ``/a/``)."""
    return rosnames.namespace(name)
