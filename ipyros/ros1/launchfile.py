"""Reading a launch file: one of its nodes as a basenode, and the rest of it without that node.

``nd.baseLaunch("robot.launch", "/robot1/planner")`` wraps a node that a launch file
starts, without editing the file. This module reads the file with roslaunch's own
loader (``roslaunch.config.load_config_default``: args and their defaults, includes,
groups, namespaces, ``$(find)``, ``<remap>`` and ``<rosparam>`` are all roslaunch's
doing, so ipyros reads exactly what ``roslaunch`` would run) and answers two questions:

- **the node** (:func:`read_base`): which ``<node>`` is meant (by full name
  ``/robot1/planner``, or a relative or short name if only one node has it), and what
  it is as a :class:`~ipyros.core.model.BaseModel`: package, executable, name, namespace,
  remaps (resolved as the node resolves them), private params (``<param>`` and
  ``<rosparam>`` inside the node, nested again), args and environment;
- **the rest** (:func:`without`): the same loaded configuration minus that node and
  its private params, which :mod:`ipyros.ros1.launch_rest` runs as roslaunch would.

Both load the file the same way (:func:`load`), so the wrapper and the rest runner see
the same nodes. Nothing here starts a process or talks to the master.
"""

from __future__ import annotations

import difflib
import os
import shlex
import socket
from pathlib import Path
from typing import TYPE_CHECKING, Any

from ..core import names
from ..core.errors import BaseNodeError
from ..core.model import BaseModel
from ..processes.launched import launch_file

if TYPE_CHECKING:
    from roslaunch.config import ROSLaunchConfig
    from roslaunch.core import Node

_LOCAL_ADDRESSES = {"localhost", "127.0.0.1", "::1"}


# -- the file --------------------------------------------------------------------------------

def launch_path(launch: str) -> Path:
    """The launch file ``launch`` names: a path (``~`` and relative to the working dir) or ``$(find pkg)/...``."""
    if not isinstance(launch, str) or not launch.strip():
        raise BaseNodeError(f"launch file {launch!r} is not a path; give one like 'robot.launch' "
                            "or '$(find my_robot)/launch/robot.launch'")
    text = launch.strip()
    if "$(" in text:
        from roslaunch.substitution_args import resolve_args
        from rospkg import ResourceNotFound

        try:
            text = resolve_args(text)
        except ResourceNotFound as error:
            raise BaseNodeError(f"cannot resolve launch file {launch!r}: no ROS package {error.args[0]!r} "
                                "on ROS_PACKAGE_PATH; check the name, or give the file's path") from None
        except Exception as error:  # roslaunch's SubstitutionException and its kin
            raise BaseNodeError(f"cannot resolve launch file {launch!r}: {one_line(error)}") from None
    return launch_file(text, launch, "$(find package)/launch/name.launch")


def stored_path(launch: str) -> str:
    """What the model keeps: ``$(find pkg)/...`` as written (it travels between machines), else the absolute path."""
    return launch.strip() if "$(" in launch else str(launch_path(launch))


def load(launch: str, args: "dict[str, str] | None" = None) -> "ROSLaunchConfig":
    """The launch file loaded by roslaunch's own loader, with ``args`` (``roslaunch FILE a:=1``).

    Args not given take their defaults; an arg the file does not declare, or a required
    one (no default) not given, is refused first with the line that fixes it. Machines
    are not assigned (that would look remote hosts up on the network); a roslaunch
    error becomes one :class:`BaseNodeError` line naming the file.
    """
    import roslaunch.config
    from roslaunch.core import RLException

    path = launch_path(launch)
    args = check_args(path, args or {})
    argv = [f"{name}:={value}" for name, value in args.items()]
    try:
        return roslaunch.config.load_config_default([(str(path), argv)], None, verbose=False,
                                                    assign_machines=False)
    except (RLException, ValueError, KeyError, OSError) as error:
        raise BaseNodeError(f"roslaunch cannot load {path}: {one_line(error)}; fix the launch file (check it with: "
                            f"roslaunch --nodes {shlex.join([str(path), *argv])})") from None


