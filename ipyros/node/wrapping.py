"""Wrapping: the live side of a node that wraps a basenode (paper section III, figure 1).

Which endpoints run is decided in :mod:`ipyros.core.plan`, and how names resolve and remap
in :mod:`ipyros.core.remapping`. This module declares the basenode (checking what it is
given), starts it with its remaps, and offers black-box discovery: read a running
basenode's interface from the graph and declare it all as ``reuse`` in one call.

A basenode may also come from a launch file (:func:`set_launch_base`, read by the
backend): then ``create()`` runs the rest of that file too, and ``nd.base`` stops both.
Running it, reading its interface and finding its package are the backend's
(``basenode``, ``wait_for_node``): the same here for both ROS.
"""

from __future__ import annotations

import difflib
import os
import re
import threading
from pathlib import Path
from typing import Any, Callable, Optional, Protocol

from ..core import msgtypes, names
from ..core.errors import BaseNodeError, DeclarationError, IpyrosError, MessageTypeError, TopicTypeConflict, cut
from ..core.model import BaseModel, NodeModel
from ..core.plan import RelaySpec, internal_name
from ..core.records import Interface
from ..core.remapping import base_fullname, base_namespace, base_node_name, basenode_remaps, check_wrapping, reresolve
from ..core.guard import DEFAULT_MACHINE_GRACE
from ..processes.basenode import BaseHandle, exit_reason
from ..processes.keeper import MachineError, Token, check_machine_name, token_path
from ..processes.playback import player_args
from . import declaring
from .placedbase import PlacedBase, placed_problem


class NodeEngine(Protocol):
    """What wrapping needs of a node (its :class:`~ipyros.node.engine.NodeEngine` has it)."""

    @property
    def name(self) -> str: ...
    @property
    def fullname(self) -> str: ...
    created: bool
    @property
    def called(self) -> str: ...
    @property
    def explicit_namespace(self) -> bool: ...
    session: Any
    base: Optional[BaseHandle]

    def model(self) -> NodeModel: ...
    def apply(self, edit: Callable[[NodeModel], None], change: str) -> None: ...
    def resolve(self, name: str, kind: str = "topic") -> str: ...
    def resolve_as(self, role: str, name: str, kind: str) -> str: ...
    def change(self, edit: Callable[[NodeModel], None], handlers: Any = None, drop: Any = (),
               check: Any = ()) -> None: ...
    def record(self, change: str) -> None: ...

_BASE_OPTIONS = {"name": "node_name", "namespace": "namespace", "remaps": "remaps", "params": "params", "args": "args",
                 "env": "env"}


# -- declarations --------------------------------------------------------------------------

def set_base(node: "NodeEngine", **fields: Any) -> None:
    """Record basenode fields (``executable``, ``package`` and the options) in the model."""
    unknown = set(fields) - {"executable", "package", *_BASE_OPTIONS}
    if unknown:
        raise DeclarationError(f"baseNode() got unknown option(s) {', '.join(sorted(unknown))}; "
                               f"known: {', '.join(_BASE_OPTIONS)}")
    if node.created:
        raise DeclarationError(f"{node.name} is already running; declare its basenode before create()")
    for key in ("executable", "package"):
        if key in fields and (not isinstance(fields[key], str) or not fields[key].strip()):
            what = "basePackage('package')" if key == "package" else "baseNode('executable')"
            raise DeclarationError(f"{what} needs a non-empty name")
    if "package" in fields:
        names.check_package_name(fields["package"])
    if "executable" in fields:
        _check_executable(fields["executable"])
    if fields.get("name"):
        names.check_node_name(fields["name"], node.session.backend.name_rules)
    _check_base_options(fields, node.session.backend)
    reread = "executable" in fields or "package" in fields  # its file may be another: read its name again
    own_name = _own_name(node, fields) if reread else None

    def edit(model: NodeModel) -> None:
        base = model.base or BaseModel()
        if "executable" in fields:
            base.bag = None  # another program now; baseBag says so again after this when it is a bag
        for key, value in fields.items():
            setattr(base, _BASE_OPTIONS.get(key, key), value)
        if reread:
            base.own_name = own_name
        model.base = base
        if fields.get("namespace") and not node.explicit_namespace:
            model.namespace = names.global_ns(fields["namespace"])
        reresolve(model)

    node.apply(edit, "base " + ", ".join(f"{k}={cut(v)}" for k, v in fields.items()))


