"""Reading a ROS 2 launch file, XML or YAML, without the launch package: its nodes as basenodes.

``nd.baseLaunch("robot.launch.xml", "/robot1/planner")`` wraps a node that a launch file
starts. ``ros2 launch`` is not on PyPI, so this module reads the two declarative formats
itself, for what robots' launch files say: ``<arg>`` (given as ``ros2 launch FILE a:=1``
would, else its default), ``<let>``, ``<node>`` with ``<remap>``, ``<param>`` (a value,
nested ``<param>`` groups, or ``from=`` a parameters file) and ``<env>``, ``<group>``
with ``<push-ros-namespace>``, ``<set-remap>``, ``<set-parameter>``, ``<set-env>``,
``<include>`` of another XML or YAML file with its ``<arg>``\\ s, ``if=``/``unless=`` on
any of them, and the substitutions ``$(var)``, ``$(env)``, ``$(find-pkg-share)``,
``$(find-pkg-prefix)``, ``$(dirname)``, ``$(filename)``.

What would run code from the file is refused, in one line: ``$(eval ...)``,
``$(command ...)`` and Python launch files (ipyros never runs code from a data file; the
launch package, which would, is not on PyPI). Tags it does not act on (``<timer>``,
``<executable>``, composable nodes) are said, never silently dropped.

:func:`read` gives every node the file starts, as a :class:`~ipyros.core.model.BaseModel`
each (its ``launch_node`` the full name); :func:`read_base` the one to wrap. The rest is
started by :mod:`.launch_rest`. Nothing here starts a process or touches the graph.
"""

from __future__ import annotations

import difflib
import os
import re
import shlex
import xml.etree.ElementTree as ET
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any, Optional

import yaml

from ..core import names
from ..core.errors import BaseNodeError
from ..core.model import BaseModel
from ..processes.launched import launch_file
from . import nodes as ros2_nodes

__all__ = ["Launched", "launch_path", "read", "read_base"]

#: What marks a launch file as Python, which only the launch package runs.
_PYTHON = (".py",)
_CODE = re.compile(r"\$\((eval|command)\b")
_INNERMOST = re.compile(r"\$\(([^()$]*)\)")
#: roslaunch's substitutions, and what ROS 2 launch files say instead.
_ROS1_SUBSTITUTIONS = {"arg": "$(var name)", "find": "$(find-pkg-share package)", "optenv": "$(env NAME default)"}


@dataclass
class Entry:
    """One element of either format, as one tree: ``<node pkg=...>`` and ``- node: {pkg: ...}`` alike."""

    tag: str
    attrs: dict[str, Any]
    children: list["Entry"] = field(default_factory=list)


@dataclass
class Scope:
    """What the launch file has set so far where an element is read: its variables, namespace, global rules."""

    file: Path
    values: dict[str, Any]
    namespace: str = "/"
    env: dict[str, str] = field(default_factory=dict)
    remaps: dict[str, str] = field(default_factory=dict)
    params: dict[str, Any] = field(default_factory=dict)

    def inner(self, file: Optional[Path] = None) -> "Scope":
        """A scope inside this one (a group, an include): what is set in it does not leak out."""
        return Scope(file or self.file, dict(self.values), self.namespace, dict(self.env), dict(self.remaps),
                     dict(self.params))


@dataclass
class Launched:
    """What a launch file starts, read with its args: the nodes in order, and what ipyros does not run."""

    path: Path
    nodes: list[BaseModel]
    notes: list[str]


# -- the file --------------------------------------------------------------------------------

def launch_path(launch: Any) -> Path:
    """The launch file ``launch`` names: a path (``~``, relative to the working dir) or ``$(find-pkg-share pkg)/...``."""
    if not isinstance(launch, (str, os.PathLike)) or not str(launch).strip():
        raise BaseNodeError(f"launch file {launch!r} is not a path; give one like 'robot.launch.xml' "
                            "or '$(find-pkg-share my_robot)/launch/robot.launch.xml'")
    text = str(launch).strip()
    if "$(" in text:
        text = _substitute(text, Scope(Path.cwd(), {}), str(launch))
    return launch_file(text, str(launch), "$(find-pkg-share package)/launch/name.launch.xml")