def declared_args(path: Path) -> dict[str, bool]:
    """The file's own ``<arg>`` names (not those of ``<include>``), each with whether it must be given."""
    import xml.etree.ElementTree as ET

    try:
        root = ET.parse(path).getroot()
    except (ET.ParseError, OSError) as error:
        raise BaseNodeError(f"roslaunch cannot load {path}: Invalid roslaunch XML syntax: {error}; "
                            "fix the launch file") from None
    found: dict[str, bool] = {}

    def walk(element: Any) -> None:
        for child in element:
            if child.tag == "include":
                continue  # its <arg> children pass values in; they declare nothing here
            if child.tag == "arg" and child.get("name"):
                found[child.get("name")] = child.get("default") is None and child.get("value") is None
            walk(child)

    walk(root)
    return found


def check_args(path: Path, args: "dict[str, Any]") -> dict[str, str]:
    """``args`` as roslaunch reads them (strings; True as ``true``), refused unless the file declares them."""
    declared = declared_args(path)
    unknown = sorted(set(args) - set(declared))
    if unknown:
        close = [m for name in unknown for m in difflib.get_close_matches(name, declared, n=1)]
        hint = f"did you mean {', '.join(close)}? " if close else ""
        raise BaseNodeError(f"launch file {path.name} has no arg {', '.join(unknown)}; {hint}its args: "
                            f"{', '.join(sorted(declared)) or 'none'}")
    text = {name: ("true" if value is True else "false" if value is False else str(value))
            for name, value in args.items()}
    missing = sorted(name for name, required in declared.items() if required and name not in text)
    if missing:
        example = ", ".join(f"{name}=..." for name in missing)
        raise BaseNodeError(f"launch file {path.name} needs arg {', '.join(missing)} (no default); give it: "
                            f"baseLaunch({path.name!r}, node, {example})")
    return text


def one_line(error: Any) -> str:
    """roslaunch's multi-line messages made one line (and kept short)."""
    text = " ".join(str(error).split())
    return text if len(text) <= 300 else text[:297] + "..."


# -- the node --------------------------------------------------------------------------------

def fullname(node: "Node") -> str:
    """``/robot1/planner``: the name the node registers with."""
    return names.join(names.global_ns(node.namespace or "/"), node.name)


def find_node(config: "ROSLaunchConfig", name: str, launch: str) -> "Node":
    """The launch file's node called ``name``: a full name, or a relative/short name only one node has.

    ``/robot1/planner`` must match exactly; ``planner`` or ``robot1/planner`` match the
    nodes whose full name ends that way, and must match one.
    """
    if not isinstance(name, str) or not name.strip("/ "):
        raise BaseNodeError(f"node name {name!r} is empty; give the node's name as in the launch file, "
                            "e.g. '/robot1/planner'")
    nodes = {fullname(n): n for n in config.nodes if n.name}
    wanted = name.strip()
    if wanted.startswith("/"):
        found = [n for full, n in nodes.items() if full == wanted.rstrip("/")]
    else:
        found = [n for full, n in nodes.items() if full.endswith("/" + wanted.strip("/"))]
    if len(found) == 1:
        return found[0]
    if found:
        raise BaseNodeError(f"{launch} has {len(found)} nodes named {wanted!r}: "
                            f"{', '.join(sorted(fullname(n) for n in found))}; give the full name")
    listing = ", ".join(sorted(nodes)) or "none"
    by_full = difflib.get_close_matches(wanted.rstrip("/"), list(nodes), n=3, cutoff=0.6)
    by_short = [full for short in difflib.get_close_matches(wanted.strip("/"), [n.name for n in nodes.values()],
                                                            n=3, cutoff=0.6)
                for full, n in nodes.items() if n.name == short]
    close = list(dict.fromkeys(by_full + by_short))[:3]
    hint = f"did you mean {' or '.join(close)}? " if close else ""
    raise BaseNodeError(f"{launch} starts no node {wanted!r}: {hint}its nodes: {listing}")