def set_machine(node: "NodeEngine", machine: Optional[str], grace: Optional[float] = DEFAULT_MACHINE_GRACE) -> None:
    """Place the basenode on the machine whose keeper is ``machine`` (None: back on this one); past ``grace`` s
    without a word from this session, that keeper stops it (None: it is left running)."""
    where = f"{node.name}.machine({machine!r})"
    if node.created:
        raise DeclarationError(f"{node.name} is already running; place its basenode before create()")
    if machine is not None:
        try:
            check_machine_name(machine)
            Token.read(token_path(machine), machine)  # said now, not when the node starts
        except MachineError as error:
            raise DeclarationError(f"{where}: {error}") from None
    if grace is not None and (not isinstance(grace, (int, float)) or isinstance(grace, bool) or
                              not 0 < grace < float("inf")):
        raise DeclarationError(f"{where}: grace={cut(grace)}: give the seconds after which its keeper stops it when "
                               "this session is silent (e.g. 30), or None to keep it running")
    base_now = node.model().base
    problem = placed_problem(base_now) if machine is not None and base_now is not None and \
        (base_now.executable or base_now.launch or base_now.bag) else None
    if problem is not None:
        raise DeclarationError(f"{where}: {problem}")

    def edit(model: NodeModel) -> None:
        base = model.base or BaseModel()
        base.machine, base.machine_grace = machine, grace if machine is not None else DEFAULT_MACHINE_GRACE
        model.base = base

    node.apply(edit, f"base machine={machine}" + (f", grace={grace}" if machine is not None else ""))


def _own_name(node: "NodeEngine", fields: dict[str, Any]) -> Optional[str]:
    """The name the code of the basenode that ``fields`` make gives its node: without ``name=`` it runs under
    that name, as it does when run by hand (the backend reads it; a binary's is not known)."""
    base = node.model().base or BaseModel()
    given: dict[str, Any] = {key: fields[key] for key in ("executable", "package") if key in fields}
    merged = BaseModel(**{**base.__dict__, **given})
    return node.session.backend.own_node_name(merged) if merged.executable else None


def _check_base_options(fields: dict[str, Any], backend: Any) -> None:
    """One line for a basenode option of the wrong shape, before anything is recorded."""
    if fields.get("namespace") is not None:
        names.check_namespace(fields["namespace"], backend.name_rules)
    remaps = fields.get("remaps")
    if remaps is not None and (not isinstance(remaps, dict)
                               or not all(isinstance(k, str) and isinstance(v, str) for k, v in remaps.items())):
        raise DeclarationError(f"baseNode(remaps={cut(remaps)}): give a dict of names, "
                               "e.g. remaps={'scan': '/robot1/scan'}")
    for source, target in (remaps or {}).items():
        names.check_remap(source, target)
    args = fields.get("args")
    if args is not None and (isinstance(args, (str, bytes)) or not isinstance(args, (list, tuple))
                             or not all(isinstance(a, str) for a in args)):
        raise DeclarationError(f"baseNode(args={cut(args)}): give a list of strings, e.g. args=['--rate', '5']")
    env = fields.get("env")
    if env is not None and (not isinstance(env, dict) or not all(
            isinstance(k, str) and re.fullmatch(r"[A-Za-z_]\w*", k) and isinstance(v, str) for k, v in env.items())):
        raise DeclarationError(f"baseNode(env={cut(env)}): give a dict of variable names and string values, "
                               "e.g. env={'ROBOT_MODE': 'sim'}")
    params = fields.get("params")
    if params is not None:
        if not isinstance(params, dict) or not all(isinstance(k, str) and k for k in params):
            raise DeclarationError(f"baseNode(params={cut(params)}): give a dict of private parameters, "
                                   "e.g. params={'rate': 5}")
        for key, value in params.items():
            names.check_param_key(key.lstrip("~_") if key[:1] in "~_" else key, f"baseNode(params={{{key!r}: ...}})")
            backend.check_param(f"~{key.lstrip('~_')}", value)


