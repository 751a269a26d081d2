"""What the magics ask, answered once for all of them (ros2cli's ``api/``): a magic parses its line,
calls these and the tools, and renders what it gets.

The live graph read afresh and checked, a live topic's type (waited for, as rostopic
does), a topic/field path split, the session's DSL nodes named in the graph; the user's
node by variable, an expression in the user's namespace, a topic name made global; and
a magic line split into its options and its free text (YAML, an expression).
"""

from __future__ import annotations

import difflib
import re
import time
from typing import Any, Callable, Optional, Protocol

from IPython.core.error import UsageError

from ..core import msgpath, names
from ..core.graph import GraphSnapshot
from ..dsl import node_of, rosNode
from ..node.session import Session, current
from ..tools.graph import GraphCache, as_dsl_nodes, live_graph as graph_now
from ..tools.probe import PromptPublisher

__all__ = ["Host", "as_dsl_nodes", "close_names", "compile_filter", "evaluate", "find_node", "global_topic", "live_graph",
           "live_type", "node_name", "option_words", "split_head", "topic_and_field", "type_once_live"]


class Host(Protocol):
    """What the magics use of the extension that loads them (:class:`~ipyros.ipython.extension.Extension`;
    a protocol, so that the magics do not import the extension that imports them)."""

    session: Session
    graph: GraphCache
    publisher: PromptPublisher
    settings: Any  # the RosMagics configurable (magics/config.py)
    printer: Any  # magics/output.py's Printer: rich in a terminal, HTML in Jupyter
    #: While a file is loaded into user_ns: the namespace as it was, whose variables advice names.
    names_before: Optional[dict]


# -- the live graph ----------------------------------------------------------------------------
def live_graph(host: Host) -> GraphSnapshot:
    """The graph read afresh (a master that just restarted gets the session registered again first)."""
    return graph_now(host.session.backend, host.graph)

def topic_and_field(snap: GraphSnapshot, name: str) -> tuple[str, str]:
    """``/turtle1/pose/position.x`` → ``("/turtle1/pose", "position.x")``, as rostopic echo reads a
    field path; a name that is a live topic, or has no live topic in it, stays whole."""
    if name in snap.topics:
        return name, ""
    parts = name.split("/")
    for cut in range(len(parts) - 1, 1, -1):
        topic = "/".join(parts[:cut])
        if topic in snap.topics:
            return topic, ".".join(parts[cut:])
    return name, ""

def type_once_live(host: Host, topic: str, poll: float = 0.5) -> Optional[str]:
    """The type of ``topic``, waiting (said once) while nobody publishes it, as rostopic echo
    waits; None if Ctrl-C ends the wait."""
    snap = live_graph(host)
    if snap.topics.get(topic) not in (None, "", "*"):
        return snap.topics[topic]
    close = close_names(topic, snap.topic_names)
    print(f"ipyros: {topic} is not published yet{close}; waiting for it (Ctrl-C stops)", flush=True)
    try:
        while True:
            time.sleep(poll)
            found = host.graph.refresh_now().topics.get(topic)
            if found not in (None, "", "*"):
                return found
    except KeyboardInterrupt:
        print(f"stopped waiting for {topic}")
        return None

def live_type(host: Host, topic: str, for_pub: bool = False, snap: Optional[GraphSnapshot] = None) -> str:
    """The type of the live ``topic`` from the graph read afresh (or from ``snap``, read once for
    several topics); a one-line error if there is none."""
    snap = snap if snap is not None else live_graph(host)
    if topic not in snap.topics:
        fix = f"; give its type: %pub {topic} pkg/Type ..." if for_pub else "; %topics lists them"
        raise UsageError(f"no live topic {topic}{close_names(topic, snap.topic_names)}{fix}")
    type_name = snap.topics[topic]
    if not type_name or type_name == "*":
        raise UsageError(f"the master does not know the type of {topic} yet; try again in a moment")
    return type_name


def close_names(name: str, known: Any) -> str:
    close = difflib.get_close_matches(name, list(known), n=3)
    return f" (did you mean {', '.join(close)}?)" if close else ""


def node_name(name: str) -> str:
    return name if name.startswith("/") else "/" + name


# -- the user's namespace and names -----------------------------------------------------------

def find_node(shell: Any, name: str) -> rosNode:
    """The rosNode a magic argument names: a variable of the user's, else a session node's name."""
    value = shell.user_ns.get(name)
    if isinstance(value, rosNode):
        return value
    if value is not None:
        raise UsageError(f"{name} is a {type(value).__name__}, not a rosNode; "
                         f"give the variable that holds the node ({_node_variables(shell)})")
    wanted = name if name.startswith("/") else None
    for engine in current().nodes.values():
        if engine.fullname == wanted or engine.name == name:
            return node_of(engine)
    raise UsageError(f"no rosNode called {name!r}; give the variable that holds the node "
                     f"({_node_variables(shell)})")


def _node_variables(shell: Any) -> str:
    names = [k for k, v in shell.user_ns.items() if isinstance(v, rosNode) and not k.startswith("_")]
    return "rosNode variables here: " + ", ".join(sorted(names)) if names else "there is no rosNode variable yet"


