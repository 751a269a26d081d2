"""A basenode's interface read from the graph: its types checked against the wrapping node's declarations, all of it
declared as ``reuse`` in one call (``nd.discover()``, ``%wrap``), the types a relay needs learnt before it opens,
and what a running basenode does not use of the node's ``reuse`` said.

What a basenode is, as declared, is :mod:`.wrapping`'s; starting it, :mod:`.basestart`'s.
"""

from __future__ import annotations

from typing import Any, Callable

from ..core import msgtypes, names
from ..core.errors import BaseNodeError, DeclarationError, MessageTypeError, TopicTypeConflict
from ..core.model import BaseModel, NodeModel
from ..core.plan import RelaySpec, internal_name
from ..core.records import Interface
from ..core.remapping import base_fullname, base_namespace, base_node_name, check_wrapping
from . import declaring
from .wrapping import WrappingNode, ended_at_start, interrupted


def check_base_types(model: NodeModel, interface: Interface) -> None:
    """Refuse a base topic declared with another type than the basenode uses."""
    actual = {name: type_ for name, type_ in interface.publications + interface.subscriptions if type_}
    for t in model.topics:
        if t.role != "reuse":
            continue
        have = actual.get(internal_name(model, t.resolved))
        if have and have != t.type:
            raise TopicTypeConflict(f"basenode {base_fullname(model)} uses {t.resolved} as {have}, but {model.name} "
                                    f"declares {t.type}; declare type={have!r}")


def declare_interface(node: "WrappingNode", interface: Interface) -> Interface:
    """Declare every topic, service and action of a basenode's interface as ``reuse`` on ``node``."""
    model = node.model()
    prefix = names.global_ns(base_namespace(model))
    untyped = [name for name, type_ in interface.publications + interface.subscriptions + interface.services
               if not type_]
    missing: dict[str, list[str]] = {}  # {what to install: [name (type)]}: declared are all the others
    # A relay of a type this Python lacks is declarable (ROS 2 learns it at create()), but discovery has just
    # tried that (_build_its_own_types): what is still lacking stays undeclared and named.
    lacking = {} if node.session.backend.relays_any_type else msgtypes.not_installed(
        type_ for _, type_ in interface.publications + interface.subscriptions)
    declares: tuple[tuple[Callable[[str, str], Any], list[tuple[str, str]], bool], ...] = (
        (lambda name, type_: declaring.publish(node, "reuse", name, type_), interface.publications, True),
        (lambda name, type_: declaring.subscribe(node, "reuse", name, None, type_), interface.subscriptions, True),
        (lambda name, type_: declaring.serve(node, "reuse", "service", name, type_, None), interface.services, False),
        (lambda name, type_: declaring.serve(node, "reuse", "action", name, type_, None), interface.actions, False))
    for declare, found, relayed in declares:
        for name, type_ in found:
            if not type_:
                continue
            try:
                if relayed and type_ in lacking:
                    raise MessageTypeError(lacking[type_])
                declare(_relative(name, prefix), type_)
            except MessageTypeError:
                package = type_.split("/", 1)[0]
                missing.setdefault(msgtypes.install_hint(package), []).append(f"{name} ({type_})")
    if untyped:
        node.session.notify(f"ipyros: {', '.join(untyped)} of {interface.node} have no known type yet "
                             "(nobody publishes them); declare them yourself with type=...")
    if missing:
        node.session.notify("ipyros: not declared, their types are not installed here: "
                            + "; ".join(f"{', '.join(what)}: {how}" for how, what in missing.items())
                            + f"; the rest of {interface.node} is declared")
    interface.not_installed = [n for names_ in missing.values() for n in names_]
    return interface


def _relative(name: str, prefix: str) -> str:
    """Keep names in the basenode's namespace relative, so they follow its namespace."""
    return name[len(prefix):] if prefix != "/" and name.startswith(prefix) else name


def discover(node: "WrappingNode", timeout: float = 10.0) -> Interface:
    """Black-box discovery: run the basenode as it is, read its interface, declare it as reuse.

    The basenode runs briefly without remaps (it is stopped before the wrapping node
    starts it again, remapped). Returns the interface, which displays as a table.
    """
    model = node.model()
    if model.base is None:
        raise DeclarationError(f"{node.name} wraps no basenode, so there is nothing to discover; declare one first: "
                               f"{node.called}.baseNode('executable').basePackage('package')")
    check_wrapping(model)
    if node.created:
        raise DeclarationError(f"{node.name} is already running; discover() its basenode before create()")
    node.session.start_process_node(node.fullname)  # the graph is read by this session's own ROS side
    interface = _run_as_it_is(node, timeout, lambda found: _build_its_own_types(node, found))
    # Without the wrapping remaps, the basenode used the public names themselves.
    interface.not_seen = [f"{t.resolved} ({t.direction})" for t in model.topics
                          if t.role == "reuse" and not _uses(interface, t.direction, t.resolved)]
    if interface.not_seen:
        node.session.notify(f"ipyros: {interface.node} did not use {', '.join(interface.not_seen)} while it was "
                             f"discovered: {_LATE}; they stay declared")
    elif not interface.publications and interface.subscriptions:
        node.session.notify(f"ipyros: {interface.node} publishes nothing yet: {_LATE}; declare what it will "
                             f"publish: {node.called}.reuse.publish('name', type=...)")
    return declare_interface(node, interface.fold_actions())