def stored_path(launch: Any) -> str:
    """What the model keeps: ``$(find-pkg-share pkg)/...`` as written (it travels between machines), else the path."""
    text = str(launch).strip()
    return text if "$(" in text else str(launch_path(text))


def _entries(path: Path, shown: str) -> list[Entry]:
    """The top-level entries of a launch file, XML or YAML, as one tree."""
    if path.name.endswith(_PYTHON):
        raise BaseNodeError(f"{shown} is a Python launch file, which only the launch package can run (and ipyros "
                            "runs no code from a file); write it as XML or YAML (robot.launch.xml), or start it "
                            "with ros2 launch and wrap its node with baseNode(...)")
    try:
        text = path.read_text()
    except OSError as error:
        raise BaseNodeError(f"cannot read launch file {shown}: {error.strerror}") from None
    if text.lstrip().startswith("<"):
        try:
            root = ET.fromstring(text)
        except ET.ParseError as error:
            raise BaseNodeError(f"launch file {shown} is not well-formed XML: {error}") from None
        if root.tag != "launch":
            raise BaseNodeError(f"launch file {shown} has <{root.tag}> at its top; a launch file has <launch>")
        return [_from_xml(child) for child in root]
    try:
        document = yaml.safe_load(text)
    except yaml.YAMLError as error:
        raise BaseNodeError(f"launch file {shown} is neither XML nor valid YAML: "
                            f"{' '.join(str(error).split())}") from None
    if not isinstance(document, dict) or not isinstance(document.get("launch"), list):
        raise BaseNodeError(f"launch file {shown} has no 'launch:' list at its top; a YAML launch file starts "
                            "with launch: followed by - node: ..., - arg: ...")
    return [_from_yaml(item, shown) for item in document["launch"]]


def _tag(name: str) -> str:
    return name.replace("_", "-")  # both spellings are in use: push_ros_namespace, push-ros-namespace


def _from_xml(element: ET.Element) -> Entry:
    return Entry(_tag(element.tag), dict(element.attrib), [_from_xml(child) for child in element])


#: In YAML, the children an entry holds in lists under these keys (``remap: [{from: a, to: b}]``).
_LISTED = ("remap", "param", "env", "arg")


def _from_yaml(item: Any, shown: str) -> Entry:
    if not isinstance(item, dict) or len(item) != 1:
        raise BaseNodeError(f"launch file {shown}: each entry under 'launch:' is one '- tag: {{...}}', "
                            f"not {str(item)[:60]!r}")
    (tag, body), = item.items()
    body = body if isinstance(body, dict) else {}
    attrs = {key: value for key, value in body.items() if key != "children" and key not in _LISTED}
    children = [_from_yaml(child, shown) for child in body.get("children") or []]
    for key in _LISTED:
        for child in body.get(key) or []:
            nested = [_from_yaml({key: grand}, shown) for grand in child.get(key) or []] \
                if isinstance(child, dict) and isinstance(child.get(key), list) else []
            scalars = {k: v for k, v in child.items() if not (k == key and nested)} if isinstance(child, dict) else {}
            children.append(Entry(key, scalars, nested))
    return Entry(_tag(tag), attrs, children)


# -- substitutions ----------------------------------------------------------------------------

def _substitute(text: Any, scope: Scope, shown: str) -> Any:
    """``text`` with its ``$(...)`` resolved, innermost first; a value that is not a string is kept as it is."""
    if not isinstance(text, str) or "$(" not in text:
        return text
    code = _CODE.search(text)
    if code:
        raise BaseNodeError(f"{shown}: $({code[1]} ...) would run code from the launch file, which ipyros does not "
                            "do; give its result as a value, or set it with an <arg>")
    while True:
        found = _INNERMOST.search(text)
        if found is None:
            return text
        text = text[:found.start()] + _one(found[1].split(), scope, shown) + text[found.end():]


