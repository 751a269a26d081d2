"""Tab completion of topics, types, nodes, packages and executables, from cached data only.

One IPython matcher (Matcher API v2, identifier ``"ipyros"``) answers in two places:

* magic lines, e.g. ``%topics /tur<TAB>``, ``%topics --type geometry_msgs/Tw<TAB>``,
  ``%handler nd <TAB>``, ``%wrap turtle<TAB>``: each magic's own ``@argument`` decorators say what
  each word is (:mod:`.arguments`), read back from the parser IPython made of them;
* string arguments of DSL calls, e.g. ``nd.new.subscribe(topic="/tur<TAB>``,
  ``.publish(topic='/tu<TAB>`` on a continuation line, ``nd.write("<TAB>``,
  ``msgType="geometry_msgs/Tw<TAB>`` (see :data:`CALLS`).

Answers come from the :class:`~ipyros.tools.graph.GraphCache` snapshot (live topics, nodes,
services), from a :class:`Catalog` of installed types, packages and executables (scanned
from disk once, then cached), and from the DSL node models found in the user's
namespace. Never from the network, so a TAB press costs well under a millisecond of
ipyros time even with thousands of topics and the master gone.

The receiver of a DSL call is found by reading the code, never by running it: in
``wnode.new.subscribe(topic="`` only the plain name ``wnode`` is looked up in
``shell.user_ns``; if its class has a ``model()`` method returning a
:class:`~ipyros.core.model.NodeModel`, the node's own topics are offered first.

IPython facts this relies on: ``/`` is not a token delimiter but ``"'(=`` are, so the
token at ``subscribe(topic="/tur`` is ``/tur``; a matcher that answers sets
``suppress=True`` so Jedi and the file matcher do not add noise; ``ordered=True``
keeps our order (the node's own names first) instead of IPython's alphabetical sort.
"""

from __future__ import annotations

import logging
import re
import threading
import time
import types
from dataclasses import dataclass, field
from functools import lru_cache
from typing import Any, Callable, Mapping, Optional, Sequence

from IPython.core.completer import CompletionContext, SimpleCompletion, SimpleMatcherResult, context_matcher

from ..core import msgpath, msgtypes, names
from ..core.graph import GraphSnapshot, actions_of, names_with_prefix
from ..core.model import NodeModel
from ..core.msgbuild import template
from ..core.names import default_namespace
from ..node.session import current
from ..tools.graph import GraphCache
from ..tools import machines
from ..tools.machines import keepers_in, machine_names
from ..tools.robot import ROBOTS
from .arguments import (
    ACTION,
    ACTION_TYPE,
    DEMO_ROBOT,
    DSL_NODE,
    EXECUTABLE,
    MACHINE,
    FIELD,
    FUNCTION,
    GOAL_TEMPLATE,
    MSG_PATH,
    MSG_TEMPLATE,
    MSG_TYPE,
    NODE,
    OWN_TOPIC,
    PACKAGE,
    REQUEST_TEMPLATE,
    SERVICE,
    SRV_TYPE,
    TIMER,
    TOPIC,
    TRANSITION,
    grammar_of,
)

log = logging.getLogger(__name__)

#: The matcher's identifier: ``%config IPCompleter.disable_matchers = ["ipyros"]`` turns it off.
IDENTIFIER = "ipyros"

