"""A handler an agent wrote, as source text, made a function without running any of the agent's code.

Defining a function runs code only in what is evaluated as the ``def`` runs: decorators, default values and (without
``from __future__ import annotations``) annotations. So the source must be one ``def`` and nothing else, with no
decorator, literal defaults, and it is compiled with annotations left unevaluated: then making the function runs
nothing of the agent's. Its body runs when it is called, in a rehearsal (captured writes, a time budget) or, once a
person approved it, as the node's handler. That is not a sandbox: a rehearsal runs the body in the session's
process, where it can do what any Python does; what it writes is kept, not sent (see docs/agent.md).

The source is kept in :mod:`linecache` under a name of its own, so that ``%handler``, the versions, ``save`` and
``export`` find it as they find a handler typed at the prompt.
"""

from __future__ import annotations

import __future__
import ast
import linecache
import itertools
from typing import Any, Callable

from ..core.errors import IpyrosError

__all__ = ["CandidateError", "LONGEST", "make_candidate", "check_candidate"]

#: The longest source an agent may give for one handler (characters).
LONGEST = 20_000

_numbers = itertools.count(1)


class CandidateError(IpyrosError, ValueError):
    """The source is not one plain ``def``: the one line says what to change."""


def check_candidate(source: object) -> ast.FunctionDef:
    """The one ``def`` of ``source``, if making it runs none of its code; else the one-line refusal."""
    if not isinstance(source, str):
        raise CandidateError(f"a handler's source is text, not {type(source).__name__}: give 'def h(msg): ...'")
    if len(source) > LONGEST:
        raise CandidateError(f"the handler's source is {len(source):,} characters; at most {LONGEST:,}")
    try:
        tree = ast.parse(source, "<candidate>", "exec")
    except SyntaxError as error:
        raise CandidateError(f"the handler's source is not Python: {error.msg} (line {error.lineno}); give one "
                             "def, e.g. 'def h(msg): node.write(\"/out\", msg)'") from None
    if len(tree.body) != 1 or not isinstance(tree.body[0], ast.FunctionDef):
        kinds = ", ".join(type(statement).__name__ for statement in tree.body) or "nothing"
        raise CandidateError(f"the handler's source must be one def and nothing else (it holds {kinds}); put "
                             "imports inside the function")
    function = tree.body[0]
    if function.decorator_list:
        raise CandidateError(f"def {function.name}: no decorator, please (it would run as the def is made)")
    for default in (*function.args.defaults, *(d for d in function.args.kw_defaults if d is not None)):
        try:
            ast.literal_eval(default)
        except ValueError:
            raise CandidateError(f"def {function.name}: a default value must be a literal (a number, a string, "
                                 f"...), not {ast.unparse(default)!r:.60}") from None
    return function


def make_candidate(source: str, namespace: dict[str, Any], name: str = "") -> Callable[..., Any]:
    """The function ``source`` defines, its globals ``namespace`` (which gains its name), its source findable.

    ``name`` renames it (its ``def`` line too), so that it takes no name the namespace already uses.
    """
    function = check_candidate(source)
    filename = f"<agent's handler {next(_numbers)}>"
    text = source if source.endswith("\n") else source + "\n"
    if name and name != function.name:
        lines = text.splitlines(True)
        line = lines[function.lineno - 1]
        at = line.index(function.name, function.col_offset + len("def"))
        lines[function.lineno - 1] = line[:at] + name + line[at + len(function.name):]
        text, function.name = "".join(lines), name
    linecache.cache[filename] = (len(text), None, text.splitlines(True), filename)
    code = compile(text, filename, "exec", flags=__future__.annotations.compiler_flag, dont_inherit=True)
    exec(code, namespace)  # noqa: S102 - one def with literal defaults: making it runs none of its code
    return namespace[function.name]
