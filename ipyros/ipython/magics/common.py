"""What the ipyros magics share: their link to the extension, and finding what a line names."""

from __future__ import annotations

import re
from typing import TYPE_CHECKING, Any, Callable

from IPython.core.error import UsageError
from IPython.core.magic import Magics

from ...core import names
from ...node.dsl import rosNode
from ...node.session import current

if TYPE_CHECKING:
    from ..extension import Extension


class ExtensionMagics(Magics):
    """A ``Magics`` class of ipyros: reaches the settings, the graph and the printer via ``ext``."""

    def __init__(self, shell: Any, ext: "Extension") -> None:
        super().__init__(shell=shell)
        self.ext = ext


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
            return engine.dsl
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