# -- the catalog of installed things ------------------------------------------------
@dataclass
class Catalog:
    """Where message/service types, packages and executables come from; results cached.

    Each source scans the disk, so it runs once (per package, for executables) and its
    sorted result is kept; :meth:`refresh` forgets them (after installing packages).
    Tests pass small fixed lists; :func:`default_catalog` wires the real scanners.
    """

    message_types: Callable[[], Sequence[str]]
    service_types: Callable[[], Sequence[str]]
    packages: Callable[[], Sequence[str]]
    executables: Callable[[str], Sequence[str]]
    templates: Callable[[str], str] = field(default=lambda msg_type: _template(msg_type))
    request_templates: Callable[[str], str] = field(default=lambda srv_type: _template(srv_type, request=True))
    action_types: Callable[[], Sequence[str]] = field(default=msgtypes.known_action_types)
    goal_templates: Callable[[str], str] = field(default=lambda action_type: template(
        msgtypes.action_messages(msgtypes.resolve_action(action_type)[1])[0]))
    #: What the keepers of other machines allow ({package: [executables]}): asked only when one is on the graph,
    #: kept for :data:`MACHINES_FOR` s.
    machine_packages: Callable[[], Mapping[str, Sequence[str]]] = field(default=lambda: {})

    def __post_init__(self) -> None:
        self._sources = (self.message_types, self.service_types, self.packages, self.executables, self.templates,
                         self.request_templates, self.action_types, self.goal_templates)
        self._machine_source = self.machine_packages
        self.refresh()

    def refresh(self) -> None:
        """Forget every cached scan; the next completion scans again."""
        types, srvs, pkgs, exes, templates, requests, actions, goals = self._sources
        self.message_types = _sorted_once(types)
        self.service_types = _sorted_once(srvs)
        self.packages = _sorted_once(pkgs)
        self.executables = lru_cache(maxsize=512)(lambda package: tuple(sorted(exes(package))))
        self.templates = lru_cache(maxsize=256)(templates)
        self.request_templates = lru_cache(maxsize=256)(requests)
        self.action_types = _sorted_once(actions)
        self.goal_templates = lru_cache(maxsize=256)(goals)
        self.machine_packages = _fresh_for(MACHINES_FOR, self._machine_source)

    def warm(self) -> None:
        """Run the whole-catalog scans now, so the first TAB does not pay for them."""
        try:
            self.message_types(), self.service_types(), self.packages()
        except Exception:  # a broken scanner shows up (at debug level) on TAB instead
            log.debug("warming the completion catalog failed", exc_info=True)


def _template(type_name: str, request: bool = False) -> str:
    """A message of ``type_name`` (or the request of the service ``type_name``) at its defaults, one line."""
    if not request:
        return template(type_name)
    _, cls = msgtypes.resolve_service(type_name)
    return template(cls._request_class if hasattr(cls, "_request_class") else cls.Request)


def _sorted_once(source: Callable[[], Sequence[str]]) -> Callable[[], tuple[str, ...]]:
    return lru_cache(maxsize=1)(lambda: tuple(sorted(source())))


#: How long what the keepers allow is kept before TAB asks them again (s).
MACHINES_FOR = 30.0


def _fresh_for(seconds: float, source: Callable[[], Any]) -> Callable[[], Any]:
    """``source()``, asked again once its last answer is ``seconds`` old."""
    kept: list[tuple[float, Any]] = []

    def fresh() -> Any:
        now = time.monotonic()
        if not kept or now - kept[0][0] > seconds:
            kept[:] = [(now, source())]
        return kept[0][1]

    return fresh


def default_catalog() -> Catalog:
    """The catalog of this machine: Python message modules on sys.path, and the ROS packages as
    the session's ROS runs them (``rosrun`` on ROS 1, ``ros2 run``'s ament index on ROS 2)."""
    backend = current().backend
    return Catalog(
        message_types=msgtypes.known_message_types,
        service_types=msgtypes.known_service_types,
        packages=backend.list_packages,
        executables=backend.list_executables,
        machine_packages=machines.allowed,
    )


# -- what is being completed --------------------------------------------------------
@dataclass(frozen=True)
class Want:
    """A decision about the text before the cursor: complete ``fragment`` as a ``kind``.

    ``fragment`` is the part of the line the completions replace (a suffix of the text
    before the cursor). ``model`` is the DSL node in play, if any; ``direction`` picks
    which of its topics come first ("publish", "subscribe" or None for all);
    ``package`` is the package whose executables are wanted; ``before`` the positional
    words before the one typed (``%pub``'s topic, then its type).
    """

    kind: str
    fragment: str
    model: Optional[NodeModel] = None
    direction: Optional[str] = None
    package: Optional[str] = None
    before: tuple[str, ...] = ()


@dataclass(frozen=True)
class CallSpec:
    """What the string arguments of a DSL method are, by position and by keyword.

    ``direction`` says which of the node's topics come first for a TOPIC/OWN_TOPIC
    argument (None: all of them). ``needs_node``: answer only when the receiver is a
    DSL node (``f.write("`` on a file is none of our business).
    """

    positional: tuple[Optional[str], ...] = ()
    keywords: Mapping[str, str] = field(default_factory=dict)
    direction: Optional[str] = None
    needs_node: bool = False


_MSG_KEYWORDS = {"topic": TOPIC, "msgType": MSG_TYPE, "type": MSG_TYPE}

