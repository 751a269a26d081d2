"""How ROS 2 runs a node: its executable found as ``ros2 run`` finds it, its command line after ``--ros-args``.

**Lookup.** Each prefix on ``AMENT_PREFIX_PATH`` (a PyPI venv has none set: ipyros uses
the venv's own prefix, where the wheels install) lists its packages as files under
``share/ament_index/resource_index/packages/``; a package's executables are the
executable files in ``<prefix>/lib/<package>/``.

**Command line.** :func:`command`: the file (a Python script with this interpreter, which
imports rclpy), its arguments, then ``--ros-args`` with ``-r`` for the name, namespace and
remaps and ``-p`` for parameters. No ROS package is imported here.
"""

from __future__ import annotations

import os
import sys
from pathlib import Path
from typing import Optional

from ..core.errors import BaseNodeError, did_you_mean
from ..core.model import BaseModel
from ..demo import AMENT_PREFIX as DEMO_PREFIX
from ..processes import basenode
from ..processes.basenode import param_value, python_command, refuse_path_with_package, script_command

__all__ = ["NODE_CALLS", "command", "find_executable", "list_executables", "list_packages", "own_node_name",
           "package_prefix", "prefixes"]


def command(base: BaseModel) -> list[str]:
    """The command line of the basenode ``base`` (its name, namespace, remaps and params after ``--ros-args``)."""
    if not base.executable:
        raise BaseNodeError("no basenode executable declared: call baseNode('executable') and basePackage('package')")
    if base.package:
        path, args = python_command(find_executable(base.package, base.executable), list(base.args))
    else:
        path, args = script_command(base.executable, list(base.args))
    rules = [f"__node:={base.node_name}"] if base.node_name else []
    rules += [f"__ns:={base.namespace.rstrip('/') or '/'}"] if base.namespace else []  # ROS 2: no trailing /
    rules += [f"{source}:={target}" for source, target in base.remaps.items()]
    settings = [f"{name.lstrip('~_')}:={param_value(value)}" for name, value in base.params.items()]
    argv = [str(path), *args]
    if rules or settings:
        argv += ["--ros-args", *[w for r in rules for w in ("-r", r)], *[w for p in settings for w in ("-p", p)]]
    return argv


def prefixes() -> list[Path]:
    """The ament prefixes, first wins: ``AMENT_PREFIX_PATH``, else this Python's prefix; then the demo's."""
    value = os.environ.get("AMENT_PREFIX_PATH") or sys.prefix
    return [*(Path(p) for p in value.split(os.pathsep) if p), DEMO_PREFIX]


def _packages() -> dict[str, Path]:
    found: dict[str, Path] = {}
    for prefix in prefixes():
        index = prefix / "share" / "ament_index" / "resource_index" / "packages"
        if index.is_dir():
            for marker in index.iterdir():
                found.setdefault(marker.name, prefix)
    return found


def package_prefix(package: str) -> Optional[Path]:
    """The ament prefix that has ``package`` (its files under ``share/<package>``), or None."""
    return _packages().get(package)


def list_packages() -> list[str]:
    """Names of the packages the ament index knows."""
    return sorted(_packages())


def list_executables(package: str) -> list[str]:
    """Names of ``package``'s executables; ``[]`` for an unknown package."""
    prefix = _packages().get(package)
    folder = prefix / "lib" / package if prefix is not None else None
    if folder is None or not folder.is_dir():
        return []
    return sorted(p.name for p in folder.iterdir() if p.is_file() and os.access(p, os.X_OK))


#: The calls that name a node in Python code (rclpy: ``create_node``, ``Node``,
#: ``LifecycleNode``, or ``__init__`` of a class derived from them): what a basenode's own name is read from.
NODE_CALLS = ("create_node", "Node", "LifecycleNode")


def own_node_name(base: BaseModel) -> Optional[str]:
    """The name the basenode's Python code gives its node, read from its file (never run), or None."""
    return basenode.own_node_name(base, find_executable, NODE_CALLS)


def find_executable(package: str, executable: str) -> Path:
    """The file ``ros2 run package executable`` would run; one line naming close matches if there is none."""
    refuse_path_with_package(executable)
    packages = _packages()
    if package not in packages:
        hint = did_you_mean(package, list(packages))
        raise BaseNodeError(f"unknown ROS 2 package {package!r}: {hint + ' ' if hint else ''}(the ament index at "
                            f"{os.pathsep.join(map(str, prefixes()))} does not list it; set AMENT_PREFIX_PATH)")
    path = packages[package] / "lib" / package / executable
    if "/" not in executable and path.is_file() and os.access(path, os.X_OK):
        return path
    have = list_executables(package)
    hint = did_you_mean(executable, have)
    raise BaseNodeError(f"package {package!r} has no executable {executable!r}; {hint + ' ' if hint else ''}"
                        f"its executables: {', '.join(have) or 'none'}")