def _check_executable(executable: str) -> None:
    """An executable name (or a path): no control characters, nothing a shell or a launch file would expand.

    It is passed to ``exec`` as one argument, never to a shell; but it is also written into
    exported scripts and launch files, where ``$(...)`` would be evaluated by roslaunch.
    """
    if any(ord(c) < 32 or c == "\x7f" for c in executable) or "$(" in executable:
        raise DeclarationError(f"baseNode({executable[:80]!r}): an executable's name or path may hold neither "
                               "control characters nor '$('; give the file's name or path as it is on disk")


def set_launch_base(node: "NodeEngine", launch: Any, node_name: str, args: Optional[dict] = None) -> None:
    """Wrap the node ``node_name`` that launch file ``launch`` starts, read with ``args`` (by the backend).

    The whole basenode comes from the file: package, executable, name, namespace,
    remaps, private params, args. Like ``baseNode``, the wrapping node lives in the
    basenode's namespace unless it was given one. Raises :class:`BaseNodeError` for a
    missing or broken file, a node it does not start, an ambiguous short name, or a
    node ipyros cannot run as the file says (a remote ``machine=``, ``launch-prefix``).
    """
    if node.created:
        raise DeclarationError(f"{node.name} is already running; declare its basenode before create()")
    if args is not None and not (isinstance(args, dict) and all(isinstance(k, str) for k in args)):
        raise DeclarationError(f"baseLaunch(args={cut(args)}): give a dict of the launch file's args, e.g. {{'rate': 5}}")
    base, notes = node.session.backend.read_launch(launch, node_name, args)

    def edit(model: NodeModel) -> None:
        model.base = base
        if not node.explicit_namespace:
            model.namespace = base.namespace or "/"
        reresolve(model)

    given = "".join(f", {name}={value!r}" for name, value in base.launch_args.items())
    node.apply(edit, f"baseLaunch({launch!r}, {node_name!r}{given}): {base.package}/{base.executable} "
                     f"as {base.launch_node}")
    for note in notes:
        node.session.notify(f"ipyros: {note}")


def set_bag(node: "NodeEngine", path: Any, rate: float, loop: bool, topics: Optional[list[str]],
            delay: float, clock: bool = False) -> None:
    """A recorded bag as the basenode: the backend's bag player, named ``bag_player`` (see ``rosNode.baseBag``)."""
    if not isinstance(path, (str, os.PathLike)):
        raise DeclarationError(f"baseBag({cut(path)}): give the bag's path, e.g. baseBag('run1.bag')")
    bagfile = node.session.backend.bags()
    bag = Path(path).expanduser().absolute()
    if not bag.exists():
        raise DeclarationError(f"baseBag({str(path)!r}): no such file; record one with %record FILE TOPIC ...")
    recorded = bagfile.bag_topics(bag)
    missing = sorted(set(topics or ()) - set(recorded))
    if missing:
        raise DeclarationError(f"the bag {bag.name} has no topic {', '.join(missing)}; it has "
                               f"{', '.join(sorted(recorded)) or 'none'}")
    if not (isinstance(rate, (int, float)) and 0 < rate <= 1000 and 0 <= delay <= 60):
        raise DeclarationError(f"baseBag(rate={rate!r}, delay={delay!r}): rate a speed factor above 0 "
                               "(1.0 as recorded), delay seconds from 0 to 60")
    set_base(node, executable=str(bagfile.PLAYER), name="bag_player",
             args=player_args(bag, float(rate), bool(loop), topics, float(delay), bool(clock)))
    played = {"path": str(bag), "rate": float(rate), "loop": bool(loop), "topics": list(topics or []) or None,
              "delay": float(delay), **({"clock": True} if clock else {})}
    node.change(lambda model: setattr(model.base, "bag", played))  # saved as baseBag(...), shown as "bag FILE"


def start_bag_clock(node: "NodeEngine") -> None:
    """A bag played with ``clock=True``: the session runs on its /clock from now on (said in one line); one bag's
    clock at a time."""
    base = node.model().base
    if base is None or not (base.bag or {}).get("clock"):
        return
    session = node.session
    if session.bag_clock not in (None, node.fullname):
        raise DeclarationError(f"{node.called}'s bag would publish /clock, but the bag of {session.bag_clock} does "
                               "already: one bag's time at a time; shut that node down first, or give "
                               "baseBag(..., clock=False)")
    session.bag_clock = node.fullname
    session.notify(session.backend.bag_time(True))


