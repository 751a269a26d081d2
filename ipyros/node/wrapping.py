"""Wrapping: a node that wraps a basenode (paper section III, figure 1), as declared.

Which endpoints run is decided in :mod:`ipyros.core.plan`, and how names resolve and remap
in :mod:`ipyros.core.remapping`. This module declares the basenode, checking what it is given (an executable, a
launch file's node, a bag played, a machine it runs on), and says in one line what its start says when it fails.
Starting it is :mod:`.basestart`'s; reading a running basenode's interface from the graph and declaring it all as
``reuse`` in one call is :mod:`.baseinterface`'s.

A basenode may also come from a launch file (:func:`set_launch_base`, read by the
backend): then ``create()`` runs the rest of that file too, and ``nd.base`` stops both.
Running it, reading its interface and finding its package are the backend's
(``basenode``, ``wait_for_node``): the same here for both ROS.
"""

from __future__ import annotations

import os
import re
from pathlib import Path
from typing import Any, Callable, Optional, Protocol

from ..core import names
from ..core.errors import BaseNodeError, DeclarationError, cut
from ..core.model import BaseModel, NodeModel
from ..core.remapping import base_fullname, reresolve
from ..core.guard import DEFAULT_MACHINE_GRACE
from ..processes.basenode import BaseHandle, exit_reason
from ..processes.keeper import MachineError, Token, check_machine_name, token_path
from ..processes.playback import player_args
from .placedbase import placed_problem


class WrappingNode(Protocol):
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

def set_base(node: "WrappingNode", **fields: Any) -> None:
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


def set_machine(node: "WrappingNode", machine: Optional[str], grace: Optional[float] = DEFAULT_MACHINE_GRACE) -> None:
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


def _own_name(node: "WrappingNode", fields: dict[str, Any]) -> Optional[str]:
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


def set_launch_base(node: "WrappingNode", launch: Any, node_name: str, args: Optional[dict] = None) -> None:
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


def set_bag(node: "WrappingNode", path: Any, rate: float, loop: bool, topics: Optional[list[str]],
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


# -- what a basenode's start says when it fails (its start: basestart; its interface read: baseinterface) --

def interrupted(doing: str, outcome: str) -> BaseNodeError:
    """Ctrl-C while ``doing``, said in one line (not a traceback from inside a wait): what was stopped."""
    return BaseNodeError(f"Ctrl-C while {doing}: {outcome}; nothing is left half-declared")


def ended_at_start(model: NodeModel, process: Any, what_now: str = "") -> BaseNodeError:
    """The one line for a basenode that ended before it settled: how, and its last log lines."""
    return BaseNodeError(f"basenode {base_fullname(model)} {exit_reason(process.returncode or 0)} at start{what_now}; "
                         f"last log lines: {' | '.join(process.tail(5)) or 'none'}")