def _one(words: list[str], scope: Scope, shown: str) -> str:
    kind, rest = (words[0], words[1:]) if words else ("", [])
    if kind == "var" and len(rest) == 1:
        if rest[0] not in scope.values:
            raise BaseNodeError(f"{shown}: $(var {rest[0]}) is not set; declare it with <arg name=\"{rest[0]}\" "
                                "default=...> or give it to baseLaunch")
        return str(scope.values[rest[0]])
    if kind == "env" and len(rest) in (1, 2):
        if rest[0] not in os.environ and len(rest) == 1:
            raise BaseNodeError(f"{shown}: $(env {rest[0]}) is not set in this session's environment; set it, "
                                f"or give a default: $(env {rest[0]} value)")
        return os.environ.get(rest[0], rest[1] if len(rest) == 2 else "")
    if kind in ("find-pkg-share", "find-pkg-prefix") and len(rest) == 1:
        prefix = ros2_nodes.package_prefix(rest[0])
        if prefix is None:
            raise BaseNodeError(f"{shown}: $({kind} {rest[0]}): no ROS 2 package {rest[0]!r} in the ament index; "
                                "install it, or check AMENT_PREFIX_PATH")
        return str(prefix / "share" / rest[0] if kind == "find-pkg-share" else prefix)
    if kind == "dirname" and not rest:
        return str(scope.file.parent)
    if kind == "filename" and not rest:
        return str(scope.file)
    if kind in _ROS1_SUBSTITUTIONS:
        raise BaseNodeError(f"{shown}: $({' '.join(words)}) is ROS 1's spelling (roslaunch), and this session runs "
                            f"ROS 2; a ROS 2 launch file says {_ROS1_SUBSTITUTIONS[kind]}")
    raise BaseNodeError(f"{shown}: ipyros does not read $({' '.join(words)}); it reads $(var), $(env), "
                        "$(find-pkg-share), $(find-pkg-prefix), $(dirname) and $(filename)")


def _truth(value: Any, shown: str) -> bool:
    text = str(value).strip().lower()
    if text not in ("true", "1", "false", "0"):  # as launch refuses it
        raise BaseNodeError(f"{shown}: if/unless needs true or false, not {value!r}")
    return text in ("true", "1")


# -- the walk ------------------------------------------------------------------------------

