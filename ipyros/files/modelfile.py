"""The node model file: a DSL node as YAML or JSON (its model plus its handlers' sources), and loading it back.

    ipyros_node_format: 1
    node: {name: ..., topics: [...], timers: [...], services: [...], params: {...}}
    handlers:
    - slot: topic /turtle1/pose          # the handler's slot key (see ipyros.core.plan)
      name: showPose
      imports: [from turtlesim.msg import Pose]   # what its global names were bound to
      source: |
        def showPose(data): ...

The format is in docs/model.md. Here: writing it (:func:`save`), reading it back checked
for shape (:func:`read`), refusing what it would run unless trusted, and defining its
handlers in a namespace (:func:`handlers_of`: IPython's ``user_ns``, so the handlers see
the user's globals and stay editable with ``%handler``). The DSL replays the declarations
(:mod:`ipyros.dsl.keeping`), so that every check applies as if typed. A model file looks
like data and travels like data: what it would run (handler code, a basenode) runs only
with ``trust=True``.

A saved file keeps code, not state: the values of the handlers' other globals (``speed``)
and helper functions they call come from the namespace they are loaded into.
"""

from __future__ import annotations

import json
import os
import shlex
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Callable, Iterable, Iterator, Optional

import yaml

from ..core import plan as planning
from ..core.code import (
    WRITER,
    define_function,
    global_names,
    handler_slots,
    handler_source,
    import_of,
    import_statement,
    lookup,
)
from ..core.errors import DataError, IpyrosError
from ..core.model import NodeModel
from ..core.userdata import load_json, load_yaml
from .atomic import write_atomic
from .kept import KeptNode

__all__ = ["FORMAT", "FORMAT_KEY", "MODEL_SUFFIXES", "ModelFile", "handler_sources", "handlers_of", "read", "save"]

FORMAT_KEY = "ipyros_node_format"
FORMAT = 1


# -- handlers and their source --------------------------------------------------------------

# -- files ------------------------------------------------------------------------------------

class _Dumper(yaml.SafeDumper):
    """Multi-line strings (handler sources) as YAML literal blocks: readable, and diffs line by line."""


_Dumper.add_representer(str, lambda dumper, text: dumper.represent_scalar(
    "tag:yaml.org,2002:str", text, style="|" if "\n" in text else None))


# -- save -------------------------------------------------------------------------------------

MODEL_SUFFIXES = ("yaml", "yml", "json")


def handler_sources(nodes: Iterable[KeptNode], namespace: Optional[dict] = None) -> dict[tuple[int, str], str]:
    """``(id(node), slot) → source`` of every handler of ``nodes`` (a list's method in ``namespace``: the lambda
    that calls it, see :func:`~ipyros.core.code.handler_source`).

    A handler without source fails it, and the error names every such handler, so
    nothing is saved with a handler silently missing.
    """
    sources, missing = {}, []
    for node in nodes:
        for slot, label in handler_slots(node.model()):
            fn = node.handlers()[slot]
            try:
                sources[(id(node), slot)] = handler_source(fn, f"{node.name} {label}", namespace)
            except IpyrosError as error:
                missing.append(str(error).split("; ")[0])  # names the handler and why
    if missing:
        raise IpyrosError(f"nothing saved: {'; '.join(missing)}; define "
                          f"{'them' if len(missing) > 1 else 'it'} with def (at the prompt or in a file), "
                          "declare again, then save")
    return sources


