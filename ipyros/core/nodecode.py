"""What a node's Python source says about it, read and never run: the name its code gives its node.

A basenode started without ``name=`` should keep the name it has when run by hand (``rosrun``,
``ros2 run``): that is the name its lifecycle manager, its parameter clients and its private
topics (``~status`` is ``/<name>/status``) are known by. ipyros must know it before the node
starts, to remap those private names, and running the node to ask would let it act on the
robot's topics unwrapped; so its source is read instead. ROS nodes name themselves with a
literal almost always (``rospy.init_node("talker")``, ``Node("talker")``,
``super().__init__("talker")``), sometimes through a module constant (``NAME = "talker"``).
Anything else (a name computed at run time, several nodes in one file, a binary) gives
``None``, and the caller falls back to the executable's name.

An installed Python node is often a small entry-point script that names nothing itself
(``from demo_nodes_py.topics.talker import main``, or setuptools' ``load_entry_point(...)``):
:func:`entry_point_of` says what it runs, so that its module can be read in turn.
"""

from __future__ import annotations

import ast
from typing import Collection, Optional

from . import names
from .errors import DeclarationError

__all__ = ["entry_point_of", "node_name_in"]


def node_name_in(source: str, calls: Collection[str]) -> Optional[str]:
    """The one node name ``source`` gives, as the first argument (or ``node_name=``, ``name=``) of a call to one
    of ``calls`` (``init_node``, ``Node``, ...), or of ``__init__`` in a class derived from one; ``None`` if it
    names none, several, or one that is not a valid node name.

    >>> node_name_in('import rospy\\nrospy.init_node("odometry")', {"init_node"})
    'odometry'
    """
    try:
        tree = ast.parse(source)
    except (SyntaxError, ValueError):  # not Python after all, or a NUL byte in it
        return None
    constants = _module_constants(tree)
    found = {name for args, keywords in _naming_calls(tree, set(calls))
             if (name := _first_name(args, keywords, constants)) is not None}
    if len(found) != 1:
        return None
    name = found.pop().strip("/")
    try:
        names.check_node_name(name)
    except DeclarationError:
        return None
    return name


def _module_constants(tree: ast.Module) -> dict[str, str]:
    """``NAME = "talker"`` at the top of the module (assigned once: a name reassigned is not a constant)."""
    seen: dict[str, list[object]] = {}
    for statement in tree.body:
        if isinstance(statement, ast.Assign) and len(statement.targets) == 1 \
                and isinstance(statement.targets[0], ast.Name):
            value = statement.value.value if isinstance(statement.value, ast.Constant) else None
            seen.setdefault(statement.targets[0].id, []).append(value)
    return {key: values[0] for key, values in seen.items() if len(values) == 1 and isinstance(values[0], str)}


def _naming_calls(tree: ast.Module, calls: set[str]) -> list[tuple[list[ast.expr], list[ast.keyword]]]:
    """The arguments of the calls that name a node: to one of ``calls``, and ``super().__init__``/
    ``Base.__init__(self, ...)`` in a class whose bases include one of them (``self`` dropped from the second)."""
    found: list[tuple[list[ast.expr], list[ast.keyword]]] = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Call) and _called(node.func) in calls:
            found.append((node.args, node.keywords))
        elif isinstance(node, ast.ClassDef) and any(_called(base) in calls for base in node.bases):
            for inner in ast.walk(node):
                if isinstance(inner, ast.Call) and isinstance(inner.func, ast.Attribute) \
                        and inner.func.attr == "__init__":
                    owner = inner.func.value
                    if isinstance(owner, ast.Call) and _called(owner.func) == "super":
                        found.append((inner.args, inner.keywords))
                    elif _called(owner) in calls and inner.args:
                        found.append((inner.args[1:], inner.keywords))
    return found


def _called(func: ast.expr) -> Optional[str]:
    """``init_node`` for ``rospy.init_node`` and for ``init_node``."""
    if isinstance(func, ast.Attribute):
        return func.attr
    if isinstance(func, ast.Name):
        return func.id
    return None


def _first_name(args: list[ast.expr], keywords: list[ast.keyword], constants: dict[str, str]) -> Optional[str]:
    argument = next((k.value for k in keywords if k.arg in ("node_name", "name")), args[0] if args else None)
    if isinstance(argument, ast.Constant) and isinstance(argument.value, str):
        return argument.value
    if isinstance(argument, ast.Name):
        return constants.get(argument.id)
    return None


def entry_point_of(source: str) -> Optional[tuple[str, str]]:
    """What an entry-point script runs: ``("module", "pkg.mod")`` for ``from pkg.mod import main`` at its top,
    ``("console_scripts", "dist name/script")`` for setuptools' ``load_entry_point("dist==1.0", "console_scripts",
    "script")``; ``None`` for any other script.

    >>> entry_point_of("import sys\\nfrom demo_nodes_py.topics.talker import main\\nsys.exit(main())")
    ('module', 'demo_nodes_py.topics.talker')
    """
    try:
        tree = ast.parse(source)
    except (SyntaxError, ValueError):
        return None
    for node in ast.walk(tree):
        if isinstance(node, ast.Call) and _called(node.func) == "load_entry_point" and len(node.args) == 3 \
                and all(isinstance(a, ast.Constant) and isinstance(a.value, str) for a in node.args):
            dist, group, script = (a.value for a in node.args)  # type: ignore[attr-defined]
            if group == "console_scripts":
                return "console_scripts", f"{dist.split('==')[0]}/{script}"
    imported = [s.module for s in tree.body if isinstance(s, ast.ImportFrom) and s.module and not s.level
                and any(alias.name == "main" for alias in s.names)]
    return ("module", imported[0]) if len(imported) == 1 else None
