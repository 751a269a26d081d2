"""How ROS 1 runs a node: its executable found as ``rosrun`` finds it, its command line as roslaunch writes it.

**Lookup.** :func:`find_executable` answers ``rosrun PACKAGE EXECUTABLE``'s question in
Python, without forking ``catkin_find`` and ``rospack``: a package's executables live
anywhere below

- its catkin *libexec* dir ``<workspace>/lib/<package>`` (Debian: ``/usr/lib/<package>``,
  e.g. ``/usr/lib/topic_tools/relay``), for the first workspace of ``CMAKE_PREFIX_PATH``
  that has the package (``/usr`` always counts, as Debian's catkin has it);
- its package dir: the folder with a ``package.xml`` naming it, found by crawling
  ``ROS_PACKAGE_PATH`` (as rospack does), else ``<workspace>/share/<package>``;
- and ipyros's own demo package ``ipyros_demo`` (``ipyros/demo``), last.

The package index is cached per ``(ROS_PACKAGE_PATH, CMAKE_PREFIX_PATH)`` so that tab
completion answers at once; a lookup that misses drops the cache and looks once more,
so a package or script created during the session is still found.

**Command line.** :func:`command`: the file, its arguments, then ROS's own command-line
remappings: ``__name:=``, ``__ns:=``, ``from:=to``, ``_param:=value``.

No ROS package is imported here.
"""

from __future__ import annotations

import functools
import os
import xml.etree.ElementTree as ET
from pathlib import Path
from typing import Iterable, Optional

from ..core.errors import BaseNodeError, did_you_mean
from ..core.model import BaseModel
from ..demo import DEMO_DIR
from ..processes import basenode
from ..processes.basenode import (
    is_executable_file,
    param_value,
    python_command,
    refuse_path_with_package,
    script_command,
)

__all__ = ["NODE_CALLS", "command", "find_executable", "link_outside", "list_executables", "list_packages",
           "own_node_name", "refresh_packages"]


def command(base: BaseModel) -> list[str]:
    """The command line of the basenode ``base`` (its name, namespace, remaps and params filled in)."""
    if not base.executable:
        raise BaseNodeError("no basenode executable declared: call baseNode('executable') and basePackage('package')")
    args = list(base.args)
    if base.package:  # a Python node for "a python3" runs on this one, which has rospy (see python_command)
        path, args = python_command(find_executable(base.package, base.executable), args)
    else:
        path, args = script_command(base.executable, args)
    argv = [str(path), *args]
    if base.node_name:
        argv.append(f"__name:={base.node_name}")
    if base.namespace:
        argv.append(f"__ns:={base.namespace}")
    argv += [f"{source}:={target}" for source, target in base.remaps.items()]
    argv += [f"_{_key(name)}:={param_value(value)}" for name, value in base.params.items()]
    return argv


def _key(name: str) -> str:
    return name[1:] if name[:1] in ("~", "_") else name


_IGNORE_MARKERS = ("CATKIN_IGNORE", "COLCON_IGNORE", "AMENT_IGNORE")


# ---------------------------------------------------------------------------
# Lookup: packages and their executables, as rosrun finds them
# ---------------------------------------------------------------------------


def _workspaces() -> list[Path]:
    """Catkin workspaces in overlay order, as ``catkin.workspace.get_workspaces`` lists them."""
    paths = [Path(p) for p in os.environ.get("CMAKE_PREFIX_PATH", "").split(os.pathsep) if p]
    found = [p for p in paths if (p / ".catkin").is_file()]
    return found + [Path("/usr")] if Path("/usr") not in found else found


def _package_name(package_dir: Path) -> Optional[str]:
    """The ``<name>`` in a package.xml (rosbuild's manifest.xml: the folder's name)."""
    manifest = package_dir / "package.xml"
    if not manifest.is_file():
        return package_dir.name if (package_dir / "manifest.xml").is_file() else None
    try:
        name = ET.parse(manifest).getroot().findtext("name")
    except (ET.ParseError, OSError):
        return None
    return name.strip() if name else None


def _walk(top: Path, seen: set[str]) -> Iterable[tuple[Path, list[str], list[str]]]:
    """``os.walk`` following symlinks (as ``find -L`` does), in sorted order, without hidden
    folders, and visiting each real folder once (``seen``) so that symlink loops end.

    Like ``os.walk``, the caller may prune the ``dirs`` list it is handed.
    """
    for current, dirs, files in os.walk(top, followlinks=True):
        real = os.path.realpath(current)
        if real in seen:
            dirs.clear()
            continue
        seen.add(real)
        dirs[:] = sorted(d for d in dirs if not d.startswith("."))
        yield Path(current), dirs, sorted(files)


