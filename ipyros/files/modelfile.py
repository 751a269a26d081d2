"""The node model file: a DSL node as YAML or JSON (its model plus its handlers' sources), and loading it back.

    ipyros_node_format: 1
    node: {name: ..., topics: [...], timers: [...], services: [...], params: {...}}
    handlers:
    - slot: topic /turtle1/pose          # the handler's slot key (see ipyros.core.plan)
      name: showPose
      imports: [from turtlesim.msg import Pose]   # what its global names were bound to
      source: |
        def showPose(data): ...

The format is in docs/model.md. :func:`load` runs each source in a namespace (IPython's
``user_ns``: the handlers see the user's globals and stay editable with ``%handler``) and
replays the declarations through the public DSL, so every check applies as if typed. A
model file looks like data and travels like data: what it would run (handler code, a
basenode) runs only with ``trust=True``.

A saved file keeps code, not state: the values of the handlers' other globals (``speed``)
and helper functions they call come from the namespace they are loaded into.
"""

from __future__ import annotations

import json
import os
import shlex
from pathlib import Path
from typing import Any, Callable, Iterable, Iterator, Optional

import yaml

from ..core import plan as planning
from ..core.errors import DataError, IpyrosError
from ..core.model import NodeModel
from ..core.userdata import load_json, load_yaml
from ..node.dsl import engine_of, rosNode
from .atomic import write_atomic
from .code import (
    WRITER,
    define_function,
    global_names,
    handler_slots,
    handler_source,
    import_of,
    import_statement,
    lookup,
)

__all__ = ["FORMAT", "FORMAT_KEY", "MODEL_SUFFIXES", "handler_sources", "load", "save"]

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


def handler_sources(nodes: Iterable[rosNode]) -> dict[tuple[int, str], str]:
    """``(id(node), slot) → source`` of every handler of ``nodes``.

    A handler without source fails it, and the error names every such handler, so
    nothing is saved with a handler silently missing.
    """
    sources, missing = {}, []
    for node in nodes:
        engine = engine_of(node)
        for slot, label in handler_slots(engine.model()):
            fn = engine.handlers()[slot]
            try:
                sources[(id(node), slot)] = handler_source(fn, f"{node.name} {label}")
            except IpyrosError as error:
                missing.append(str(error).split("; ")[0])  # names the handler and why
    if missing:
        raise IpyrosError(f"nothing saved: {'; '.join(missing)}; define "
                          f"{'them' if len(missing) > 1 else 'it'} with def (at the prompt or in a file), "
                          "declare again, then save")
    return sources


def save(node: rosNode, path: "str | os.PathLike[str]") -> Path:
    """Save ``node``'s model and its handlers' sources to ``path`` (YAML, or JSON for ``.json``)."""
    engine = engine_of(node)
    model = engine.model()
    sources = handler_sources([node])
    entries = []
    for slot, _ in handler_slots(model):
        fn, source = engine.handlers()[slot], sources[(id(node), slot)]
        origins = {n: import_of(lookup(n, fn, None), fn.__module__) for n in global_names(source)}
        entry: dict[str, Any] = {"slot": slot, "name": fn.__name__}
        imports = [import_statement(n, o) for n, o in origins.items() if o is not None]
        if imports:
            entry["imports"] = imports
        entries.append({**entry, "source": source})
    data = {FORMAT_KEY: FORMAT, "ros": engine.session.backend.name, "node": model.to_dict(), "handlers": entries}
    if str(path).lower().endswith(".json"):
        return write_atomic(path, json.dumps(data, indent=2, ensure_ascii=False) + "\n")
    return write_atomic(path, yaml.dump(data, Dumper=_Dumper, sort_keys=False, allow_unicode=True, width=100))


# -- load -------------------------------------------------------------------------------------