#: The methods whose string arguments are completed (the DSL's, and rospy's own).
CALLS: dict[str, CallSpec] = {
    "subscribe": CallSpec((TOPIC, None, MSG_TYPE, MSG_TYPE), _MSG_KEYWORDS, "subscribe"),
    "publish": CallSpec((TOPIC, MSG_TYPE, MSG_TYPE), _MSG_KEYWORDS, "publish"),
    "write": CallSpec((TOPIC,), {"topic": TOPIC}, "publish", needs_node=True),
    "unsubscribe": CallSpec((OWN_TOPIC,), {"topic": OWN_TOPIC}, "subscribe"),
    "unpublish": CallSpec((OWN_TOPIC,), {"topic": OWN_TOPIC}, "publish"),
    "handler": CallSpec((OWN_TOPIC,), {"topic": OWN_TOPIC}, "subscribe", needs_node=True),
    "remove": CallSpec((OWN_TOPIC,), {"topic": OWN_TOPIC, "timer": TIMER, "service": SERVICE, "action": ACTION},
                       needs_node=True),
    "action": CallSpec((ACTION, ACTION_TYPE), {"name": ACTION, "type": ACTION_TYPE, "actionType": ACTION_TYPE},
                       needs_node=True),
    "send_goal": CallSpec((ACTION,), {"name": ACTION, "type": ACTION_TYPE}, needs_node=True),
    "service": CallSpec((SERVICE, SRV_TYPE, None, SRV_TYPE), {"name": SERVICE, "srvType": SRV_TYPE, "type": SRV_TYPE},
                        needs_node=True),
    "baseNode": CallSpec((EXECUTABLE,), {"executable": EXECUTABLE}),
    "basePackage": CallSpec((PACKAGE,), {"package": PACKAGE}),
    "machine": CallSpec((MACHINE,), {"name": MACHINE}, needs_node=True),
    "guard": CallSpec((OWN_TOPIC,), {"topic": OWN_TOPIC, "machine": MACHINE, "estop_topic": TOPIC}, "publish",
                      needs_node=True),
    "Subscriber": CallSpec((TOPIC,)),
    "Publisher": CallSpec((TOPIC,)),
    "wait_for_message": CallSpec((TOPIC,)),
}

#: Keywords so specific to ROS that any call with them is answered, DSL or not.
_ROS_KEYWORDS = {"msgType": MSG_TYPE, "msg_type": MSG_TYPE, "srvType": SRV_TYPE, "srv_type": SRV_TYPE}


# -- reading magic lines --------------------------------------------------------------
_MAGIC_LINE = re.compile(r"^\s*(%?)([A-Za-z_]\w*)\s+(.*)$", re.S)


def magic_want(line: str, user_ns: Mapping[str, Any], line_magics: Mapping[str, Any],
               automagic: bool = True) -> Optional[Want]:
    """What to complete at the end of ``line`` if it calls one of ``line_magics`` (the shell's) whose arguments
    say what they complete (:mod:`.arguments`), else None.

    Without ``%`` the line counts only when automagic would run it: the name is a magic
    and no variable shadows it.
    """
    m = _MAGIC_LINE.match(line)
    if not m:
        return None
    percent, name, args = m.groups()
    if not percent and (not automagic or name in user_ns):
        return None
    magic = line_magics.get(name)
    grammar = grammar_of(magic) if magic is not None else None
    if grammar is None:
        return None
    words = args.split()
    current = "" if not args or args[-1].isspace() else words.pop()
    word, positionals = grammar.classify(words, current)
    if word is None or word.kind is None:
        return None
    kind = word.kind
    # The value of --opt=value or a remap from:=to: only the part after the last = or :.
    fragment = re.split(r"[=:]", current)[-1] if current.startswith("-") or ":=" in current else current
    model = _model_of(user_ns, positionals[0]) if kind == OWN_TOPIC and positionals else None
    package = positionals[0] if kind == EXECUTABLE and positionals else None
    return Want(kind, fragment, model, word.direction, package, tuple(positionals))


# -- reading DSL calls ----------------------------------------------------------------
@dataclass(frozen=True)
class StringArgument:
    """An unfinished one-line string literal, passed as an argument of a call.

    For ``nd.new.subscribe(topic="/tur``: ``fragment="/tur"``, ``keyword="topic"``,
    ``index=0`` (top-level commas before it), ``chain=("nd", "new", "subscribe")``
    (attribute names from the root, calls skipped), ``root_called=False``.
    """

    fragment: str
    keyword: Optional[str]
    index: int
    chain: tuple[str, ...]
    root_called: bool


_ARG_START = re.compile(r"\s*(?:([A-Za-z_]\w*)\s*=\s*)?[rRuU]?$")