def _crawl(root: Path) -> Iterable[tuple[str, Path]]:
    """``(name, dir)`` of every package below ``root``, the way rospack crawls.

    A package's own subfolders are not searched for more packages; folders marked
    CATKIN_IGNORE are skipped, and ``rospack_nosubdirs`` stops the descent.
    """
    for here, dirs, _files in _walk(root, set()):
        name = _package_name(here)
        if name or any((here / m).exists() for m in (*_IGNORE_MARKERS, "rospack_nosubdirs")):
            dirs.clear()
            if name and not any((here / m).exists() for m in _IGNORE_MARKERS):
                yield name, here


def _is_ros_share_dir(share: Path) -> bool:
    """Whether ``<ws>/share/<name>`` belongs to a ROS package (not just any /usr/share folder).

    Debian's runtime-only packages (e.g. ``topic-tools``) ship no package.xml, only a
    catkin env hook or cmake config next to their executables in ``/usr/lib/<name>``.
    """
    return any((share / m).exists() for m in ("package.xml", "catkin_env_hook", f"cmake/{share.name}Config.cmake"))


@functools.lru_cache(maxsize=4)
def _index(env_key: tuple[str, str]) -> dict[str, Path]:
    """Package name → package dir (first found wins: ROS_PACKAGE_PATH, workspaces, demo).

    ``env_key`` is only there to key the cache on the environment that shaped it.
    Packages with only a libexec dir map to their ``<ws>/share/<name>`` marker folder.
    """
    found: dict[str, Path] = {}
    for root in os.environ.get("ROS_PACKAGE_PATH", "").split(os.pathsep):
        if root and Path(root).is_dir():
            for name, path in _crawl(Path(root)):
                found.setdefault(name, path)
    for ws in _workspaces():
        share = ws / "share"
        for lib_dir in sorted((ws / "lib").glob("*/")):
            if _is_ros_share_dir(share / lib_dir.name):
                found.setdefault(_package_name(share / lib_dir.name) or lib_dir.name, share / lib_dir.name)
        for manifest in sorted(share.glob("*/package.xml")):
            name = _package_name(manifest.parent)
            if name:
                found.setdefault(name, manifest.parent)
    found.setdefault(_package_name(DEMO_DIR) or "ipyros_demo", DEMO_DIR)
    return found


def _env_key() -> tuple[str, str]:
    return os.environ.get("ROS_PACKAGE_PATH", ""), os.environ.get("CMAKE_PREFIX_PATH", "")


def _search_dirs(package: str) -> list[Path]:
    """Where rosrun looks for ``package``'s executables: catkin libexec/share dirs, then its package dir.

    Like ``catkin_find --without-underlays --libexec --share``, only the first workspace
    that has the package counts; a libexec dir counts even for a package rospack does not
    know (Debian ships some, like ``roslib``, without any package.xml).
    """
    dirs: list[Path] = []
    for ws in _workspaces():
        dirs = [d for d in (ws / "lib" / package, ws / "share" / package) if d.is_dir()]
        if dirs:
            break
    package_dir = _index(_env_key()).get(package)
    if package_dir is not None and package_dir.is_dir():
        dirs.append(package_dir)
    unique: dict[str, Path] = {}
    for d in dirs:
        unique.setdefault(os.path.realpath(d), d)
    return list(unique.values())


@functools.lru_cache(maxsize=256)
def _executables(package: str, env_key: tuple[str, str]) -> dict[str, tuple[Path, ...]]:
    """Basename → executable files of ``package``, searched like rosrun's ``find -L``.

    Folders named ``build`` right below a package dir (rosrun skips them) and hidden
    folders are not searched; symlink loops are cut by remembering real paths.
    """
    found: dict[str, list[Path]] = {}
    seen: set[str] = set()
    for top in _search_dirs(package):
        for here, dirs, files in _walk(top, seen):
            if here == top and "build" in dirs:
                dirs.remove("build")
            for f in files:
                if is_executable_file(here / f):
                    found.setdefault(f, []).append(here / f)
    return {name: tuple(paths) for name, paths in sorted(found.items())}