_LATE = "a node may advertise only after its first input (topic_tools throttle and mux do)"


def _run_as_it_is(node: "WrappingNode", timeout: float, ask: Callable[[Interface], None]) -> Interface:
    """Run the basenode briefly as it is (no remaps), ``ask`` its interface while it runs, and stop it."""
    model = node.model()
    assert model.base is not None  # a node that wraps nothing is never run as it is
    base = BaseModel(**{**model.base.__dict__, "node_name": base_node_name(model.base),
                        "namespace": base_namespace(model)})
    probe = node.session.backend.basenode(base).start()
    try:
        interface = node.session.backend.wait_for_node(base_fullname(model), timeout=timeout,
                                                       alive=lambda: probe.running)
        ask(interface)
        return interface
    except BaseNodeError:
        if not probe.running:
            raise ended_at_start(model, probe) from None
        raise
    except KeyboardInterrupt:
        raise interrupted(f"running basenode {base_fullname(model)} as it is to read its interface",
                          "it was stopped") from None
    finally:
        probe.stop()


def learn_relayed_types(node: "WrappingNode", relays: list[RelaySpec], timeout: float = 10.0) -> None:
    """Make importable the types of ``relays`` that this Python lacks, from the basenode's own descriptions,
    before the relays open (ROS 2, whose relays need each type's class).

    A running basenode is asked as it runs; else it is run briefly as it is, as :func:`discover` does, so
    that the relays still open before it starts wrapped and nothing it sends at start is lost. A type that
    cannot be learnt is refused in one line naming the package to install.
    """
    backend = node.session.backend
    if backend.relays_any_type:  # ROS 1 relays the bytes of any type
        return
    lacking = msgtypes.not_installed(relay.type for relay in relays)
    if not lacking:
        return
    model = node.model()
    # Each type → the public name of a relay of it: what the basenode uses unremapped (run as it is, or before the
    # restart that remaps it to a reuse declared on the running node).
    wanted = {relay.type: relay.source if internal_name(model, relay.source) == relay.target else relay.target
              for relay in relays if relay.type in lacking}
    listed, hint = ", ".join(lacking), "; ".join(sorted(set(lacking.values())))

    def build(running: str) -> None:
        try:
            built = backend.build_types_of(running, wanted, node.session.progress)
        except MessageTypeError as error:
            raise MessageTypeError(f"{listed} not installed here, and {error}; or {hint}") from None
        if built:
            node.session.notify(f"ipyros: built {', '.join(built)} from {running}'s own type descriptions "
                                "(not installed here) to relay them")

    if node.base is not None and node.base.running:
        build(base_fullname(model))
    else:
        node.session.notify(f"ipyros: running basenode {base_fullname(model)} briefly as it is, to learn "
                            f"{listed} (not installed here) before relaying")
        _run_as_it_is(node, timeout, lambda interface: build(interface.node))
    left = list(msgtypes.not_installed(wanted))
    if left:
        raise MessageTypeError(f"{', '.join(left)} not installed here, and not made from basenode "
                               f"{base_fullname(model)}'s own descriptions: {hint}")


def _build_its_own_types(node: "WrappingNode", interface: Interface) -> None:
    """Make the message types the basenode uses and this Python lacks importable, from the basenode itself where
    the backend can (ROS 2: its type descriptions, then a build); say what was built, or why not, in one line."""
    if node.session.backend.relays_any_type:  # ROS 1 relays the bytes of any type: nothing to build, nor to look for
        return
    wanted: dict[str, str] = {}
    for name, type_ in interface.publications + interface.subscriptions:
        try:
            if type_:
                msgtypes.resolve_message(type_)
        except MessageTypeError:
            wanted.setdefault(type_, name)
    if not wanted:
        return
    try:
        built = node.session.backend.build_types_of(interface.node, wanted, node.session.progress)
    except MessageTypeError as error:
        node.session.notify(f"ipyros: {error}")
        return
    if built:
        node.session.notify(f"ipyros: built {', '.join(built)} from {interface.node}'s own type descriptions "
                            "(not installed here); they are declared and relayed like the others")


def _uses(interface: Interface, direction: str, name: str) -> bool:
    entries = interface.publications if direction == "publish" else interface.subscriptions
    return any(entry == name for entry, _ in entries)


def report_unused_reuses(node: "WrappingNode", model: NodeModel, interface: Interface) -> None:
    """Say, once per start, which ``reuse`` declarations of ``model`` the settled basenode does not use (yet)."""
    unused = [f"reuse.{t.direction}({t.name!r})" for t in model.topics
              if t.role == "reuse" and not _uses(interface, t.direction, internal_name(model, t.resolved))]
    if unused:
        node.session.notify(f"ipyros: basenode {interface.node} does not use {', '.join(unused)} of {node.called} "
                             f"(yet): nothing is relayed there until it does ({_LATE}); if a name is wrong, "
                             f"{node.called}.remove('name') and declare the right one")