def string_argument(source: str) -> Optional[StringArgument]:
    """Read ``source`` (a cell up to the cursor) and describe the string argument it ends in.

    A small scanner, not a parser: it tracks strings, comments and brackets, which is
    all it takes to find the call around the cursor across continuation lines.
    """
    stack: list[list[int]] = []  # [open position, top-level commas, start of the current argument]
    pairs: dict[int, int] = {}  # closing bracket position → its opening position
    i, n = 0, len(source)
    while i < n:
        c = source[i]
        if c == "#":
            end = source.find("\n", i)
            i = n if end < 0 else end
        elif c in "\"'":
            quote = c * 3 if source.startswith(c * 3, i) else c
            end = _string_end(source, i + len(quote), quote)
            if end is None:  # the string runs to the cursor: this is the one being typed
                return None if len(quote) == 3 else _argument_at(source, i, stack, pairs)
            i = end
            continue
        elif c in "([{":
            stack.append([i, 0, i + 1])
        elif c in ")]}":
            if stack:
                pairs[i] = stack.pop()[0]
        elif c == "," and stack:
            stack[-1][1] += 1
            stack[-1][2] = i + 1
        i += 1
    return None


def _string_end(source: str, i: int, quote: str) -> Optional[int]:
    """Position after the literal's closing quote; None if it is still open at the end."""
    n = len(source)
    while i < n:
        c = source[i]
        if c == "\\":
            i += 2
        elif source.startswith(quote, i):
            return i + len(quote)
        elif c == "\n" and len(quote) == 1:
            return i + 1  # an unterminated one-line string: a syntax error, skip past it
        else:
            i += 1
    return None


def _argument_at(source: str, quote_at: int, stack: list[list[int]], pairs: dict[int, int]) -> Optional[StringArgument]:
    if not stack or source[stack[-1][0]] != "(":
        return None
    paren, commas, arg_start = stack[-1]
    m = _ARG_START.match(source, arg_start, quote_at)
    if not m:
        return None  # e.g. "a" + "b", or a string inside an expression: not an argument by itself
    chain = _call_chain(source, paren, pairs)
    if chain is None:
        return None
    names, root_called = chain
    return StringArgument(source[quote_at + 1:], m.group(1), commas, names, root_called)


def _call_chain(source: str, paren: int, pairs: dict[int, int]) -> Optional[tuple[tuple[str, ...], bool]]:
    """The dotted names before ``source[paren]``: ``a.b(x).c(`` → (("a", "b", "c"), False)."""
    names: list[str] = []
    called = True  # the name right before `paren` is the one being called
    j = paren
    while True:
        end = _skip_space_back(source, j)
        start = end
        while start > 0 and (source[start - 1].isalnum() or source[start - 1] == "_"):
            start -= 1
        if start == end or source[start].isdigit():
            return None
        names.append(source[start:end])
        dot = _skip_space_back(source, start)
        if dot == 0 or source[dot - 1] != ".":
            return tuple(reversed(names)), called
        before = _skip_space_back(source, dot - 1)
        if before > 0 and source[before - 1] == ")" and before - 1 in pairs:
            j, called = pairs[before - 1], True
        else:
            j, called = before, False


def _skip_space_back(source: str, j: int) -> int:
    """The position just after the last non-space character before ``j``."""
    while j > 0 and source[j - 1].isspace():
        j -= 1
    return j


def call_want(arg: StringArgument, user_ns: Mapping[str, Any]) -> Optional[Want]:
    """What to complete in the string argument ``arg``, or None if it is not ours."""
    method, root = arg.chain[-1], arg.chain[0]
    model = None if arg.root_called or len(arg.chain) < 2 else _model_of(user_ns, root)
    spec = CALLS.get(method)
    kind: Optional[str] = None
    if spec is not None and (model is not None or not spec.needs_node):
        if arg.keyword is not None:
            kind = spec.keywords.get(arg.keyword)
        elif arg.index < len(spec.positional):
            kind = spec.positional[arg.index]
    elif model is not None and arg.keyword is not None:
        kind = {**_MSG_KEYWORDS, **_ROS_KEYWORDS}.get(arg.keyword)
    if kind is None and arg.keyword in _ROS_KEYWORDS:
        kind = _ROS_KEYWORDS[arg.keyword]
    if kind is None:
        return None
    package = model.base.package if kind == EXECUTABLE and model is not None and model.base else None
    return Want(kind, arg.fragment, model, spec.direction if spec else None, package)