class _Reader:
    """One reading of a launch file and what it includes: nodes and notes, in the order the file has them."""

    def __init__(self, shown: str) -> None:
        self.shown = shown
        self.nodes: list[BaseModel] = []
        self.notes: list[str] = []

    def value(self, entry: Entry, key: str, scope: Scope, default: Any = None) -> Any:
        return _substitute(entry.attrs.get(key, default), scope, self.shown)

    def wanted(self, entry: Entry, scope: Scope) -> bool:
        if "if" in entry.attrs and not _truth(self.value(entry, "if", scope), self.shown):
            return False
        return not ("unless" in entry.attrs and _truth(self.value(entry, "unless", scope), self.shown))

    def walk(self, entries: list[Entry], scope: Scope) -> None:
        for entry in entries:
            if self.wanted(entry, scope):
                self.step(entry, scope)

    def step(self, entry: Entry, scope: Scope) -> None:
        tag = entry.tag
        if tag == "arg":
            name = str(entry.attrs.get("name", ""))
            if name not in scope.values:
                if "default" not in entry.attrs:
                    raise BaseNodeError(f"{self.shown} needs the argument {name!r}: give it to baseLaunch "
                                        f"({name}=...)")
                scope.values[name] = self.value(entry, "default", scope)
        elif tag == "let":
            scope.values[str(entry.attrs.get("name", ""))] = self.value(entry, "value", scope)
        elif tag == "group":
            inner = scope if str(self.value(entry, "scoped", scope, "true")).lower() == "false" else scope.inner()
            if "namespace" in entry.attrs:
                inner.namespace = _join(inner.namespace, self.value(entry, "namespace", scope))
            self.walk(entry.children, inner)
        elif tag == "push-ros-namespace":
            scope.namespace = _join(scope.namespace, self.value(entry, "namespace", scope))
        elif tag == "set-env":
            scope.env[str(self.value(entry, "name", scope))] = str(self.value(entry, "value", scope, ""))
        elif tag == "unset-env":
            scope.env.pop(str(self.value(entry, "name", scope)), None)
        elif tag == "set-remap":
            scope.remaps[str(self.value(entry, "from", scope))] = str(self.value(entry, "to", scope))
        elif tag == "set-parameter":
            scope.params[str(self.value(entry, "name", scope))] = _typed(self.value(entry, "value", scope))
        elif tag == "include":
            self.include(entry, scope)
        elif tag == "node":
            self.node(entry, scope)
        else:
            self.notes.append(f"{self.shown}: ipyros does not run <{tag}> (it starts nodes, from XML and YAML); "
                              "start that part yourself")

    def include(self, entry: Entry, scope: Scope) -> None:
        target = Path(str(self.value(entry, "file", scope, ""))).expanduser()
        target = target if target.is_absolute() else scope.file.parent / target
        if not target.name.endswith(_PYTHON) and not target.is_file():
            raise BaseNodeError(f"{self.shown}: the included file {target} is not there; check its path")
        inner = scope.inner(target)
        for arg in (child for child in entry.children if child.tag == "arg" and self.wanted(child, scope)):
            inner.values[str(arg.attrs.get("name", ""))] = self.value(arg, "value", scope)
        shown, self.shown = self.shown, f"{target.name} (included by {self.shown})"
        try:
            self.walk(_entries(target, self.shown), inner)
        finally:
            self.shown = shown

    def node(self, entry: Entry, scope: Scope) -> None:
        executable = self.value(entry, "exec", scope)
        if executable is None:
            hint = " (that is ROS 1's spelling: ROS 2 names it exec=)" if "type" in entry.attrs else ""
            raise BaseNodeError(f"{self.shown}: a <node> without exec=...{hint}; give the executable's name")
        own = str(self.value(entry, "namespace", scope, "") or "")
        namespace = _join(scope.namespace, own) if own else scope.namespace
        name = self.value(entry, "name", scope)
        package = self.value(entry, "pkg", scope)
        # Without name=, ros2 launch runs the node under the name its code gives it: so it is known here too.
        own_name = None if name else ros2_nodes.own_node_name(BaseModel(executable=str(executable), package=package))
        called = str(name or own_name or Path(str(executable)).stem)
        params = dict(scope.params)
        remaps = dict(scope.remaps)
        env = dict(scope.env)
        for child in (c for c in entry.children if self.wanted(c, scope)):
            if child.tag == "remap":
                remaps[str(self.value(child, "from", scope))] = str(self.value(child, "to", scope))
            elif child.tag == "param":
                params.update(self.params_of(child, scope, names.join(namespace, called)))
            elif child.tag == "env":
                env[str(self.value(child, "name", scope))] = str(self.value(child, "value", scope, ""))
        args = shlex.split(str(self.value(entry, "args", scope, "") or ""))
        ros_args = shlex.split(str(self.value(entry, "ros_args", scope, entry.attrs.get("ros-args", "")) or ""))
        if ros_args:
            args += ["--ros-args", *ros_args, "--"]
        for unsupported in ("launch-prefix", "launch_prefix", "respawn"):
            if unsupported in entry.attrs:
                self.notes.append(f"{self.shown}: ipyros does not act on {unsupported}= of node "
                                  f"{names.join(namespace, called)}")
        self.nodes.append(BaseModel(
            executable=str(executable), package=package, node_name=name, own_name=own_name,
            namespace=namespace, remaps=remaps, params=params, args=args, env=env,
            launch_node=names.join(namespace, called)))

    def params_of(self, entry: Entry, scope: Scope, node: str, prefix: str = "") -> dict[str, Any]:
        """A ``<param>``'s values: one, a nested group (``a.b``), or a parameters file's for this node."""
        if "from" in entry.attrs:
            return _params_file(Path(str(self.value(entry, "from", scope))).expanduser(), node, self.shown)
        name = f"{prefix}{self.value(entry, 'name', scope)}"
        if entry.children:
            found: dict[str, Any] = {}
            for child in (c for c in entry.children if self.wanted(c, scope)):
                found.update(self.params_of(child, scope, node, f"{name}."))
            return found
        return {name: _typed(self.value(entry, "value", scope))}


def _join(namespace: str, name: Any) -> str:
    """A namespace ``name`` pushed inside ``namespace``: an absolute one replaces it, a relative one goes inside."""
    text = str(name)
    if text.startswith("/"):
        return text.rstrip("/") or "/"
    text = text.strip("/")
    return names.join(namespace, text) if text else namespace


def _typed(value: Any) -> Any:
    """A parameter's value as launch types it: YAML read (``5`` an int, ``true`` a bool, ``[1, 2]`` a list)."""
    if not isinstance(value, str):
        return value
    try:
        typed = yaml.safe_load(value)
    except yaml.YAMLError:
        return value
    return typed if isinstance(typed, (bool, int, float, list)) else value


