"""Keeping a node's work, the DSL's side: ``nd.save``, ``rosNode.load``, ``nd.export``, ``ipyros.restore``.

The formats are the files layer's (:mod:`ipyros.files`): ``.py`` is runnable DSL code
(:mod:`~ipyros.files.savefile`), ``.yaml``/``.json`` the node model with its handlers'
sources (:mod:`~ipyros.files.modelfile`), an export a script or package that needs no
ipyros (:mod:`~ipyros.files.export`). What needs a session is here: which ROS wrote
a file, replaying a model file's declarations through the DSL (so that every check
applies as if typed), and running a saved ``.py`` file: :class:`restoring` stops what it
started if it fails halfway, :func:`spin` keeps its nodes up when it runs as a script.
"""

from __future__ import annotations

import os
import sys
import time
from pathlib import Path
from typing import Any, Callable, Iterable, Optional

from ..core import plan as planning
from ..core.errors import DeclarationError, IpyrosError
from ..core.model import NodeModel
from ..files import export as exporting, modelfile, savefile
from ..node.engine import NodeEngine
from ..node.session import current

__all__ = ["RestoreError", "export", "load", "restore", "restoring", "save", "save_nodes", "save_session", "spin"]


class RestoreError(IpyrosError):
    """Running a saved file failed; what it had started was stopped again."""


# -- save, load, export ----------------------------------------------------------------------

def save(engine: NodeEngine, path: "str | os.PathLike[str]", namespace: Optional[dict] = None) -> Path:
    """Save a node to ``path``; the suffix says how (see :meth:`ipyros.dsl.rosnode.rosNode.save`)."""
    suffix = str(path).rsplit(".", 1)[-1].lower() if "." in str(path) else ""
    ros = engine.session.backend.name
    if suffix == "py":
        return savefile.save_nodes([engine], path, namespace, ros)
    if suffix in modelfile.MODEL_SUFFIXES:
        return modelfile.save(engine, path, ros)
    raise DeclarationError(f"{path}: say what to save by the suffix: .py (runnable code) "
                           "or .yaml / .json (the node model)")


def save_session(path: "str | os.PathLike[str]", namespace: Optional[dict] = None) -> Path:
    """Write every node running in this session to the Python file ``path``; return its path."""
    session = current()
    return savefile.save_nodes(list(session.nodes.values()), path, namespace, session.backend.name)


def save_nodes(engines: list[NodeEngine], path: "str | os.PathLike[str]", namespace: Optional[dict] = None) -> Path:
    """Write the nodes of ``engines`` to the Python file ``path`` (``%save_nodes a b file.py``)."""
    ros = engines[0].session.backend.name if engines else "ROS"
    return savefile.save_nodes(engines, path, namespace, ros)


def load(node_class: Callable[..., Any], path: Any, namespace: Optional[dict] = None, *, create: bool = False,
         session: Any = None, trust: bool = False) -> Any:
    """Bring back a node saved by :func:`save` (see :meth:`ipyros.dsl.rosnode.rosNode.load`)."""
    if str(path).endswith(".py"):
        nodes = restore(node_class, path, namespace)  # type: ignore[arg-type]
        if len(nodes) != 1:
            raise DeclarationError(f"{path} holds {len(nodes)} nodes ({', '.join(n.name for n in nodes)}); "
                                   "ipyros.restore(path) brings them all back")
        node = nodes[0]
    else:
        node = _load_model(node_class, path, namespace, session, trust)
    return node.create() if create else node


def _load_model(node_class: Callable[..., Any], path: Any, namespace: Optional[dict], session: Any,
                trust: bool) -> Any:
    """A model file's node, declared (not created): its handlers defined in ``namespace`` (default: a fresh
    dict; IPython's ``user_ns`` lets them read the user's globals), its declarations replayed through the DSL.
    Names the handlers call ``.write`` on (``nd.write(...)``) are bound to the new node if ``namespace``
    lacks them."""
    namespace = {} if namespace is None else namespace
    file = modelfile.read(path, trust)
    functions = modelfile.handlers_of(file, namespace)
    model, session = file.model, session or current()
    node = node_class(model.name, namespace=model.namespace, session=session)
    _across_ros(file, session)
    try:
        _declare(node, model, functions)
    except IpyrosError as error:
        raise type(error)(f"{file.path}: {error}") from None
    for name in sorted(file.writers):
        namespace.setdefault(name, node)
    return node


def _across_ros(file: modelfile.ModelFile, session: Any) -> None:
    """A model made on the other ROS: say what runs differently.

    The model itself is the same on both (names, types as ``pkg/Type``, QoS as data); what
    can differ is what it names: message packages and basenodes must be installed here
    (their lookups say so, in one line, if they are not), and a launch file must be one
    this ROS reads (the backend refuses it otherwise).
    """
    here = session.backend.name
    if file.made_on in (None, here):
        return
    notes = [f"{file.path} was made on {file.made_on}; loading it on {here}"]
    kept = set(session.backend.qos_fields)  # what a declaration's QoS means on this ROS
    unused = sorted({k for t in file.model.topics for k in (t.qos or {})} - kept)
    if unused:
        notes.append(f"its QoS {', '.join(unused)} mean nothing on {here} and are kept")
    session.notify("ipyros: " + "; ".join(notes))