def _model_of(user_ns: Mapping[str, Any], name: str) -> Optional[NodeModel]:
    """The NodeModel of the DSL node held by variable ``name``; a dict lookup, nothing evaluated."""
    obj = user_ns.get(name)
    if not is_dsl_node(obj):
        return None
    try:
        model = obj.model()
    except Exception:  # a broken object must not break TAB
        log.debug("%s.model() failed", name, exc_info=True)
        return None
    return model if isinstance(model, NodeModel) else None


def is_dsl_node(obj: Any) -> bool:
    """Whether ``obj`` looks like a DSL node: its class has a ``model()`` method."""
    return obj is not None and not isinstance(obj, type) and callable(getattr(type(obj), "model", None))


# -- answering ------------------------------------------------------------------------
@dataclass(frozen=True)
class Asked:
    """One TAB's question, as each answer of :data:`_ANSWERS` gets it."""

    want: Want
    snap: GraphSnapshot
    user_ns: Mapping[str, Any]
    limit: Optional[int]


def _words(kind: str, words: Callable[[Asked], Sequence[str]]) -> Callable[["Answerer", Asked], list[tuple[str, str]]]:
    """An answer offering ``words(asked)`` that start with the fragment typed, each described as ``kind``."""
    return lambda answerer, asked: [(w, kind) for w in words(asked) if w.startswith(asked.want.fragment)]