def _params_file(path: Path, node: str, shown: str) -> dict[str, Any]:
    """The parameters a ROS 2 parameters file gives ``node`` (under ``/**``, its name or full name), flattened."""
    try:
        document = yaml.safe_load(path.read_text()) or {}
    except (OSError, yaml.YAMLError) as error:
        raise BaseNodeError(f"{shown}: cannot read the parameters file {path}: {error}") from None
    found: dict[str, Any] = {}
    for key in ("/**", node.rsplit("/", 1)[-1], node.lstrip("/"), node):
        section = document.get(key) if isinstance(document, dict) else None
        if isinstance(section, dict) and isinstance(section.get("ros__parameters"), dict):
            found.update(_flat(section["ros__parameters"]))
    return found


def _flat(values: dict[str, Any], prefix: str = "") -> dict[str, Any]:
    found: dict[str, Any] = {}
    for key, value in values.items():
        if isinstance(value, dict):
            found.update(_flat(value, f"{prefix}{key}."))
        else:
            found[f"{prefix}{key}"] = value
    return found


def _declared(entries: list[Entry]) -> set[str]:
    """The ``<arg>`` names a file declares, wherever in it (not in what it includes)."""
    found: set[str] = set()
    for entry in entries:
        if entry.tag == "arg" and "name" in entry.attrs:
            found.add(str(entry.attrs["name"]))
        if entry.tag == "group":
            found |= _declared(entry.children)
    return found


# -- what callers ask ----------------------------------------------------------------------

def read(launch: Any, args: Optional[dict[str, Any]] = None) -> Launched:
    """Every node ``launch`` starts with ``args`` set (as ``ros2 launch FILE a:=1``), in the file's order.

    An arg the file does not declare is refused, naming the ones it does; each node comes
    back with its launch file and args (``launch``, ``launch_args``) and full name (``launch_node``).
    """
    path = launch_path(launch)
    shown = path.name
    entries = _entries(path, shown)
    given = {name: _launch_value(value) for name, value in (args or {}).items()}
    declared = _declared(entries)
    for name in given:
        if name not in declared:
            close = difflib.get_close_matches(name, sorted(declared), n=1)
            hint = f"did you mean {close[0]}? " if close else ""
            raise BaseNodeError(f"{shown} has no argument {name!r}; {hint}"
                                f"its arguments: {', '.join(sorted(declared)) or 'none'}")
    reader = _Reader(shown)
    reader.walk(entries, Scope(path, dict(given)))
    stored = stored_path(launch)
    return Launched(path, [replace(node, launch=stored, launch_args=given) for node in reader.nodes], reader.notes)


def read_base(launch: Any, name: str, args: Optional[dict[str, Any]] = None) -> tuple[BaseModel, list[str]]:
    """The node ``name`` of ``launch`` (its full name, or a relative or short one only it has), and the notes."""
    launched = read(launch, args)
    return find_node(launched, name), launched.notes


def find_node(launched: Launched, name: str) -> BaseModel:
    """The node of ``launched`` that ``name`` means; one line naming the candidates when none or several."""
    if not isinstance(name, str) or not name.strip("/"):
        raise BaseNodeError(f"baseLaunch needs the name of a node of {launched.path.name}, e.g. "
                            f"{launched.nodes[0].launch_node if launched.nodes else '/robot/planner'!r}")
    every = [node.launch_node or "" for node in launched.nodes]
    if name.startswith("/"):
        matches = [node for node in launched.nodes if node.launch_node == name.rstrip("/")]
    else:
        matches = [node for node in launched.nodes if (node.launch_node or "").endswith("/" + name.strip("/"))]
    if len(matches) == 1:
        return matches[0]
    if matches:
        raise BaseNodeError(f"{launched.path.name} starts several nodes named {name!r}: "
                            f"{', '.join(n.launch_node or '' for n in matches)}; give the full name")
    close = difflib.get_close_matches(name, every, n=1)
    hint = f"did you mean {close[0]}? " if close else ""
    raise BaseNodeError(f"{launched.path.name} starts no node {name!r}; {hint}it starts: {', '.join(every) or 'none'}")


def _launch_value(value: Any) -> str:
    """A Python value as a launch argument: booleans as launch spells them."""
    return str(value).lower() if isinstance(value, bool) else str(value)
