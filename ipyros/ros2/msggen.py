"""A workspace's own ``.msg``, ``.srv`` and ``.action`` files made importable at the prompt, without colcon (ROS 2).

On ROS 2 a message type is Python classes *and* C type support: rclpy hands messages to
the middleware through compiled libraries. colcon builds them with CMake; here the same
rosidl generators (on PyPI, installed with rclpy) write the same C and Python sources, and
the machine's C compiler builds them against the headers and libraries the wheels
installed, as ``rosidl_generate_interfaces`` would:

==============================================  =============================================
library (under ``<into>/lib``)                  what it is
==============================================  =============================================
``lib<pkg>__rosidl_generator_c.so``             the C structs and their functions
``lib<pkg>__rosidl_typesupport_introspection_c``  field layout, for generic readers
``lib<pkg>__rosidl_typesupport_fastrtps_c.so``  serialisation for Fast DDS
``lib<pkg>__rosidl_typesupport_c.so``           the dispatch rmw asks, which loads the above
``lib<pkg>__rosidl_generator_py.so``            Python object ⇄ C struct conversion
==============================================  =============================================

and the Python package under ``<into>/python/<pkg>``, with its three ``<pkg>_s__*.so``
extension modules. ``<into>/python`` goes on ``sys.path`` and ``PYTHONPATH``,
``<into>/lib`` on ``LD_LIBRARY_PATH`` (read when the dispatch looks a library up), so the
types work at once, here and in the processes started after. A build takes a few seconds.
"""

from __future__ import annotations

import contextlib
import ctypes
import importlib
import importlib.util
import io
import itertools
import os
import re
import shutil
import subprocess
import sys
import sysconfig
import tempfile
from pathlib import Path
from typing import Any, Callable

from ..core import msgtypes
from ..core.errors import IpyrosError, MessageTypeError
from ..core.progress import Progress, no_progress
from . import nodes

__all__ = ["build_from_node", "build_messages"]

#: The generators, each writing into a folder of its own (the key), and the libraries built from what they write.
_GENERATORS = {"c": "rosidl_generator_c", "ts_c": "rosidl_typesupport_c",
               "introspection_c": "rosidl_typesupport_introspection_c",
               "fastrtps_c": "rosidl_typesupport_fastrtps_c", "py": "rosidl_generator_py"}
_KINDS = {"msg": ".msg", "srv": ".srv", "action": ".action"}  # and .idl in each, as a node's type description gives
#: What services and actions use beside the package's own fields (their event and goal messages).
_IMPLIED = {"srv": ("service_msgs", "builtin_interfaces"),
            "action": ("action_msgs", "unique_identifier_msgs", "builtin_interfaces", "service_msgs")}
_INCLUDE = re.compile(r'^#include "(\w+)/(?:msg|srv|action)/\w+\.idl"', re.M)
#: What a build does, in the steps its progress counts: each generator run, then each library compiled (the C
#: structs, three type supports, the Python conversion, and the Python package's three extension modules).
_STEPS = len(_GENERATORS) + 8