class Answerer:
    """Turns a :class:`Want` into completions, from the graph snapshot, the catalog and user_ns.

    Each completion carries a short description IPython shows beside it: the message
    type of a topic (when known), else what kind of name it is.
    """

    def __init__(self, graph: GraphCache, catalog: Catalog):
        self.graph = graph
        self.catalog = catalog

    def completions(self, want: Want, user_ns: Mapping[str, Any],
                    limit: Optional[int] = None) -> list[SimpleCompletion]:
        """The completions, the first ``limit`` of them if given (IPython shows 500 at most: with 10,000
        live topics, making the other 9,500 would be most of a TAB's time)."""
        found = self._found(want, user_ns, limit)
        seen: set[str] = set()
        out = []
        for text, meta in found:
            if text not in seen:  # the node's own name first, the live duplicate dropped
                seen.add(text)
                out.append(SimpleCompletion(text, type=meta))
                if len(out) == limit:
                    break
        return out

    def _found(self, want: Want, user_ns: Mapping[str, Any], limit: Optional[int] = None) -> list[tuple[str, str]]:
        """What the kind of word wanted is answered with: a path's fields where the word is a message path, else
        the answer of :data:`_ANSWERS` for its kind (none for a kind it lacks)."""
        snap, frag, kind = self.graph.snapshot, want.fragment, want.kind
        if kind == FIELD and not frag.startswith("/"):  # %plot TOPIC linear.<TAB>: a field of that topic
            fields = msgpath.complete(self._carried(want.before[0], snap), "." + frag) if want.before else []
            return [(text[1:], meta) for text, meta in fields]
        if kind in (MSG_PATH, FIELD) and msgpath.is_path(frag):  # %echo /odom.pose.<TAB>: the fields there
            topic, into = msgpath.split_topic(frag)
            return [(topic + text, meta) for text, meta in msgpath.complete(self._carried(topic, snap), into)]
        answer = _ANSWERS.get(kind)
        return answer(self, Asked(want, snap, user_ns, limit)) if answer is not None else []

    def _timers(self, asked: "Asked") -> list[tuple[str, str]]:
        timers = asked.want.model.timers if asked.want.model else []
        return sorted((t.name, TIMER) for t in timers if t.name.startswith(asked.want.fragment))

    def _nodes(self, asked: "Asked") -> list[tuple[str, str]]:
        nodes = _relative_or_global(asked.snap.nodes, asked.want.fragment, "/")
        return [(n, _stale(NODE, asked.snap)) for n, _ in nodes]

    def _in_namespace(self, asked: "Asked", fits: Callable[[Any], bool], meta: Callable[[Any], str]
                      ) -> list[tuple[str, str]]:
        """The user's variables whose value ``fits`` (a DSL node, a function), by the fragment typed."""
        frag = asked.want.fragment
        return sorted((k, meta(v)) for k, v in list(asked.user_ns.items())
                      if k.startswith(frag) and not k.startswith("_") and fits(v))

    def _message_types(self, asked: "Asked") -> list[tuple[str, str]]:
        want, frag = asked.want, asked.want.fragment
        found = [(t, MSG_TYPE) for t in _types(self.catalog.message_types(), frag)]
        live = asked.snap.topics.get(_global(want.before[0])) if want.before else None
        if live and live.startswith(frag):  # %pub TOPIC <TAB>: the type the topic carries, first
            found = [(live, f"carried by {_global(want.before[0])}")] + [f for f in found if f[0] != live]
        return found

    def _template(self, asked: "Asked", make: Callable[[str], str], what: str) -> list[tuple[str, str]]:
        """A whole message (or request) at its defaults for the type before it: offered before anything is typed,
        as it replaces nothing; an unknown type offers none (the magic itself says so, in one line)."""
        want = asked.want
        if want.fragment or len(want.before) < 2:
            return []
        try:
            return [(make(want.before[1]), f"{want.before[1]}{what}")]
        except Exception:  # noqa: BLE001 - an unknown type: the magic says so
            return []

    def _packages(self, asked: "Asked") -> list[tuple[str, str]]:
        placed = self._placed(asked.snap)  # a keeper's packages need not be here
        return [(p, PACKAGE if p not in placed or p in self.catalog.packages() else "package on a machine")
                for p in names_with_prefix(sorted({*self.catalog.packages(), *placed}), asked.want.fragment)]

    def _executables(self, asked: "Asked") -> list[tuple[str, str]]:
        package = asked.want.package
        if not package:
            return []
        here = self._executables_here(package)
        there = self._placed(asked.snap).get(package, ())
        return [(e, EXECUTABLE if e in here else "executable on a machine")
                for e in names_with_prefix(sorted({*here, *there}), asked.want.fragment)]

    def _placed(self, snap: GraphSnapshot) -> Mapping[str, Sequence[str]]:
        """What the keepers on the graph allow (asked only when one is there)."""
        if not keepers_in(snap.topics):
            return {}
        try:
            return self.catalog.machine_packages()
        except Exception:  # a keeper that does not answer: nothing more to offer
            log.debug("asking the keepers what they allow failed", exc_info=True)
            return {}

    def _executables_here(self, package: str) -> Sequence[str]:
        try:
            return self.catalog.executables(package)
        except Exception:  # a package this machine does not have (a keeper's): none here
            return ()

    @staticmethod
    def _carried(topic: str, snap: GraphSnapshot) -> Any:
        """The message class of the type ``topic`` carries (the graph's), or None if unknown here."""
        type_name = snap.topics.get(_global(topic))
        try:
            return msgtypes.resolve_message(type_name)[1] if type_name else None
        except Exception:  # a type this Python lacks: nothing to offer
            return None

    def _action_words(self, want: Want, snap: GraphSnapshot) -> list[tuple[str, str]]:
        """``%action NAME <TAB>``: the live action's type first, then every action type; after the
        type (or after a name whose type the graph knows), the goal at its defaults."""
        frag = want.fragment
        live = next((a.type for a in actions_of(snap) if want.before and a.name == _global(want.before[0])), None)
        if want.kind == ACTION_TYPE:
            found = [(t, ACTION_TYPE) for t in _types(self.catalog.action_types(), frag)]
            if live and live.startswith(frag):
                found = [(live, f"type of {_global(want.before[0])}")] + [f for f in found if f[0] != live]
            if not frag and live:  # the type may be left out: the goal itself is offered too
                found += self._action_words(Want(GOAL_TEMPLATE, "", before=want.before), snap)
            return found
        action_type = want.before[1] if len(want.before) > 1 else live
        if frag or not action_type:
            return []
        try:
            return [(self.catalog.goal_templates(action_type), f"{action_type} goal, at its defaults")]
        except Exception:  # an unknown type: %action itself will say so, in one line
            return []

    def _topics(self, want: Want, snap: GraphSnapshot, limit: Optional[int] = None) -> list[tuple[str, str]]:
        model, frag = want.model, want.fragment
        namespace = model.namespace if model is not None else default_namespace()
        own = _own(model.topics if model else [], want.direction, frag, namespace)
        if want.kind == OWN_TOPIC and model is not None:
            return own
        # enough live names for the limit even if each of the node's own is among them (dropped as a duplicate)
        live = _relative_or_global(snap.topic_names, frag, namespace, None if limit is None else limit + len(own))
        return own + [(text, _stale(snap.topics[name] or TOPIC, snap)) for text, name in live]

    def _services(self, want: Want, snap: GraphSnapshot) -> list[tuple[str, str]]:
        model, frag = want.model, want.fragment
        namespace = model.namespace if model is not None else default_namespace()
        own = _own(model.services if model else [], None, frag, namespace)
        return own + [(text, _stale(SERVICE, snap)) for text, _ in _relative_or_global(tuple(snap.services), frag,
                                                                                        namespace)]