def check_supported(config: "ROSLaunchConfig", node: "Node", launch: str) -> list[str]:
    """Refuse what ipyros cannot run as the launch file says; return notes on what it runs differently.

    Refused: a remote ``machine=`` (ipyros runs basenodes on this machine) and a
    ``launch-prefix`` (gdb, valgrind, ...: ipyros runs the executable itself).
    """
    full = fullname(node)
    if node.machine_name:
        machine = config.machines.get(node.machine_name)
        address = getattr(machine, "address", None)
        if machine is None or not _is_local(address) or getattr(machine, "user", None) not in (None, "", _user()):
            raise BaseNodeError(f"{full} runs on machine {node.machine_name!r} ({address or 'unknown'}) in {launch}; "
                                "ipyros runs a basenode on this machine only: wrap a node without machine=")
    if node.launch_prefix:
        raise BaseNodeError(f"{full} has launch-prefix={node.launch_prefix!r} in {launch}; ipyros starts the "
                            "executable itself and cannot apply it: wrap a node without launch-prefix")
    notes = []
    if node.respawn:
        notes.append(f"{full} is respawn=\"true\" in {launch}: ipyros reports its exits instead of respawning it "
                     "(restart it with .base.restart())")
    if node.required:
        notes.append(f"{full} is required=\"true\" in {launch}: if it dies, ipyros tells you and the rest of the "
                     "launch keeps running")
    return notes


def _is_local(address: Any) -> bool:
    """Whether a machine address is this machine, judged without asking DNS."""
    if not isinstance(address, str):
        return False
    return address in _LOCAL_ADDRESSES or address.startswith("127.") or address in (socket.gethostname(),
                                                                                     os.uname().nodename)


def _user() -> str:
    try:
        import pwd

        return pwd.getpwuid(os.getuid()).pw_name
    except (ImportError, KeyError):
        return os.environ.get("USER", "")


def private_params(config: "ROSLaunchConfig", node_fullname: str) -> dict[str, Any]:
    """The node's private params (``/ns/name/...``), nested again: ``{"gains": {"p": 1.5}, "rate": 5}``.

    roslaunch flattens ``<rosparam>`` dicts into one param per leaf; nesting them back
    gives the same tree on the parameter server and a readable model.
    """
    prefix = node_fullname + "/"
    params: dict[str, Any] = {}
    for key in sorted(config.params):
        if not key.startswith(prefix):
            continue
        *parents, leaf = key[len(prefix):].split("/")
        branch = params
        for part in parents:
            branch = branch.setdefault(part, {})
        branch[leaf] = config.params[key].value
    return params


def base_model(config: "ROSLaunchConfig", node: "Node", launch: str) -> BaseModel:
    """The node as a basenode: what ``roslaunch`` would run, as plain data."""
    full = fullname(node)
    namespace = names.global_ns(node.namespace or "/")
    remaps = {names.resolve(src, namespace, node.name, "remapped"): names.resolve(dst, namespace, node.name, "remapped")
              for src, dst in node.remap_args}
    return BaseModel(
        executable=node.type, package=node.package, node_name=node.name, namespace=namespace,
        remaps=remaps, params=private_params(config, full), args=shlex.split(node.args or ""),
        env={str(k): str(v) for k, v in node.env_args}, launch=stored_path(launch), launch_node=full,
    )


def read_base(launch: "str | os.PathLike[str]", name: str,
              args: "dict[str, Any] | None" = None) -> tuple[BaseModel, list[str]]:
    """Node ``name`` of launch file ``launch`` (loaded with ``args``) as a basenode, and notes on
    what ipyros runs differently."""
    launch = os.fspath(launch) if isinstance(launch, os.PathLike) else launch
    args = check_args(launch_path(launch), args or {})
    config = load(launch, args)
    node = find_node(config, name, launch)
    notes = check_supported(config, node, launch)
    base = base_model(config, node, launch)
    base.launch_args = args
    return base, notes


# -- the rest --------------------------------------------------------------------------------

def without(config: "ROSLaunchConfig", node_fullname: str) -> "ROSLaunchConfig":
    """``config`` without the node ``node_fullname`` and its private params (the wrapper sets those).

    Raises :class:`BaseNodeError` if the configuration has no such node, e.g. because
    the file changed since it was read, or names the node ``$(anon ...)``.
    """
    keep = [n for n in config.nodes if not (n.name and fullname(n) == node_fullname)]
    if len(keep) == len(config.nodes):
        raise BaseNodeError(f"the launch file starts no node {node_fullname} any more; declare baseLaunch() again")
    config.nodes = keep
    config.resolved_node_names = [n for n in config.resolved_node_names if n != node_fullname]
    prefix = node_fullname + "/"
    config.params = {k: p for k, p in config.params.items() if not k.startswith(prefix)}
    return config
