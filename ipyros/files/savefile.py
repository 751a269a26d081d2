"""Saved nodes as Python: the DSL as a person would type it, run to bring the nodes back.

    nd.save("kobuki.py")                  # one node
    ipyros.save_session("lab.py")         # every node of the session (%save_nodes lab.py)

The file holds, in this order: imports, the plain-literal globals the handlers read,
the handlers' and their helpers' sources (current versions), then the declarations
inside ``with restoring():`` ending with ``create()``; earlier handler versions come as
``nd.restore_versions(...)`` so ``nd.revert`` still reaches them. Restoring is running it:
``python3 kobuki.py`` (``spin()`` keeps the nodes up until Ctrl-C), ``%run kobuki.py``,
or ``ipyros.restore`` (``rosNode.load``, ``%load_nodes``): see :mod:`ipyros.dsl.keeping`.
No pickle: text and code only.

Nothing is dropped silently: a handler without source fails the save, naming every such
handler; a global that is neither importable nor a literal is listed in the file and in
a :class:`SaveWarning`.
"""

from __future__ import annotations

import keyword
import os
import re
import time
import types
from pathlib import Path
from typing import Any, Iterable, Optional, Sequence

from ..core import plan as planning
from ..core.code import WRITER, Bindings, container_of, handler_slots, handler_source
from ..core.errors import IpyrosError, warn_user
from ..core.guard import DEFAULT_GRACE, DEFAULT_LEASE, DEFAULT_MACHINE_GRACE, DEFAULT_REPEAT
from ..core.model import GuardModel, NodeModel
from .atomic import write_atomic
from .kept import KeptNode
from .modelfile import handler_sources

__all__ = ["MARKER", "SaveWarning", "save_nodes"]

MARKER = "# ipyros saved nodes, format 1"
_OWN_NAMES = {"rosNode", "restoring", "spin"}  # what the file imports from ipyros


class SaveWarning(UserWarning):
    """A saved file needs globals it could not hold; they are listed at its top."""


# -- save -------------------------------------------------------------------------------------

def save_nodes(nodes: Sequence[KeptNode], path: "str | os.PathLike[str]", namespace: Optional[dict] = None,
               ros: str = "ROS") -> Path:
    """Write ``nodes`` to the Python file ``path``; return its path.

    ``namespace`` (IPython's ``user_ns``) is where the handlers' globals and the nodes'
    variable names are looked up first; ``ros`` names the ROS that made them, for the reader.
    """
    if not nodes:
        raise IpyrosError("there is no node to save; create one first (nd = rosNode('name'))")
    if Path(path).suffix != ".py":
        raise IpyrosError(f"{path}: a saved session is Python; give a path ending in .py")
    text = _SavedFile(nodes, namespace).render(Path(path).name, ros)
    compile(text, str(path), "exec")  # a file that does not compile is ipyros's bug: fail before writing
    return write_atomic(path, text)


