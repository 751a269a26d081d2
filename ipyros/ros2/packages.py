"""Finding a ROS 2 package's executable as ``ros2 run PACKAGE EXECUTABLE`` does: the ament index.

Each prefix on ``AMENT_PREFIX_PATH`` (a PyPI venv has none set: ipyros uses the venv's own
prefix, where the wheels install) lists its packages as files under
``share/ament_index/resource_index/packages/``; a package's executables are the
executable files in ``<prefix>/lib/<package>/``. No ROS package is imported for this.
"""

from __future__ import annotations

import os
import sys
from pathlib import Path

from ..core.errors import BaseNodeError
from ..processes.basenode import DEMO_DIR, did_you_mean, refuse_path_with_package

__all__ = ["find_executable", "list_executables", "list_packages", "prefixes"]


#: The demo robot's package, ``ipyros_demo``, as an ament prefix of its own (its executables
#: are the ROS 1 ones: they run on either ROS, see ipyros/demo/demonode.py).
DEMO_PREFIX = DEMO_DIR / "ament"


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