def _declare(node: Any, model: NodeModel, functions: dict[str, Callable[..., Any]]) -> None:
    """Replay ``model`` through the public DSL: base first, then topics, services, timers, params, guards (a
    guard is data: every value of it is checked as if typed, and it runs nothing)."""
    base = model.base
    if base is not None and base.bag:  # a recorded bag: played by this ipyros's player
        node.baseBag(**base.bag)
        base = None
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
    for a in model.actions:  # as for services: the slot is the intercepting new's
        handler = functions.get(planning.action_slot(a.resolved)) if a.role == "new" else None
        getattr(node, a.role).action(a.name, type=a.type, handler=handler)
    for timer in model.timers:
        node.timer(timer.period, functions.get(planning.timer_slot(timer.name)), name=timer.name,
                   oneshot=timer.oneshot)
    for key, value in model.params.items():
        node.params[key] = value
    for guard in model.guards:
        node.guard(guard.name, limits=guard.limits or None, rate=guard.rate or None, on_limit=guard.on_limit,
                   timeout=guard.timeout, stop=guard.stop, repeat=guard.repeat, grace=guard.grace,
                   estop_topic=guard.estop_topic)


def export(engine: NodeEngine, path: "str | os.PathLike[str]", namespace: Optional[dict] = None,
           language: str = "python") -> Path:
    """Export a node to run without ipyros, for the session's ROS (see :func:`ipyros.files.export.export`); a guard's
    rules' inputs are subscribed there with the types the live graph shows now."""
    backend = engine.session.backend
    ruled = any(g.rules or g.stale for g in engine.model().guards)
    types = backend.graph_snapshot(timeout=1.0).topics if ruled else {}
    return exporting.export(engine, path, backend.export_flavour(), namespace, language, types)


# -- running a saved file --------------------------------------------------------------------

class restoring:  # noqa: N801 - used as a statement: with restoring():
    """Stop what a saved file started if it fails halfway, and say where it failed in one line."""

    def __init__(self) -> None:
        self.session = current()
        self.file = sys._getframe(1).f_code.co_filename  # the saved file running this block
        self.before: set[int] = set()

    def __enter__(self) -> "restoring":
        self.before = {id(n) for n in self.session.nodes.values()}
        return self

    def __exit__(self, kind: Any, error: Any, tb: Any) -> bool:
        if error is None:
            return False
        started = [n for n in self.session.nodes.values() if id(n) not in self.before]
        for node in reversed(started):
            node.shutdown()
        line = next((frame.tb_lineno for frame in _frames(tb) if frame.tb_frame.f_code.co_filename == self.file), None)
        where = f"{Path(self.file).name}, line {line}" if line else Path(self.file).name
        stopped = f"; stopped {', '.join(n.fullname for n in started)} again" if started else ""
        message = str(error) if isinstance(error, IpyrosError) else f"{type(error).__name__}: {error}"
        raise RestoreError(f"restoring {where} failed: {message}{stopped}") from None


def _frames(tb: Any) -> Iterable[Any]:
    while tb is not None:
        yield tb
        tb = tb.tb_next


def restore(node_class: type, path: "str | os.PathLike[str]", namespace: Optional[dict] = None) -> list[Any]:
    """Run the saved file ``path`` in ``namespace`` (default: a fresh one); return the nodes it made
    (the ``node_class`` objects it bound to names).

    Its ``if __name__ == "__main__"`` part does not run (``__name__`` is not ``__main__``).
    """
    path = Path(path).expanduser()
    try:
        text = path.read_text(encoding="utf-8")
    except OSError as error:
        raise IpyrosError(f"cannot read {path}: {error.strerror}") from None
    if savefile.MARKER not in text.splitlines()[:12]:
        raise IpyrosError(f"{path} is not a file saved by ipyros (no '{savefile.MARKER}' line at its top); "
                          "save nodes with nd.save('file.py') or %save_nodes file.py")
    namespace = {} if namespace is None else namespace
    before = {id(v) for v in namespace.values() if isinstance(v, node_class)}
    saved = {k: namespace[k] for k in ("__name__", "__file__") if k in namespace}
    namespace.update(__name__="__ipyros_restore__", __file__=str(path))
    try:
        code = compile(text, str(path), "exec")
        exec(code, namespace)  # noqa: S102 - the user's own saved file, as %run would
    except SyntaxError as error:
        raise RestoreError(f"{path} does not compile: {error.msg} at line {error.lineno}") from None
    except RestoreError:
        raise
    except Exception as error:  # before the with block: an import, a global
        line = next((f.tb_lineno for f in _frames(error.__traceback__) if f.tb_frame.f_code.co_filename == str(path)),
                    None)
        raise RestoreError(f"restoring {path.name}{f', line {line}' if line else ''} failed: "
                           f"{type(error).__name__}: {error}") from None
    finally:
        for key in ("__name__", "__file__"):
            namespace.pop(key, None)
        namespace.update(saved)
    return [v for v in dict.fromkeys(v for v in namespace.values() if isinstance(v, node_class))
            if id(v) not in before]


def spin() -> None:
    """Keep the nodes up until Ctrl-C when a saved file runs as a script; at a prompt, return at once."""
    if sys.flags.interactive or _in_ipython():
        return
    session = current()
    running = ", ".join(session.nodes) or "no nodes"
    print(f"ipyros: running {running}; Ctrl-C stops {'them' if len(session.nodes) > 1 else 'it'}", flush=True)
    try:
        while session.nodes and not session.closed:
            time.sleep(0.2)
    except KeyboardInterrupt:
        pass
    finally:
        session.close()


def _in_ipython() -> bool:
    shell = sys.modules.get("IPython")
    return shell is not None and shell.get_ipython() is not None