def load(path: "str | os.PathLike[str]", namespace: Optional[dict] = None, *,
         session: Any = None, trust: bool = False) -> rosNode:
    """Rebuild the node saved in ``path``, declared but not created.

    A model file looks like data and travels like data, so the code in it (imports and
    handler sources) runs only when asked: ``trust=True``. Without it, a file that carries
    code is refused, in one line naming what would run; a model without code (its handlers
    taken by name from ``namespace``) loads as it is. A saved ``.py`` file is code, and runs
    as Python files do (:func:`ipyros.files.savefile.restore`).

    Handler sources run in ``namespace`` (default: a fresh dict); pass IPython's
    ``user_ns`` so the handlers read the user's globals. Names the handlers call
    ``.write`` on (``nd.write(...)``) are bound to the new node if ``namespace`` lacks them.
    """
    path = Path(path).expanduser()
    namespace = {} if namespace is None else namespace
    data = _read(path)
    if not trust:
        _refuse_untrusted(path, data)
    try:
        model = NodeModel.from_dict(data["node"])
    except (TypeError, ValueError, AttributeError) as error:
        raise IpyrosError(f"{path}: the node is malformed: {error}") from None
    functions = {entry["slot"]: _define(path, entry, namespace) for entry in data["handlers"]}
    functions.update(_by_name(path, model, functions, namespace))
    node = rosNode(model.name, namespace=model.namespace, session=session)
    _across_ros(path, data.get("ros"), model, node)
    try:
        _declare(node, model, functions)
    except IpyrosError as error:
        raise type(error)(f"{path}: {error}") from None
    for entry in data["handlers"]:
        for name in WRITER.findall(entry["source"]):
            namespace.setdefault(name, node)
    return node


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
    args = base.get("args") if isinstance(base.get("args"), list) else []
    line = " ".join(shlex.quote(str(word)) for word in [base.get("executable") or "?", *args])
    if len(line) > 200:
        line = line[:197] + "..."
    if base.get("launch"):
        return f"{base.get('launch_node') or '?'} of the launch file {base['launch']} (and the rest of that file)"
    if base.get("package"):
        return f"{line} of package {base['package']}"
    return line


def _across_ros(path: Path, made_on: Optional[str], model: NodeModel, node: rosNode) -> None:
    """A model made on the other ROS: refuse what cannot run here, in one line; say what runs differently.

    The model itself is the same on both (names, types as ``pkg/Type``, QoS as data); what
    can differ is what it names: message packages and basenodes must be installed here
    (their lookups say so, in one line, if they are not), and a launch-file basenode needs
    roslaunch, which is ROS 1's.
    """
    session = engine_of(node).session
    here = session.backend.name
    if made_on in (None, here):
        return
    notes = [f"{path} was made on {made_on}; loading it on {here}"]
    kept = set(session.backend.qos_fields)  # what a declaration's QoS means on this ROS
    if any(t.qos and set(t.qos) - kept for t in model.topics):
        notes.append(f"its QoS {', '.join(sorted({k for t in model.topics for k in (t.qos or {})} - kept))} mean "
                     f"nothing on {here} and are kept")
    session.notify("ipyros: " + "; ".join(notes))


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
    names = {planning.topic_slot(t.resolved): t.handler for t in model.topics}
    names.update({planning.service_slot(s.resolved): s.handler for s in model.services})
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


def _declare(node: rosNode, model: NodeModel, functions: dict[str, Callable[..., Any]]) -> None:
    """Replay ``model`` through the public DSL: base first, then topics, services, timers, params."""
    base = model.base
    if base is not None and base.launch:  # the launch file says the rest, as it does now
        node.baseLaunch(base.launch, base.launch_node or base.node_name or "", args=base.launch_args)
        base = None
    if base is not None and base.executable:
        node.baseNode(base.executable, name=base.node_name, namespace=base.namespace, remaps=base.remaps,
                      params=base.params, args=base.args)
    if base is not None and base.package:
        node.basePackage(base.package)
    for t in model.topics:
        role = getattr(node, t.role)
        if t.direction == "publish":
            role.publish(t.name, type=t.type, latch=t.latch, qos=t.qos)
        else:
            role.subscribe(t.name, handler=functions.get(planning.topic_slot(t.resolved)), type=t.type, qos=t.qos)
    for s in model.services:  # a reuse relays and takes no handler: the slot is the intercepting new's
        handler = functions.get(planning.service_slot(s.resolved)) if s.role == "new" else None
        getattr(node, s.role).service(s.name, type=s.type, handler=handler)
    for timer in model.timers:
        node.timer(timer.period, functions.get(planning.timer_slot(timer.name)), name=timer.name,
                   oneshot=timer.oneshot)
    for key, value in model.params.items():
        node.params[key] = value