#: Per kind of word wanted, how a TAB answers it (the kinds of :mod:`ipyros.ipython.arguments`).
_ANSWERS: dict[str, Callable[[Answerer, Asked], list[tuple[str, str]]]] = {
    **dict.fromkeys((TOPIC, OWN_TOPIC, MSG_PATH, FIELD), lambda a, q: a._topics(q.want, q.snap, q.limit)),
    SERVICE: lambda a, q: a._services(q.want, q.snap),
    TIMER: Answerer._timers,
    NODE: Answerer._nodes,
    DSL_NODE: lambda a, q: a._in_namespace(q, is_dsl_node, lambda v: type(v).__name__),
    FUNCTION: lambda a, q: a._in_namespace(q, lambda v: isinstance(v, types.FunctionType), lambda v: FUNCTION),
    MSG_TYPE: Answerer._message_types,
    MSG_TEMPLATE: lambda a, q: a._template(q, a.catalog.templates, ", every field at its default"),
    REQUEST_TEMPLATE: lambda a, q: a._template(q, a.catalog.request_templates, " request, at its defaults"),
    SRV_TYPE: lambda a, q: [(t, SRV_TYPE) for t in _types(a.catalog.service_types(), q.want.fragment)],
    ACTION: lambda a, q: [(x.name, x.type) for x in actions_of(q.snap)
                          if x.name.startswith(_global(q.want.fragment) if q.want.fragment else "/")],
    **dict.fromkeys((ACTION_TYPE, GOAL_TEMPLATE), lambda a, q: a._action_words(q.want, q.snap)),
    # the standard transitions: asking the node which it offers now would wait on it
    TRANSITION: _words(TRANSITION, lambda q: ("configure", "cleanup", "activate", "deactivate", "shutdown")),
    PACKAGE: Answerer._packages,
    DEMO_ROBOT: _words(DEMO_ROBOT, lambda q: list(ROBOTS)),
    MACHINE: _words(MACHINE, lambda q: machine_names(q.snap.topics)),
    EXECUTABLE: Answerer._executables,
}


def _stale(meta: str, snap: GraphSnapshot) -> str:
    """A completion's description, saying so when it comes from the last graph of a master now down."""
    if not snap.stale:
        return meta
    return f"{meta} (master down; as of {time.strftime('%H:%M:%S', time.localtime(snap.known_at))})"


def _global(name: str) -> str:
    return names.resolve(name, default_namespace(), "ipyros", "topic") if name else name


def _own(declared: Sequence[Any], direction: Optional[str], fragment: str, namespace: str) -> list[tuple[str, str]]:
    """The node's declared topics/services matching ``fragment``, sorted, with their types."""
    found = []
    for d in declared:
        if direction is None or d.direction == direction:
            text = _as_typed(d.name, d.resolved, fragment, namespace)
            if text.startswith(fragment):
                found.append((text, d.type))
    return sorted(found)


def _as_typed(name: str, resolved: str, fragment: str, namespace: str) -> str:
    """How to offer a declared name: global if the user types a global name, else as declared."""
    if fragment.startswith("/"):
        return resolved
    if fragment and not fragment.startswith("~") and name.startswith("/"):
        ns = names.global_ns(namespace)
        return resolved[len(ns):] if resolved.startswith(ns) else resolved
    return name


def _relative_or_global(sorted_names: Sequence[str], fragment: str, namespace: str,
                        limit: Optional[int] = None) -> list[tuple[str, str]]:
    """(text, global name) pairs, the first ``limit`` if given: global names for ``""`` or ``/x``; for a
    relative ``x``, the names in ``namespace`` that it starts, written relative to it."""
    if not fragment or fragment.startswith("/"):
        return [(n, n) for n in names_with_prefix(sorted_names, fragment)[:limit]]
    if fragment.startswith("~"):
        return []  # private names only make sense for the node's own declarations
    ns = names.global_ns(namespace)
    return [(n[len(ns):], n) for n in names_with_prefix(sorted_names, ns + fragment)[:limit]]


_LONG_TYPE = re.compile(r"(\w+)/(msg|srv)/(.*)")


def _types(known: Sequence[str], fragment: str) -> list[str]:
    """``geometry_msgs/Tw`` by prefix; a bare ``Tw`` also finds ``geometry_msgs/Twist``; ROS 2's
    long form ``geometry_msgs/msg/Tw`` is answered in that form (``known`` has the short one)."""
    long_form = _LONG_TYPE.match(fragment)
    if long_form:
        package, kind, rest = long_form.groups()
        return [t.replace("/", f"/{kind}/", 1) for t in names_with_prefix(known, f"{package}/{rest}")]
    found = names_with_prefix(known, fragment)
    if "/" not in fragment and fragment:
        found += [t for t in known if t.partition("/")[2].startswith(fragment)]
    return found