def save(node: KeptNode, path: "str | os.PathLike[str]", ros: str) -> Path:
    """Save ``node``'s model and its handlers' sources to ``path`` (YAML, or JSON for ``.json``); ``ros`` says
    which ROS made it (``"ROS 1"``), so that loading it on the other can say what differs."""
    model = node.model()
    sources = handler_sources([node])
    entries = []
    for slot, _ in handler_slots(model):
        fn, source = node.handlers()[slot], sources[(id(node), slot)]
        origins = {n: import_of(lookup(n, fn, None), fn.__module__) for n in global_names(source)}
        entry: dict[str, Any] = {"slot": slot, "name": fn.__name__}
        imports = [import_statement(n, o) for n, o in origins.items() if o is not None]
        if imports:
            entry["imports"] = imports
        entries.append({**entry, "source": source})
    data = {FORMAT_KEY: FORMAT, "ros": ros, "node": model.to_dict(), "handlers": entries}
    if str(path).lower().endswith(".json"):
        return write_atomic(path, json.dumps(data, indent=2, ensure_ascii=False) + "\n")
    return write_atomic(path, yaml.dump(data, Dumper=_Dumper, sort_keys=False, allow_unicode=True, width=100))


# -- load -------------------------------------------------------------------------------------

@dataclass(frozen=True)
class ModelFile:
    """A model file read back: the node's model, its handlers' entries (slot, name, imports, source), and the
    ROS that made it (None in files older than that key)."""

    path: Path
    model: NodeModel
    handlers: list[dict]
    made_on: Optional[str]

    @property
    def writers(self) -> set[str]:
        """The names the handlers call ``.write`` on (``nd.write(...)``): the node they were written for."""
        return {name for entry in self.handlers for name in WRITER.findall(entry["source"])}


def read(path: "str | os.PathLike[str]", trust: bool = False) -> ModelFile:
    """The model file ``path``, checked for shape; refused, in one line, if it would run anything untrusted.

    A model file looks like data and travels like data, so the code in it (imports and
    handler sources) and the basenode it names run only when asked: ``trust=True``.
    Without it, a file that carries either is refused, naming what would run; a model
    without code (its handlers taken by name from the namespace) loads as it is.
    """
    path = Path(path).expanduser()
    data = _read(path)
    if not trust:
        _refuse_untrusted(path, data)
    try:
        model = NodeModel.from_dict(data["node"])
    except (TypeError, ValueError, AttributeError) as error:
        raise IpyrosError(f"{path}: the node is malformed: {error}") from None
    return ModelFile(path, model, data["handlers"], data.get("ros"))


def handlers_of(file: ModelFile, namespace: dict) -> dict[str, Callable[..., Any]]:
    """Slot → function: each handler's imports and source run in ``namespace``, and the handlers the file
    names without source found there by name."""
    functions = {entry["slot"]: _define(file.path, entry, namespace) for entry in file.handlers}
    functions.update(_by_name(file.path, file.model, functions, namespace))
    return functions


def _refuse_untrusted(path: Path, data: dict) -> None:
    """Refuse, in one line saying what would run, a model file that would run anything: code, or a process.

    A model file looks like data and travels like data (an attachment, a repository), so
    loading it runs nothing unless asked: not the handlers' sources and imports, and not a
    basenode either, which is a program started with the user's rights (a launch file, a
    bag, ``/bin/sh -c ...``: whatever ``base`` names). A model of topics, timers, services and
    parameters whose handlers are found by name in the namespace loads without trust.
    """
    would = []
    if data["handlers"]:
        imports = sorted({line for entry in data["handlers"] for line in entry.get("imports") or []})
        would.append((f"imports {'; '.join(imports)} and " if imports else "") + "the handlers "
                     + ", ".join(entry["name"] for entry in data["handlers"]))
    base = data["node"].get("base")
    if base is not None:
        would.append(f"the basenode {_command_of(base)}")
    if would:
        raise IpyrosError(f"{path} would run {' and '.join(would)}; read it, and if you trust it load it with "
                          f"trust=True (rosNode.load({str(path)!r}, trust=True), %load_nodes --trust)")