def build_messages(package_dir: "str | os.PathLike[str]", into: "str | os.PathLike[str] | None" = None,
                   progress: Progress = no_progress) -> list[str]:
    """Build the package at ``package_dir`` (its ``msg/``, ``srv/``, ``action/``) and make it importable.

    Built under ``into`` (default ``$IPYROS_MESSAGES_DIR``, else ``~/.ipyros/messages``, in
    a ``ros2`` folder), its ``progress`` counted in generator runs and libraries compiled (a few seconds).
    Returns the types built (``pkg/Type``).
    """
    package_dir = Path(package_dir).expanduser().resolve()
    package = msgtypes.package_name_of(package_dir)
    files = [path for kind in _KINDS if (package_dir / kind).is_dir()
             for path in sorted((package_dir / kind).iterdir()) if path.suffix in (_KINDS[kind], ".idl")]
    if not files:
        raise MessageTypeError(f"{package_dir} has no msg/*.msg, srv/*.srv or action/*.action files; give the "
                               "folder of a message package (the one with package.xml and msg/)")
    compilers = [shutil.which("gcc"), shutil.which("g++")]
    if not all(compilers) or not (Path(sysconfig.get_paths()["include"]) / "Python.h").is_file():
        raise MessageTypeError("building ROS 2 message types needs a C compiler and Python's headers: "
                               f"apt-get install gcc g++ python3-dev (for {sys.executable}), then build again")
    missing = [name for name in ("catkin_pkg", *_GENERATORS.values()) if importlib.util.find_spec(name) is None]
    if missing:
        raise MessageTypeError(f"building ROS 2 message types needs {', '.join(missing)} in this Python: pip install "
                               f"{' '.join(n if n == 'catkin_pkg' else 'ros-' + n.replace('_', '-') for n in missing)}")
    _check_field_types(package, files)
    root = msgtypes.messages_dir(into) / "ros2"
    with tempfile.TemporaryDirectory(prefix="ipyros-rosidl-") as work, \
            progress(f"building {package}'s message types", _STEPS, "steps") as step:
        out = Path(work)
        steps = itertools.count(1)

        def advance() -> None:
            step(next(steps))

        _generate(package, package_dir, files, out, advance)
        libs, python = root / "lib", root / "python" / package
        shutil.rmtree(python, ignore_errors=True)
        libs.mkdir(parents=True, exist_ok=True)
        _compile(package, _dependencies(package, out, files), out, libs, python, advance)
    _import_from(root, package)
    return [f"{package}/{path.stem}" for path in files]


_BUILTIN = {"bool", "byte", "char", "float32", "float64", "int8", "uint8", "int16", "uint16", "int32", "uint32",
            "int64", "uint64", "string", "wstring"}


def _check_field_types(package: str, files: list[Path]) -> None:
    """Refuse, naming the file and the type, a field whose type is neither built in nor the package's own.

    rosidl takes such a name for one of the package's own and fails later with a missing file;
    the usual case is ROS 1's ``Header``, which ROS 2 spells ``std_msgs/Header``.
    """
    own = {path.stem for path in files if path.parent.name == "msg"}
    for path in (f for f in files if f.suffix != ".idl"):  # IDL names every type in full
        for line in path.read_text(errors="replace").splitlines():
            words = line.split("#", 1)[0].split()
            if len(words) < 2 or words[0] == "---" or "=" in words[1] or "=" in words[0]:
                continue
            base = re.split(r"[\[<]", words[0], maxsplit=1)[0]
            if "/" in base or base in _BUILTIN or base in own:
                continue
            spelled = "std_msgs/Header" if base == "Header" else f"its_package/{base}"
            raise MessageTypeError(f"cannot build {package}/{path.stem} from {path}: {base} is neither a built-in "
                                   f"type nor a message of {package}; ROS 2 names another package's type with "
                                   f"its package ({spelled})")


def _generate(package: str, package_dir: Path, files: list[Path], out: Path, advance: Callable[[], None]) -> None:
    """Each generator's sources for the package under ``out/<key>/<package>``; its one-line error if one fails."""
    interface_files = [f"{package_dir}:{path.relative_to(package_dir)}" for path in files]
    # where the types the package uses are found: every installed package that has .idl files
    shares = [str(folder) for prefix in nodes.prefixes() if (prefix / "share").is_dir()
              for folder in (prefix / "share").iterdir() if any(folder.glob("*/*.idl"))]
    chatter = io.StringIO()  # the generators print each file they read and write, and rosidl_cli its entry points
    for key, generator in _GENERATORS.items():
        module = importlib.import_module(f"{generator}.cli")
        name = next(n for n in dir(module) if n.startswith("Generate") and n != "GenerateCommandExtension")
        try:
            with contextlib.redirect_stdout(chatter), contextlib.redirect_stderr(chatter):
                getattr(module, name)(name).generate(package, interface_files, shares, out / key / package)
        except Exception as error:  # noqa: BLE001 - rosidl's parsers raise plain exceptions naming the file
            raise MessageTypeError(f"cannot build {package} from {package_dir}: {' '.join(str(error).split())}") \
                from None
        advance()


