"""A workspace's own ``.msg`` and ``.srv`` files made importable at the prompt, without catkin (ROS 1).

catkin builds a message package's Python classes with genpy; Debian's ROS packages ship
those classes but not their ``.msg`` files. So the definitions a new package uses
(``std_msgs/Header``, ``geometry_msgs/Point``) are written back from the installed classes,
whose ``_full_text`` holds each one, and genpy generates the new package's classes from
them into a folder of its own, which this process (and every process it starts) imports from.
"""

from __future__ import annotations

import os
import re
import tempfile
from pathlib import Path

from ..core import msgtypes
from ..core.errors import MessageTypeError

__all__ = ["build_messages"]

_SEPARATOR = re.compile(r"^={10,}\s*$", re.M)
_BUILTIN = {"bool", "byte", "char", "int8", "uint8", "int16", "uint16", "int32", "uint32", "int64", "uint64",
            "float32", "float64", "string", "time", "duration"}


def build_messages(package_dir: "str | os.PathLike[str]", into: "str | os.PathLike[str] | None" = None) -> list[str]:
    """Generate the Python classes of the package at ``package_dir`` (its ``msg/*.msg`` and ``srv/*.srv``).

    They are written under ``into`` (default ``$IPYROS_MESSAGES_DIR``, else ``~/.ipyros/messages``),
    which is put first on ``sys.path`` and ``PYTHONPATH``: ``from my_robot_msgs.msg import Status``
    works at once, here and in the basenodes started after. Returns the types built (``pkg/Type``).
    """
    import genpy.generate_initpy
    import genpy.generator
    from genmsg import MsgContext

    package_dir = Path(package_dir).expanduser().resolve()
    package = msgtypes.package_name_of(package_dir)
    files = {kind: sorted((package_dir / kind).glob(f"*.{kind}")) for kind in ("msg", "srv")}
    if not any(files.values()):
        raise MessageTypeError(f"{package_dir} has no msg/*.msg or srv/*.srv files; give the folder of a message "
                               "package (the one with package.xml, msg/ and srv/)")
    root = msgtypes.messages_dir(into)
    built: list[str] = []
    with tempfile.TemporaryDirectory(prefix="ipyros-msgdeps-") as deps:
        search = _dependencies(package, [f for kind in files.values() for f in kind], Path(deps))
        search[package] = [str(package_dir / "msg")]
        for kind, generator in (("msg", genpy.generator.MsgGenerator()), ("srv", genpy.generator.SrvGenerator())):
            if not files[kind]:
                continue
            out = root / package / kind
            out.mkdir(parents=True, exist_ok=True)
            context = MsgContext.create_default()
            for path in files[kind]:
                full = f"{package}/{path.stem}"
                try:
                    generator.generate(context, full, str(path), str(out), search)
                except Exception as error:  # genmsg's and genpy's own: the file and the line they name
                    raise MessageTypeError(f"cannot build {full} from {path}: {str(error).strip()}") from None
                built.append(full)
            genpy.generate_initpy.write_modules(str(out))
        (root / package / "__init__.py").touch()
    msgtypes.import_from(root)
    return built


def _dependencies(package: str, files: list[Path], folder: Path) -> dict[str, list[str]]:
    """Write the definitions the files use, from the installed classes, as ``folder/<pkg>/msg/<Type>.msg``;
    genpy's search path for them (``{pkg: [dir]}``)."""
    search: dict[str, list[str]] = {}
    for used in sorted({t for path in files for t in _used_types(path.read_text(errors="replace"))}):
        if used.split("/")[0] == package:
            continue
        try:
            _, cls = msgtypes.resolve_message(used)
        except MessageTypeError as error:
            raise MessageTypeError(f"{used}, which this package's messages use, is not installed here ({error}); "
                                   "install it first") from None
        for section in _SEPARATOR.split(cls._full_text):
            text = section.strip("\n")
            if text.startswith("MSG: "):  # a definition it uses in turn
                name, _, body = text[5:].partition("\n")
            else:
                name, body = cls._type, text
            pkg, _, stem = name.strip().partition("/")
            target = folder / pkg / "msg"
            target.mkdir(parents=True, exist_ok=True)
            (target / f"{stem}.msg").write_text(body + "\n")
            search.setdefault(pkg, [str(target)])
    return search


def _used_types(text: str) -> set[str]:
    """The message types a ``.msg``/``.srv`` text names in its fields (``Header`` is ``std_msgs/Header``)."""
    found = set()
    for line in text.splitlines():
        words = line.split("#", 1)[0].split()
        if len(words) < 2 or words[0] == "---" or "=" in words[1]:
            continue
        base = words[0].split("[", 1)[0]
        if base in _BUILTIN:
            continue
        found.add("std_msgs/Header" if base == "Header" else base)
    return {t for t in found if "/" in t}