def _command_of(base: Any) -> str:
    """What a model file's ``base`` would start, in words: a launch file's node, a package's executable, a file."""
    if not isinstance(base, dict):
        return repr(base)[:80]
    args: list[Any] = base["args"] if isinstance(base.get("args"), list) else []
    line = " ".join(shlex.quote(str(word)) for word in [base.get("executable") or "?", *args])
    if len(line) > 200:
        line = line[:197] + "..."
    if base.get("launch"):
        return f"{base.get('launch_node') or '?'} of the launch file {base['launch']} (and the rest of that file)"
    if base.get("package"):
        return f"{line} of package {base['package']}"
    return line


def _by_name(path: Path, model: NodeModel, functions: dict[str, Any], namespace: dict) -> dict[str, Any]:
    """Handlers a model file declares without their source: found by name in ``namespace``."""
    wanted = {slot: name for slot, name in _slot_handlers(model) if slot not in functions}
    found = {slot: namespace[name] for slot, name in wanted.items() if callable(namespace.get(name))}
    lacking = sorted({name for slot, name in wanted.items() if slot not in found})
    if lacking:
        raise IpyrosError(f"{path} has no source for handler(s) {', '.join(lacking)} and they are not defined here; "
                          "define them first (def name(msg): ...), then load")
    return found


def _slot_handlers(model: NodeModel) -> Iterator[tuple[str, str]]:
    """``(slot key, handler name)`` of every handler the model declares."""
    names = {planning.topic_slot(t.resolved): t.handler for t in model.topics if t.handler}
    names.update({planning.service_slot(s.resolved): s.handler for s in model.services if s.role == "new" and s.handler})
    names.update({planning.action_slot(a.resolved): a.handler for a in model.actions if a.role == "new" and a.handler})
    names.update({planning.timer_slot(t.name): t.handler for t in model.timers})
    for slot, _ in handler_slots(model):
        yield slot, names[slot] or "?"


def _read(path: Path) -> dict:
    """The file's data, checked for shape; every problem is one line naming the file."""
    try:
        text = path.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as error:
        raise IpyrosError(f"cannot read {path}: {getattr(error, 'strerror', None) or error}") from None
    try:
        data = (load_json if path.suffix.lower() == ".json" else load_yaml)(text, str(path))
    except DataError as error:
        raise IpyrosError(str(error)) from None
    if not isinstance(data, dict) or FORMAT_KEY not in data:
        raise IpyrosError(f"{path} is not a saved ipyros node (no {FORMAT_KEY}: key); save one with nd.save(path)")
    if data[FORMAT_KEY] != FORMAT:
        raise IpyrosError(f"{path} has format version {data[FORMAT_KEY]!r}, this ipyros reads version {FORMAT}")
    data.setdefault("handlers", [])  # a model without code: handlers are found by name when loaded
    for key, kind in (("node", dict), ("handlers", list)):
        if not isinstance(data.get(key), kind):
            raise IpyrosError(f"{path}: missing or malformed key {key!r} (a {kind.__name__} is expected)")
    for i, entry in enumerate(data["handlers"]):
        missing = [k for k in ("slot", "name", "source") if not isinstance(entry, dict) or
                   not isinstance(entry.get(k), str)]
        if missing:
            raise IpyrosError(f"{path}: handler #{i + 1} lacks {', '.join(missing)}")
    return data


def _define(path: Path, entry: dict, namespace: dict) -> Callable[..., Any]:
    """Run one handler's imports and source in ``namespace``; return the function it defines."""
    name, source = entry["name"], entry["source"]
    what = f"{path}: handler {name} ({entry['slot']})"
    for statement in entry.get("imports") or []:
        bound = statement.split()[-1].split(".")[0]
        if bound not in namespace:
            try:
                exec(statement, namespace)  # noqa: S102 - an import line the file names
            except Exception as error:  # noqa: BLE001 - any failure is the file's problem, told in one line
                raise IpyrosError(f"{what} needs `{statement}`, which fails: {error}") from None
    return define_function(name, source, namespace, what, f"<ipyros {path.name}: {name}>")