def stop_bag_clock(node: "NodeEngine") -> None:
    """The node whose bag's clock the session ran on stops: the wall clock again (said in one line)."""
    session = node.session
    if session.bag_clock == node.fullname:
        session.bag_clock = None
        session.notify(session.backend.bag_time(False))


# -- the basenode process ------------------------------------------------------------------

#: How long a running basenode may take to show up in the graph (s); one that ends sooner is told at once. Long,
#: because a start can be slow for good reasons (a map loaded; on ROS 2, discovery in a graph of many processes:
#: the 41st basenode of one session took over 10 s on 2 cores); the wait is said once it takes a while.
REGISTRATION_TIMEOUT = 45.0

#: After how long (s) a basenode still starting is said at the prompt, with how to stop waiting.
SLOW_START_NOTICE = 3.0


def start_base(node: "NodeEngine", settle_timeout: Optional[float] = None) -> None:
    """Launch the basenode remapped onto the wrapping node's internal names, and check its types.

    A basenode from a launch file starts after the rest of its file (the backend's
    ``launch_base``); ``node.base`` holds the one handle whose ``stop()`` stops all of it,
    set before anything starts, so that the node's shutdown after a failure half-way stops
    what did start.
    """
    model = node.model()
    if model.base is None:
        return
    session = node.session
    backend = session.backend
    from_launch = model.base.launch is not None
    base = BaseModel(**{**model.base.__dict__, "node_name": base_node_name(model.base),
                        "namespace": base_namespace(model), "remaps": basenode_remaps(model, backend.action_parts),
                        # from a ROS 1 launch file, the params go on the parameter server as roslaunch puts them
                        "params": {} if from_launch and backend.launch_params_on_server else model.base.params})

    starting = threading.Event()  # while set, an exit is create()'s error to raise, not a notice
    starting.set()

    def died(proc: Any, returncode: int, last_lines: list[str]) -> None:
        if starting.is_set():
            return
        tail = "\n    ".join(last_lines[-8:])
        on = f" on {base.machine}" if base.machine else ""
        session.notify(f"ipyros: basenode {base_fullname(model)} of {node.called}{on} {exit_reason(returncode)}; "
                       f"restart it with {node.called}.base.restart()\n    {tail}")

    process: BaseHandle
    if base.machine is not None:  # its machine's keeper runs it
        problem = placed_problem(base)
        if problem is not None:
            raise BaseNodeError(f"{node.called}.machine({base.machine!r}): {problem}; or leave .machine() out")
        process = PlacedBase(base, backend, node.fullname, session.notify, on_exit=died)
    else:
        process = backend.basenode(base, on_exit=died)
        real = backend.note_link(base, process)
        if real is not None:
            session.notify(f"ipyros: {base.package}/{base.executable} is a link to {real}, outside the package; "
                           "that is what runs (as rosrun would run it)")
    handle: Any = process
    if from_launch:
        launch = model.base.launch

        def rest_died(proc: Any, returncode: int, last_lines: list[str]) -> None:
            tail = "\n    ".join(last_lines[-8:])
            what = f"node {proc.node_name}" if getattr(proc, "node_name", None) else "the rest"  # ROS 2: each node
            session.notify(f"ipyros: {what} of {launch} (run for {node.name}) {exit_reason(returncode)}; "
                           f"run it again with {node.called}.shutdown() and {node.called}.create()\n    {tail}")

        handle = backend.launch_base(model.base, process, base_fullname(model), rest_died)
    node.base = handle
    handle.start()
    if getattr(handle, "not_started", None):
        session.notify(f"ipyros: could not start {', '.join(handle.not_started)} of {model.base.launch} "
                       f"(the rest runs without); why: {node.called}.base.rest.tail()")
    timeout = settle_timeout or REGISTRATION_TIMEOUT

    def slow() -> None:
        if starting.is_set() and process.running:
            session.notify(f"ipyros: basenode {base_fullname(model)} of {node.called} runs but is not in the graph "
                           f"yet; waiting up to {timeout:g} s (Ctrl-C stops it and {node.called})")

    notice = threading.Timer(SLOW_START_NOTICE, slow)
    notice.daemon = True
    notice.start()
    try:
        with session.progress(f"waiting for basenode {base_fullname(model)} to show up in the graph"):
            interface = backend.wait_for_node(base_fullname(model), timeout=timeout, alive=lambda: process.running)
        starting.clear()
        if not process.running:  # it ended after settling, before a notice could be sent
            raise BaseNodeError("ended")
    except BaseNodeError:
        if not process.running:
            raise _ended_at_start(model, process, f" (nothing of {node.called} was left running)") from None
        raise _never_seen(node, model, timeout) from None
    except KeyboardInterrupt:  # create() stops the basenode and everything else of the node on its way out
        raise interrupted(f"waiting for basenode {base_fullname(model)} of {node.called} to show up in the graph",
                          f"it and the rest of {node.called} were stopped") from None
    finally:
        notice.cancel()
    check_base_types(model, interface)
    report_unused_reuses(node, model, interface)