class _SavedFile:
    """The text of a saved file, gathered node by node."""

    def __init__(self, nodes: Sequence[KeptNode], namespace: Optional[dict]) -> None:
        self.nodes, self.namespace = list(nodes), namespace
        self.bindings = Bindings()
        self.handlers: dict[str, str] = {}  # function name in the file → source
        self.slot_names: dict[tuple[int, str], str] = {}  # (node id, slot) → function name in the file
        self.sources = handler_sources(self.nodes, namespace)
        self.variables = self._variables()
        self.watches: dict[int, list[tuple[str, str]]] = {}  # node id → (parameter key, function name) of on_param
        self.unwatched: list[str] = []  # on_param handlers without a source: said when saving
        for node in self.nodes:
            for slot, _ in handler_slots(node.model()):
                self._handler(node, slot)
                for version in node.slot_versions(slot)[0]:  # what an earlier version needs, to revert to it
                    if isinstance(version.function, types.FunctionType) and version.source:
                        self.bindings.bind(version.function, version.source, self.namespace, self._skip)
            for key, fn in node.param_handlers().items():
                self._param_handler(node, key, fn)

    # -- names ------------------------------------------------------------------------------
    def _variables(self) -> dict[int, str]:
        """Each node's variable in the file: the name its handlers write through, else the user's, else its name."""
        taken: set[str] = set(_OWN_NAMES)
        chosen: dict[int, str] = {}
        for node in self.nodes:
            scopes = [self.namespace or {}] + [fn.__globals__ for fn in node.handlers().values()
                                               if isinstance(fn, types.FunctionType)]
            bound = [k for scope in scopes for k, v in scope.items() if v is node.owner and not k.startswith("_")]
            writers = [w for (owner, _), src in self.sources.items() if owner == id(node) for w in WRITER.findall(src)]
            candidates = [w for w in writers if w in bound] + bound + [_identifier(node.name)]
            name = next((c for c in candidates if c not in taken), None) or _unique(_identifier(node.name), taken)
            chosen[id(node)] = name
            taken.add(name)
        return chosen

    def _skip(self, name: str, value: Any) -> bool:
        """Globals the file binds itself: the saved nodes' variables and what it imports from ipyros."""
        return name in _OWN_NAMES or name in self.variables.values()

    # -- handlers ----------------------------------------------------------------------------
    def _handler(self, node: KeptNode, slot: str) -> None:
        own = _identifier(re.sub(r"\W+", "_", slot.replace("topic ", "on ", 1)).strip("_"))  # on_cmd_vel, timer_tick
        self.slot_names[(id(node), slot)] = self._keep(node, node.handlers()[slot], self.sources[(id(node), slot)], own)

    def _param_handler(self, node: KeptNode, key: str, fn: Any) -> None:
        """An ``on_param`` handler, kept as a handler is; one without a source is said, not saved."""
        try:
            source = handler_source(fn, f"{node.name} on_param {key!r}", self.namespace)
        except IpyrosError:
            self.unwatched.append(f"{node.name} {key!r}")
            return
        name = self._keep(node, fn, source, _identifier(f"on_{key.replace('/', '_')}"))
        self.watches.setdefault(id(node), []).append((key, name))

    def _keep(self, node: KeptNode, fn: Any, source: str, own: str) -> str:
        """Keep handler ``fn`` (its ``source``) in the file under its name, or ``own`` for a lambda; the name."""
        name = getattr(fn, "__name__", "<lambda>")
        held = container_of(fn, self.namespace)
        if held is not None:  # poses.append: kept as the lambda calling it; the list starts empty again
            container, value = held
            self.bindings.values.setdefault(container, f"{container} = {type(value).__name__}()  # filled by "
                                                       f"{node.name}'s handler: its data is not kept")
            name = "<lambda>"
        if name == "<lambda>":  # a name of its own
            name, source = own, f"{own} = {source}"
        if self.handlers.get(name, source) != source:
            raise IpyrosError(f"nothing saved: two different handlers are named {name}; rename one "
                              "(def another_name(msg): ...), declare it again, then save")
        self.handlers[name] = source
        if isinstance(fn, types.FunctionType):
            self.bindings.bind(fn, source, self.namespace, self._skip)
        return name

    # -- the text ----------------------------------------------------------------------------
    def render(self, stem: str, made_on: str) -> str:
        names = ", ".join(n.fullname for n in self.nodes)
        parts = [f'"""Nodes saved by ipyros on {time.strftime("%Y-%m-%d %H:%M:%S")}: {names}.\n\n'
                 f"Made on {made_on}. The DSL is the same on ROS 1 and ROS 2: it runs on either where the\n"
                 f"message packages and basenodes it names are installed.\n\n"
                 f"Bring them back, running: python3 {stem} (Ctrl-C stops them), %run {stem} in IPython,\n"
                 f"or rosNode.load(path). It is plain Python with the ipyros DSL: edit it, commit it, share it.\n"
                 f'"""\n{MARKER}\n' + "\n".join(["from ipyros import restoring, rosNode, spin",
                                                 *self.bindings.import_lines(skip=_OWN_NAMES)])]
        b = self.bindings
        if b.values or b.unbound:
            lines = ["# The globals the handlers read, as they were when saved."] + list(b.values.values())
            lines += [f"# Not saved: {name} ({why}); define it before running this file." for name, why in
                      b.unbound.items()]
            parts.append("\n".join(lines))
        parts += [src.rstrip("\n") for src in {**b.functions, **self.handlers}.values()]
        body = [line for node in self.nodes for line in self._declarations(node)][:-1]
        parts.append("with restoring():  # if a line below fails, the nodes it started are stopped again\n"
                     + "\n".join(f"    {line}" if line else "" for line in body))
        parts.append('if __name__ == "__main__":  # run as a script: keep the nodes up until Ctrl-C\n    spin()')
        if self.unwatched:  # said, not lost
            warn_user(f"ipyros: the on_param handlers of {', '.join(self.unwatched)} have no source and are not in the "
                      "saved file; give them a def and declare them again (nd.on_param(key, fn))", SaveWarning)
        if b.unbound:
            warn_user(f"ipyros: the saved file needs {', '.join(b.unbound)} defined before it runs "
                      "(listed at its top): " + "; ".join(f"{k} is {v.split(', ', 1)[1]}" for k, v in
                                                         b.unbound.items()), SaveWarning)
        return "\n\n\n".join(parts) + "\n"

    def _declarations(self, node: KeptNode) -> list[str]:
        """The DSL calls that declare ``node`` as it is, then create it if it runs."""
        model, var = node.model(), self.variables[id(node)]
        ns = f", namespace={model.namespace!r}" if model.namespace != "/" else ""
        lines = [f"{var} = rosNode({model.name!r}{ns})"]
        lines += _base_lines(var, model)
        fn_of = lambda slot: self.slot_names[(id(node), slot)]  # noqa: E731
        for t in model.topics:
            args = [f"handler={fn_of(planning.topic_slot(t.resolved))}"] if t.role == "new" and \
                t.direction == "subscribe" else []
            args.append(f"msgType={t.type!r}")
            if t.latch:
                args.append("latch=True")
            if t.qos:
                args.append(f"qos={t.qos!r}")
            lines.append(_declaring(f"{var}.{t.role}.{t.direction}", t.name, args))
        for s in model.services:
            handler = [f"handler={fn_of(planning.service_slot(s.resolved))}"] if s.role == "new" else []
            lines.append(_declaring(f"{var}.{s.role}.service", s.name, [f"srvType={s.type!r}", *handler]))
        for a in model.actions:
            handler = [f"handler={fn_of(planning.action_slot(a.resolved))}"] if a.role == "new" else []
            lines.append(_declaring(f"{var}.{a.role}.action", a.name, [f"type={a.type!r}", *handler]))
        for timer in model.timers:
            fn = fn_of(planning.timer_slot(timer.name))
            options = (f", name={timer.name!r}" if timer.name != fn else "") + (", oneshot=True" if timer.oneshot else "")
            lines.append(f"{var}.timer({timer.period!r}, {fn}{options})")
        lines += [f"{var}.params[{key!r}] = {value!r}" for key, value in model.params.items()]
        lines += [f"{var}.on_param({key!r}, {name})" for key, name in self.watches.get(id(node), [])]
        lines += [guard_line(var, guard) for guard in model.guards]
        lines += self._versions(node, var, model)
        lines.append(f"{var}.create()" if node.created else f"# {var}.create()  (it was not running when saved)")
        return lines + [""]

    def _versions(self, node: KeptNode, var: str, model: NodeModel) -> list[str]:
        """``restore_versions`` calls for the handlers that had more than one version."""
        lines = []
        for slot, _ in handler_slots(model):
            versions, current = node.slot_versions(slot)
            if len(versions) < 2 or any(v.source is None for v in versions):
                continue
            what = _declared_name(model, slot)
            current = current or len(versions)
            lines.append(f"{var}.restore_versions({what!r}, [  # {var}.versions({what!r}) lists them")
            lines += [f"    ({v.when!r}, {_python_string(v.source)})," for v in versions]  # type: ignore[arg-type]
            lines.append(f"], current={current})")
        return lines