def _dependencies(package: str, out: Path, files: list[Path]) -> list[str]:
    """The message packages the built types use: named in the generated ``.idl`` files, and what a service or
    action always uses."""
    idls = [*(out / "c" / package).rglob("*.idl"), *(path for path in files if path.suffix == ".idl")]
    used = {found for idl in idls for found in _INCLUDE.findall(idl.read_text())}
    for path in files:
        used.update(_IMPLIED.get(path.parent.name, ()))
    used.discard(package)
    missing = sorted(p for p in used if nodes.package_prefix(p) is None)
    if missing:
        raise MessageTypeError(f"{package} uses {', '.join(missing)}, not installed here: pip install "
                               f"{' '.join('ros-' + p.replace('_', '-') for p in missing)}, then build again")
    return sorted(used)


def _compile(package: str, deps: list[str], out: Path, libs: Path, python: Path, advance: Callable[[], None]) -> None:
    """The five libraries into ``libs``, the Python package (sources and extension modules) into ``python``."""
    import numpy

    prefixes = nodes.prefixes()
    includes = [f"-I{out / key}" for key in _GENERATORS] + [f"-I{sysconfig.get_paths()['include']}",
                                                            f"-I{numpy.get_include()}"]
    for prefix in prefixes:
        if (prefix / "include").is_dir():
            includes += [f"-I{prefix / 'include'}", *(f"-I{d}" for d in (prefix / "include").iterdir() if d.is_dir())]
    searched = [libs, *(prefix / "lib" for prefix in prefixes if (prefix / "lib").is_dir())]

    def build(target: Path, sources: list[Path], links: list[str], cxx: bool = False) -> None:
        command = ["g++" if cxx else "gcc", "-shared", "-fPIC", "-O2", "-w", "-o", str(target), *map(str, sources),
                   *includes, *(f"-L{d}" for d in searched), *(f"-l{lib}" for lib in links),
                   f"-Wl,-rpath,{':'.join(map(str, searched))}", f"-Wl,-soname,{target.name}"]
        done = subprocess.run(command, capture_output=True, text=True)
        if done.returncode != 0:
            first = next((line for line in done.stderr.splitlines() if "error" in line), done.stderr.strip()[-300:])
            raise MessageTypeError(f"cannot compile {target.name} for {package}: {first.strip()}")
        advance()

    def sources(key: str, pattern: str) -> list[Path]:
        return sorted(p for p in (out / key / package).rglob(pattern) if "_s.ep." not in p.name)

    def each(kind: str) -> list[str]:
        return [f"{dep}__{kind}" for dep in deps]

    c = f"{package}__rosidl_generator_c"
    build(libs / f"lib{c}.so", sources("c", "*.c"), [*each("rosidl_generator_c"), "rosidl_runtime_c", "rcutils"])
    for kind, key, runtime, cxx in (
            ("rosidl_typesupport_introspection_c", "introspection_c", "rosidl_typesupport_introspection_c", False),
            ("rosidl_typesupport_fastrtps_c", "fastrtps_c", "rosidl_typesupport_fastrtps_c", True),
            ("rosidl_typesupport_c", "ts_c", "rosidl_typesupport_c", True)):
        pattern = "*.cpp" if cxx else "*.c"
        build(libs / f"lib{package}__{kind}.so", sources(key, pattern),
              [c, *each(kind), runtime, *(["fastcdr", "rcutils"] if key == "fastrtps_c" else []), "rosidl_runtime_c"],
              cxx)
    py = f"{package}__rosidl_generator_py"
    build(libs / f"lib{py}.so", sources("py", "*.c"), [c, *each("rosidl_generator_py"), "rosidl_runtime_c"])
    generated = out / "py" / package
    shutil.copytree(generated, python, ignore=shutil.ignore_patterns("*.c", "tmp"))
    (python / "__init__.py").touch()
    for kind in ("rosidl_typesupport_c", "rosidl_typesupport_introspection_c", "rosidl_typesupport_fastrtps_c"):
        build(python / f"{package}_s__{kind}.so", [generated / f"_{package}_s.ep.{kind}.c"],
              [py, f"{package}__{kind}", c, "rosidl_runtime_c"])