def interrupted(doing: str, outcome: str) -> BaseNodeError:
    """Ctrl-C while ``doing``, said in one line (not a traceback from inside a wait): what was stopped."""
    return BaseNodeError(f"Ctrl-C while {doing}: {outcome}; nothing is left half-declared")


def names_like(name: str, seen: list[str]) -> list[str]:
    """Up to three of ``seen`` that look like ``name`` (a typo, a namespace, a suffix a launch added), best first;
    none for names that merely share letters, so a hint never points at an unrelated node."""
    return difflib.get_close_matches(name, seen, n=3, cutoff=0.7)


def _never_seen(node: "NodeEngine", model: NodeModel, timeout: float) -> BaseNodeError:
    """The one line for a basenode that ran but never showed up in the graph (create() then stops it): the
    graph's nodes of a name like the one it was given, in case it took another."""
    backend, name = node.session.backend, base_fullname(model)
    try:
        seen = [n for n in backend.graph_snapshot().nodes if n not in node.session.nodes]  # not its own
    except IpyrosError:
        seen = []
    like = names_like(name, seen)
    return BaseNodeError(f"basenode {name} of {node.called} ran {timeout:g} s without showing up in the graph "
                         f"({backend.where()}), so it was stopped; is it a ROS node that keeps the name it is given?"
                         + (f" nodes of a name like it: {', '.join(like)}" if like else ""))


def _ended_at_start(model: NodeModel, process: Any, what_now: str = "") -> BaseNodeError:
    """The one line for a basenode that ended before it settled: how, and its last log lines."""
    return BaseNodeError(f"basenode {base_fullname(model)} {exit_reason(process.returncode or 0)} at start{what_now}; "
                         f"last log lines: {' | '.join(process.tail(5)) or 'none'}")


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


def declare_interface(node: "NodeEngine", interface: Interface) -> Interface:
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


def discover(node: "NodeEngine", timeout: float = 10.0) -> Interface:
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


def _run_as_it_is(node: "NodeEngine", timeout: float, ask: Callable[[Interface], None]) -> Interface:
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
            raise _ended_at_start(model, probe) from None
        raise
    except KeyboardInterrupt:
        raise interrupted(f"running basenode {base_fullname(model)} as it is to read its interface",
                          "it was stopped") from None
    finally:
        probe.stop()


def learn_relayed_types(node: "NodeEngine", relays: list[RelaySpec], timeout: float = 10.0) -> None:
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


def _build_its_own_types(node: "NodeEngine", interface: Interface) -> None:
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


def report_unused_reuses(node: "NodeEngine", model: NodeModel, interface: Interface) -> None:
    """Say, once per start, which ``reuse`` declarations of ``model`` the settled basenode does not use (yet)."""
    unused = [f"reuse.{t.direction}({t.name!r})" for t in model.topics
              if t.role == "reuse" and not _uses(interface, t.direction, internal_name(model, t.resolved))]
    if unused:
        node.session.notify(f"ipyros: basenode {interface.node} does not use {', '.join(unused)} of {node.called} "
                             f"(yet): nothing is relayed there until it does ({_LATE}); if a name is wrong, "
                             f"{node.called}.remove('name') and declare the right one")