def guard_line(var: str, guard: GuardModel) -> str:
    """``nd.guard(...)`` as it was declared (its settings that are not the defaults)."""
    options = {"limits": {p: tuple(b) for p, b in guard.limits.items()} or None, "rate": guard.rate or None,
               "on_limit": guard.on_limit if guard.on_limit != "clamp" else None, "timeout": guard.timeout,
               "stop": guard.stop, "repeat": guard.repeat if guard.repeat != DEFAULT_REPEAT else None,
               "grace": guard.grace if guard.grace != DEFAULT_GRACE else None, "estop_topic": guard.estop_topic,
               "machine": guard.machine,
               "lease": guard.lease if guard.machine and guard.lease != DEFAULT_LEASE else None,
               "rules": guard.rules or None, "stale": guard.stale or None}  # rules as data: rule()'s keywords
    text = "".join(f", {key}={value!r}" for key, value in options.items() if value is not None)
    if guard.machine is not None and guard.machine_grace != DEFAULT_MACHINE_GRACE:
        text += f", machine_grace={guard.machine_grace!r}"
    return f"{var}.guard({guard.name!r}{text})"


def _declaring(method: str, name: str, args: list[str]) -> str:
    """One declaration, in the paper's spelling where the name allows it: ``nd.reuse.publish.cmd_vel(...)``
    for a relative name whose parts are Python names, else ``nd.reuse.publish('/cmd_vel', ...)``.
    ``args`` are keyword arguments: they read the same in both spellings.
    """
    parts = name.split("/")
    if all(part.isidentifier() and not keyword.iskeyword(part) for part in parts):
        return f"{method}.{'.'.join(parts)}({', '.join(args)})"
    return f"{method}({', '.join([repr(name), *args])})"


