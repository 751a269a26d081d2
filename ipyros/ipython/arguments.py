"""A magic's words, declared once: IPython's ``@argument`` plus what TAB completes for each.

The ros2cli pattern: the completer belongs to the argument itself, so a magic's grammar
is written once, in its ``@argument`` decorators, and completion reads it back from the
parser IPython builds of them::

    @magic_arguments()
    @argument("topic", complete=TOPIC, help="the live topic to listen to")
    @argument("-t", "--type", complete=MSG_TYPE, help="...")
    @line_magic
    def echo(self, line): ...

:func:`grammar_of` turns that parser into a :class:`Grammar`, which says what the word
being typed is, given the words before it: a positional argument (by its place, as
argparse would fill them: one word, an optional one, or all the rest) or the value of an
option.
"""

from __future__ import annotations

import argparse
from dataclasses import dataclass, field
from typing import Any, Callable, Mapping, Optional

from IPython.core import magic_arguments

__all__ = ["ACTION", "ACTION_TYPE", "DEMO_ROBOT", "DSL_NODE", "EXECUTABLE", "FIELD", "FUNCTION", "GOAL_TEMPLATE",
           "MACHINE", "MSG_PATH", "MSG_TEMPLATE", "MSG_TYPE", "NODE", "OWN_TOPIC", "PACKAGE", "REQUEST_TEMPLATE", "SERVICE", "SRV_TYPE",
           "TIMER", "TOPIC", "TRANSITION", "Grammar", "Word", "argument", "grammar_of"]

# What an argument is, i.e. where its completions come from.
TOPIC = "topic"              # live topics (+ the node's own first, when a node is known)
MSG_PATH = "message path"    # a live topic, then past a '.', '[' or '{' the fields of the type it carries
FIELD = "field"              # a field of the topic before it, dotted (or a message path, when it starts with /)
OWN_TOPIC = "own topic"      # the node's own topics only (live ones if no node is known)
SERVICE = "service"          # live services + the node's own
MSG_TYPE = "message type"
SRV_TYPE = "service type"
NODE = "node"                # live ROS node names
DSL_NODE = "DSL node"        # variables in user_ns holding a DSL node
FUNCTION = "function"        # the user's functions (a candidate handler for %try)
TIMER = "timer"              # the node's timer names
PACKAGE = "package"
EXECUTABLE = "executable"    # executables of the package named by the argument before
DEMO_ROBOT = "demo robot"    # the robots %demo starts
MACHINE = "machine"          # the machines' keepers on the graph, and the machines whose token is here
MSG_TEMPLATE = "template"    # a message of the type before it, every field at its default
REQUEST_TEMPLATE = "request template"  # the request of the service type before it, at its defaults
ACTION = "action"            # live actions
ACTION_TYPE = "action type"  # action types (the live action's before it first)
GOAL_TEMPLATE = "goal template"  # the goal of the action (type) before it, at its defaults
TRANSITION = "lifecycle transition"  # what a lifecycle manager asks of a managed node (ROS 2)

#: Kinds that complete the first word of their argument only (a whole message, inserted at once).
_FIRST_WORD_ONLY = {MSG_TEMPLATE, REQUEST_TEMPLATE, GOAL_TEMPLATE}


class argument(magic_arguments.argument):  # noqa: N801 - used as IPython's own @argument is
    """IPython's ``@argument``, plus ``complete=KIND`` (what TAB offers for it) and, for an
    ``OWN_TOPIC``, ``direction=`` (which of the node's topics: ``"subscribe"``, ``"publish"``)."""

    def __init__(self, *args: Any, complete: Optional[str] = None, direction: Optional[str] = None,
                 **kwds: Any) -> None:
        super().__init__(*args, **kwds)
        self.complete, self.direction = complete, direction

    def add_to_parser(self, parser: Any, group: Any) -> None:
        action = (group if group is not None else parser).add_argument(*self.args, **self.kwds)
        action.complete, action.direction = self.complete, self.direction
        return None  # not a group (IPython reads a result as the group later arguments go into)


@dataclass(frozen=True)
class Word:
    """What one argument of a magic is: its completion kind, which topics (for ``OWN_TOPIC``), how many words."""

    kind: Optional[str]
    direction: Optional[str] = None
    many: bool = False  # it takes all the words that are left (nargs "*", "+", ...)


@dataclass(frozen=True)
class Grammar:
    """A magic's words: its positional arguments in order, and each option with the value it takes.

    An option mapped to None is a flag (it takes no value); ``other_options``, if set, is
    what any other ``-x`` word is (``%wrap``'s remaps are ``from:=to``, not options).
    """

    positional: tuple[Word, ...] = ()
    options: Mapping[str, Optional[Word]] = field(default_factory=dict)

    def classify(self, words: list[str], current: str) -> tuple[Optional[Word], list[str]]:
        """The argument the word ``current`` is typed for, given the ``words`` before it (None: not one
        completed); and the positional words seen, for the arguments that depend on them."""
        positionals: list[str] = []
        pending: Optional[Word] = None
        awaiting_value = False
        for word in words:
            if awaiting_value:
                awaiting_value = False
            elif word.startswith("-") and len(word) > 1 and word.split("=", 1)[0] in self.options:
                value = self.options[word.split("=", 1)[0]]
                awaiting_value = value is not None and "=" not in word
                pending = value
            else:
                positionals.append(word)
        if awaiting_value:
            return pending, positionals
        if current.startswith("-"):
            option, eq, _ = current.partition("=")
            return (self.options.get(option) if eq else None), positionals
        return self._positional(len(positionals)), positionals

    def _positional(self, index: int) -> Optional[Word]:
        """The positional argument the word at ``index`` (of the positional words) fills."""
        for word in self.positional:
            if word.many:
                first = index == 0
                return word if first or word.kind not in _FIRST_WORD_ONLY else None
            if index == 0:
                return word
            index -= 1
        return None


_grammars: dict[int, tuple[Any, Optional[Grammar]]] = {}


def grammar_of(magic: Callable[..., Any]) -> Optional[Grammar]:
    """The grammar of a magic declared with :class:`argument` (None: a magic that completes nothing,
    IPython's own among them). Read once from the parser IPython made of its decorators."""
    function = getattr(magic, "__func__", magic)
    parser = getattr(function, "parser", None)
    cached = _grammars.get(id(function))
    if cached is not None and cached[0] is parser:
        return cached[1]
    grammar = _from_parser(parser) if isinstance(parser, argparse.ArgumentParser) else None
    _grammars[id(function)] = (parser, grammar)
    return grammar


def _from_parser(parser: argparse.ArgumentParser) -> Optional[Grammar]:
    positional: list[Word] = []
    options: dict[str, Optional[Word]] = {}
    completes = False
    for action in parser._actions:  # argparse keeps them in declaration order; there is no public list
        kind = getattr(action, "complete", None)
        completes = completes or kind is not None
        word = Word(kind, getattr(action, "direction", None),
                    many=action.nargs in ("*", "+", argparse.REMAINDER) or isinstance(action.nargs, int)
                    and action.nargs > 1)
        if action.option_strings:
            takes_value = action.nargs != 0
            for option in action.option_strings:
                options[option] = word if takes_value else None
        else:
            positional.append(word)
    return Grammar(tuple(positional), options) if completes else None