def _import_from(root: Any, package: str) -> None:
    """Make the built packages importable here and in the processes started from here.

    The type support dispatch loads a library by its bare name (``dlopen``), which searches the
    ``LD_LIBRARY_PATH`` this process started with: here the package's libraries are loaded
    first, and a library already loaded under that name (its soname) is the one found.
    Processes started from here find them on their ``LD_LIBRARY_PATH``.
    """
    libs = root / "lib"
    parts = [p for p in os.environ.get("LD_LIBRARY_PATH", "").split(os.pathsep) if p and p != str(libs)]
    os.environ["LD_LIBRARY_PATH"] = os.pathsep.join([str(libs), *parts])
    for kind in ("rosidl_generator_c", "rosidl_typesupport_introspection_c", "rosidl_typesupport_fastrtps_c",
                 "rosidl_typesupport_c", "rosidl_generator_py"):
        ctypes.CDLL(str(libs / f"lib{package}__{kind}.so"), mode=ctypes.RTLD_GLOBAL)
    msgtypes.import_from(root / "python")


# -- a type that only a running node has -------------------------------------------------------

def build_from_node(process: Any, node: str, wanted: dict[str, str], into: "str | os.PathLike[str] | None" = None,
                    patience: float = 5.0, progress: Progress = no_progress) -> list[str]:
    """Build the types ``wanted`` (``pkg/Type`` → a topic ``node`` uses it on) from ``node``'s own descriptions.

    A ROS 2 node answers ``~/get_type_description`` (REP 2011) with each type's definition as
    it was built (``type_sources``: IDL or ``.msg``), and those of the types it uses. Those of
    packages no ament prefix here has are written as a package and built (:func:`build_messages`);
    a package the machine has is never built again. ``process`` is the session's
    :class:`~ipyros.ros2.runtime.ProcessNode`. Returns the types built.
    """
    from type_description_interfaces.srv import GetTypeDescription

    from .introspect import call

    graph = process.graph()
    sources: dict[str, tuple[str, str]] = {}  # pkg/msg/Type: (encoding, text)
    for type_name, topic in sorted(wanted.items()):
        full = type_name if type_name.count("/") == 2 else type_name.replace("/", "/msg/", 1)
        hashes = [str(e.topic_type_hash) for e in (*graph.get_publishers_info_by_topic(topic),
                                                    *graph.get_subscriptions_info_by_topic(topic))
                  if e.topic_type == full]
        request = GetTypeDescription.Request(type_name=full, type_hash=hashes[0] if hashes else "",
                                             include_type_sources=True)
        try:
            answer = call(process, f"{node}/get_type_description", GetTypeDescription, request, patience)
        except IpyrosError as error:
            raise MessageTypeError(f"cannot learn {type_name} from {node}: {error}; build its package with "
                                   "build_messages(folder)") from None
        if not answer.successful:
            raise MessageTypeError(f"{node} did not describe {type_name}: {answer.failure_reason}; build its "
                                   "package with build_messages(folder)")
        sources.update({s.type_name: (s.encoding, s.raw_file_contents) for s in answer.type_sources})
    missing = {name: source for name, source in sources.items()
               if nodes.package_prefix(name.split("/", 1)[0]) is None}
    packages = sorted({name.split("/", 1)[0] for name in missing})
    if len(packages) > 1:
        raise MessageTypeError(f"{node}'s types come from {len(packages)} packages this machine lacks "
                               f"({', '.join(packages)}), which ipyros builds one at a time only: build each with "
                               "build_messages(folder), those used by the others first")
    built: list[str] = []
    with tempfile.TemporaryDirectory(prefix="ipyros-described-") as work:
        for package in packages:
            for name, (encoding, text) in missing.items():
                _, kind, stem = name.split("/")
                path = Path(work) / package / kind / f"{stem}.{'idl' if encoding == 'idl' else kind}"
                path.parent.mkdir(parents=True, exist_ok=True)
                path.write_text(text)
            built += build_messages(Path(work) / package, into, progress)
    return built