def _base_lines(var: str, model: NodeModel) -> list[str]:
    base = model.base
    if base is None:
        return []
    if base.bag:  # a recorded bag: played as baseBag plays it, wherever ipyros's player lies now
        options = {k: v for k, v in base.bag.items() if k != "path" and v is not None}
        text = "".join(f", {k}={v!r}" for k, v in options.items())
        return [f"{var}.baseBag({base.bag['path']!r}{text})"]
    if base.launch:  # a node of a launch file: the launch file says the rest
        args = f", args={base.launch_args!r}" if base.launch_args else ""
        return [f"{var}.baseLaunch({base.launch!r}, {base.launch_node!r}{args})"]
    options = {"name": base.node_name, "namespace": base.namespace, "remaps": base.remaps or None,
               "params": base.params or None, "args": base.args or None, "env": base.env or None}
    text = "".join(f", {k}={v!r}" for k, v in options.items() if v)
    lines = [f"{var}.baseNode({base.executable!r}{text})"] if base.executable else []
    lines += [f"{var}.basePackage({base.package!r})"] if base.package else []
    if base.machine:
        grace = "" if base.machine_grace == DEFAULT_MACHINE_GRACE else f", grace={base.machine_grace!r}"
        lines.append(f"{var}.machine({base.machine!r}{grace})")
    return lines


def _declared_name(model: NodeModel, slot: str) -> str:
    """What the user typed for the handler in ``slot``: the topic, the service, or the timer's name."""
    for t in model.topics:
        if planning.topic_slot(t.resolved) == slot and t.role == "new":
            return t.name
    for s in model.services:
        if planning.service_slot(s.resolved) == slot:
            return s.name
    for a in model.actions:
        if planning.action_slot(a.resolved) == slot:
            return a.name
    return slot.split(" ", 1)[1]


def _python_string(text: str) -> str:
    """``text`` as a string literal a person can read: a raw triple-quoted block where it can be."""
    if "'''" not in text and not text.endswith("\\") and "\r" not in text:
        return "r'''" + text + "'''"
    return repr(text)


def _identifier(text: str) -> str:
    name = re.sub(r"\W", "_", text.strip("/").rsplit("/", 1)[-1]) or "node"
    return name if name[0].isalpha() and not keyword.iskeyword(name) else f"node_{name}"


def _unique(name: str, taken: Iterable[str]) -> str:
    taken = set(taken)
    return next(f"{name}_{i}" for i in range(2, 10_000) if f"{name}_{i}" not in taken)