# -- the IPython side -----------------------------------------------------------------
#: The answer when the text is ours but nothing matches (see RosMatcher.__call__).
NOTHING = SimpleCompletion("", type="no match")


class RosMatcher:
    """The matcher object: decides whether a completion is ours and answers it.

    ``__call__`` takes what a Matcher API v2 matcher takes and returns what it returns;
    :func:`install` wraps it in a ``context_matcher`` function for IPython.
    """

    def __init__(self, shell: Any, graph: GraphCache, catalog: Catalog):
        self.shell = shell
        self.answerer = Answerer(graph, catalog)
        #: JupyterLab shows a completion's type in lower case (a message type would read
        #: ``geometry_msgs/twist``, which is no type): in a kernel the type says the kind of name.
        self.kinds_only = getattr(shell, "kernel", None) is not None

    def want(self, context: CompletionContext) -> Optional[Want]:
        """The decision for this context, or None when another matcher should answer."""
        user_ns = self.shell.user_ns
        line = context.text_until_cursor
        manager = getattr(self.shell, "magics_manager", None)
        line_magics = manager.magics["line"] if manager is not None else {}
        # Without automagic a bare "topics /x" is Python, not a magic.
        want = magic_want(line, user_ns, line_magics, automagic=bool(getattr(self.shell, "automagic", False)))
        if want is None and ('"' in line or "'" in line):
            lines = context.full_text.split("\n")[: context.cursor_line]
            arg = string_argument("\n".join([*lines, line]))
            want = call_want(arg, user_ns) if arg is not None else None
        return want

    def __call__(self, context: CompletionContext) -> SimpleMatcherResult:
        try:
            want = self.want(context)
            if want is None:
                return SimpleMatcherResult(completions=[], suppress=False)
            completions = self.answerer.completions(want, self.shell.user_ns, context.limit)
            if self.kinds_only:
                completions = [SimpleCompletion(c.text, type=want.kind) for c in completions]
        except Exception:  # TAB must never show a traceback; say why at debug level
            log.debug("ipyros completion failed", exc_info=True)
            return SimpleMatcherResult(completions=[], suppress=False)
        if not completions:
            # IPython lets a matcher suppress the others only if it has a completion, so
            # "no such topic" would bring in file names (``%topics /`` listing the disk
            # when the master is down). One empty completion replacing nothing says
            # "nothing" and keeps them out: the terminal skips empty texts.
            return SimpleMatcherResult(completions=[NOTHING], matched_fragment="", suppress=True)
        return SimpleMatcherResult(
            completions=completions, matched_fragment=want.fragment, suppress=True, ordered=True
        )


@dataclass(frozen=True)
class Installed:
    """What :func:`install` returns; give it to :func:`uninstall`."""

    matcher: Callable[[CompletionContext], SimpleMatcherResult]  # the function in custom_matchers
    ros: RosMatcher
    warming: threading.Thread  # the catalog's first scans; joined, it is warm

    def warm(self, timeout: float) -> bool:
        """Wait up to ``timeout`` s for the catalog's first scans; True once they are done."""
        self.warming.join(timeout)
        return not self.warming.is_alive()


def install(shell: Any, graph: GraphCache, catalog: Optional[Catalog] = None) -> Installed:
    """Add the ipyros matcher to ``shell``'s completer (the real catalog if none is given).

    The catalog's disk scans start at once in a short-lived background thread.
    """
    catalog = catalog or default_catalog()
    warming = threading.Thread(target=catalog.warm, name="ipyros-catalog-warm", daemon=True)
    warming.start()
    ros = RosMatcher(shell, graph, catalog)

    # A plain function: IPython reads __qualname__ and the attributes context_matcher sets.
    @context_matcher(identifier=IDENTIFIER)
    def ipyros_matcher(context: CompletionContext) -> SimpleMatcherResult:
        return ros(context)

    shell.Completer.custom_matchers.append(ipyros_matcher)
    return Installed(ipyros_matcher, ros, warming)


def uninstall(shell: Any, handle: Installed) -> None:
    """Remove the matcher that :func:`install` added; harmless if it is already gone."""
    matchers = shell.Completer.custom_matchers
    if handle.matcher in matchers:
        matchers.remove(handle.matcher)