def evaluate(shell: Any, expression: str, what: str) -> Any:
    """``expression`` evaluated in the user's namespace; a NameError becomes a UsageError."""
    try:
        return shell.ev(expression)
    except NameError as error:
        raise UsageError(f"{what}: {error}") from None
    except SyntaxError as error:
        raise UsageError(f"{what}: {expression!r} is not a Python expression ({error.msg})") from None


def global_topic(name: str) -> str:
    """A topic name typed at a magic, made global as rostopic does (``chatter`` → ``/chatter``).

    Relative names resolve in ``ROS_NAMESPACE``; an invalid name is a one-line error.
    """
    return names.resolve(name, names.default_namespace(), "ipyros", "topic")


def compile_filter(expression: str, namespace: dict) -> Any:
    """``--filter EXPR`` compiled once; the returned test, ``keep(msg, number=None, **names)``, says whether to keep
    message ``m`` (``number``: which it is, counted if not given; ``names``: more the expression may read, a bag's
    ``topic`` and ``t``)."""
    expression = expression.strip()
    if len(expression) > 1 and expression[0] == expression[-1] and expression[0] in "'\"":
        expression = expression[1:-1]  # IPython's argument split keeps the quotes
    if expression.startswith("/"):
        return _path_filter(expression, namespace)
    try:
        code = compile(expression, "<%echo --filter>", "eval")
    except SyntaxError as error:
        raise UsageError(f"--filter {expression!r} is not a Python expression ({error.msg}); "
                         "write one over the message m, e.g. --filter 'm.linear.x > 0'") from None

    counted = iter(range(1, 1 << 62))

    def keep(msg: Any, number: Optional[int] = None, **names: Any) -> bool:
        number = next(counted) if number is None else number  # which message it is, for the error line
        try:
            return bool(eval(code, namespace, {"m": msg, **names}))  # noqa: S307 - the user's own expression
        except Exception as error:  # noqa: BLE001 - said in one line, and the listening stops
            raise UsageError(f"--filter {expression!r} raised {type(error).__name__}: {error} on message "
                             f"{number}; fix the expression (the message is m)") from None

    return keep


def _path_filter(expression: str, namespace: dict) -> Any:
    """``--filter '/cmd_vel{linear.x!=0}'``: a message path as a filter, Foxglove's way: a message of its topic is
    kept when the path selects something in it (its filters hold); a message of another topic is kept as it is."""
    path = msgpath.parse(expression)
    counted = iter(range(1, 1 << 62))

    def keep(msg: Any, number: Optional[int] = None, topic: Optional[str] = None, **names: Any) -> bool:
        number = next(counted) if number is None else number
        if topic is not None and topic != path.topic:
            return True
        try:
            return bool(path.values(msg, namespace))
        except msgpath.MessagePathError as error:
            raise UsageError(f"--filter: {error} (message {number}); fix the path") from None

    return keep


# -- magic lines with free text ----------------------------------------------------------------

def split_head(line: str, parser: Any, positional: Callable[[int, str], bool]) -> tuple[str, str]:
    """Split a magic line into its options-and-names head and the raw text after it.

    For magics whose last argument is free text (a YAML message, a Python expression),
    which argparse's shell-like splitting would mangle (quotes removed, spaces lost).
    The options are the magic's own (``parser``, what ``@argument`` made of its
    decorators: one grammar, for parsing, help and completion alike). The head is every
    option with its value and the words for which ``positional(index, word)`` is true;
    the first other word starts the raw text, kept exactly as typed, but for options
    typed after it (``%pub /t std_msgs/String hi -r 2``), which go to the head too.
    """
    values, flags = option_words(parser)
    head: list[str] = []
    rest = line
    count = 0
    takes_value = False
    while True:
        match = _WORD.match(rest)
        if match is None:
            return " ".join(head), ""
        word = match.group(1)
        if takes_value:
            takes_value = False
        elif word.startswith("-") and not _NUMBER.match(word):
            takes_value = word in values
        elif positional(count, word):
            count += 1
        else:
            data, trailing = _trailing_options(rest.strip(), values, flags)
            return " ".join(head + trailing), data
        head.append(word)
        rest = rest[match.end():]


def option_words(parser: Any) -> tuple[set[str], set[str]]:
    """The option strings of ``parser`` that take a value, and those that do not (flags)."""
    values, flags = set(), set()
    for action in getattr(parser, "_actions", ()):
        (flags if action.nargs == 0 else values).update(action.option_strings)
    return values, flags


def _trailing_options(text: str, values: set[str], flags: set[str]) -> tuple[str, list[str]]:
    """``text`` without the magic's options at its end, and those options (``{data: 1} -t 2`` → ``{data: 1}``, ``-t 2``)."""
    words = [(m.start(1), m.group(1)) for m in _WORD.finditer(text)]
    taken: list[str] = []
    cut = len(text)
    while words:
        start, word = words[-1]
        if word in flags or word.split("=", 1)[0] in values and "=" in word:
            taken[:0] = [word]
            words.pop()
        elif len(words) >= 2 and words[-2][1] in values and not word.startswith(("{", "[")):
            taken[:0] = [words[-2][1], word]
            start = words[-2][0]
            words[-2:] = []
        else:
            break
        cut = start
    return text[:cut].rstrip(), taken


_WORD = re.compile(r"""\s*("[^"]*"|'[^']*'|\S+)""")  # a quoted word is one word, as the shell reads it
_NUMBER = re.compile(r"-\.?\d")
