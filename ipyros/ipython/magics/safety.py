"""``%estop``: every guarded output of the session to its stop message at once, held until released.

    %estop              every node of the session that has a guard
    %estop nd           that node's guards only
    %estop --release    let commands through again

What a guard is, and what it promises and does not: :mod:`ipyros.core.guard`.
"""

from __future__ import annotations

from IPython.core.error import UsageError
from IPython.core.magic import line_magic, magics_class
from IPython.core.magic_arguments import magic_arguments, parse_argstring

from ...dsl import engine_of, node_of
from ...node.session import current
from ...tools.estop import estop_each
from ..api import find_node
from ..arguments import DSL_NODE, argument
from .common import ExtensionMagics


@magics_class
class SafetyMagics(ExtensionMagics):
    """The e-stop of the session's guards."""

    @magic_arguments()
    @argument("node", nargs="?", complete=DSL_NODE, help="a node whose guards only (default: every node's)")
    @argument("--release", action="store_true", help="let commands through the guards again")
    @line_magic
    def estop(self, line: str) -> None:
        """Put every guarded output to its stop message at once and hold it there, whatever else arrives, until
        %estop --release (nd.estop() and nd.release() do it for one node). Not certified functional safety: the
        robot's hardware e-stop stays the last line."""
        args = parse_argstring(self.estop, line)
        if args.node:
            nodes = [find_node(self.shell, args.node)]
        else:
            nodes = [node_of(engine) for engine in current().nodes.values()
                     if engine.created and engine.model().guards]
        if not nodes:
            raise UsageError("no running node of this session has a guard; guard an output first: "
                             "nd.guard('/cmd_vel', limits={'linear.x': (-0.5, 0.5)}, timeout=0.5)")
        done = [f"{topic} ({engine_of(node).called})" for node, topics in estop_each(nodes, not args.release)
                for topic in topics]
        if args.release:
            print(f"ipyros: released {', '.join(done)}: commands pass the guards again")
        else:
            print(f"ipyros: e-stopped {', '.join(done)}: the stop message holds until %estop --release")