def refresh_packages() -> None:
    """Forget the cached package index (e.g. after installing or creating a package)."""
    _index.cache_clear()
    _executables.cache_clear()


def list_packages() -> list[str]:
    """Names of the ROS packages rosrun could run something from (cached; for completion)."""
    return sorted(_index(_env_key()))


def list_executables(package: str) -> list[str]:
    """Names of ``package``'s executables (cached; for completion); ``[]`` for an unknown package."""
    return list(_executables(package, _env_key()))


#: The calls that name a node in Python code (rospy: ``init_node``): what a basenode's own name is read from.
NODE_CALLS = ("init_node",)


def own_node_name(base: BaseModel) -> Optional[str]:
    """The name the basenode's Python code gives its node, read from its file (never run), or None."""
    return basenode.own_node_name(base, find_executable, NODE_CALLS)


def find_executable(package: str, executable: str) -> Path:
    """The file ``rosrun package executable`` would run.

    ``executable`` may also be a path relative to the package dir (``scripts/talker``),
    as rosrun allows. Raises :class:`BaseNodeError` naming close matches when the
    package or executable is unknown, or when the name is ambiguous.
    """
    if not package or not executable:
        raise BaseNodeError(
            "a basenode needs a package and an executable, e.g. basePackage('topic_tools') and baseNode('relay')"
        )
    refuse_path_with_package(executable)
    for fresh in (False, True):  # the second try forgets the caches: something new may have appeared
        if fresh:
            refresh_packages()
        if "/" in executable:  # rosrun takes a path as relative to the package dir
            package_dir = _index(_env_key()).get(package)
            if package_dir is not None and is_executable_file(package_dir / executable):
                return _inside(package_dir, package_dir / executable, package, executable)
            continue
        candidates = _executables(package, _env_key()).get(executable)
        if candidates:
            return _pick(package, executable, candidates)
    raise _lookup_error(package, executable)


def _inside(package_dir: Path, path: Path, package: str, executable: str) -> Path:
    """``path``, if it lies inside ``package_dir`` (after links and ``..``): a package runs only its own files."""
    if not os.path.realpath(path).startswith(os.path.realpath(package_dir) + os.sep):
        raise BaseNodeError(f"{executable!r} leads out of package {package!r} ({os.path.realpath(path)}); name an "
                            f"executable inside it, or run a file by its path with no package: baseNode('/path/to/node')")
    return path


def _pick(package: str, executable: str, candidates: tuple[Path, ...]) -> Path:
    """One of several same-named files: rosrun prefers a catkin libexec one over a share/source one."""
    if len(candidates) == 1:
        return candidates[0]
    # links to one file are that file (ipyros_demo lists its scripts again in its ament prefix, demo/ament)
    if len({os.path.realpath(p) for p in candidates}) == 1:
        return next((p for p in candidates if not p.is_symlink()), candidates[0])
    libexec = [p for p in candidates if any(p.is_relative_to(ws / "lib" / package) for ws in _workspaces())]
    if len(libexec) == 1:
        return libexec[0]
    raise BaseNodeError(
        f"package {package!r} has several executables named {executable!r} ({', '.join(map(str, candidates))}): "
        "name one by its path relative to the package, e.g. 'scripts/" + executable + "'"
    )


def _lookup_error(package: str, executable: str) -> BaseNodeError:
    if not _search_dirs(package):
        hint = did_you_mean(package, list_packages())
        return BaseNodeError(
            f"unknown ROS package {package!r}: " + (hint or "check the name with `rospack list`")
            + " (packages are searched in ROS_PACKAGE_PATH, the catkin workspaces and ipyros_demo)"
        )
    names = list_executables(package)
    hint = did_you_mean(executable.rsplit("/", 1)[-1], names)
    listing = f"its executables: {', '.join(names)}" if names else "it has no executable files"
    return BaseNodeError(f"package {package!r} has no executable {executable!r}: {hint + ' ' if hint else ''}{listing}")


def link_outside(package: str, path: Path) -> Optional[str]:
    """Where ``path``, an executable found in ``package``, really is, if a link takes it out of the package.

    rosrun follows such links (``find -L``), and so does ipyros: a package may well link to a
    program installed elsewhere. But what runs is then not the package's own file, so it is
    said.
    """
    real = os.path.realpath(path)
    homes = [os.path.realpath(d) + os.sep for d in _search_dirs(package)]
    if not homes or any(real.startswith(home) for home in homes):
        return None
    return real

