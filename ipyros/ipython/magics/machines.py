"""``%machines``: the robots' keepers this session sees, what each allows and keeps, and the link to each.

    %machines           a row a keeper: host, ROS, the packages it allows, the guards and basenodes placed on
                        it, the round trip of the link (ms), whether this session holds its token

A keeper is ``python -m ipyros.machine --name robot1 --allow PKG`` on the robot's computer (see the guide's
"A robot on another machine"); a node places a guard on it with ``nd.guard(..., machine="robot1")`` and its
basenode with ``.machine("robot1")``.
"""

from __future__ import annotations

from IPython.core.magic import line_magic, magics_class
from IPython.core.magic_arguments import magic_arguments, parse_argstring

from ...core.records import Machines
from ...tools.machines import look
from ..arguments import argument
from .common import ExtensionMagics


@magics_class
class MachineMagics(ExtensionMagics):
    """The machines' keepers."""

    @magic_arguments()
    @argument("--timeout", type=float, default=3.0, help="how long to wait for the keepers' answers (s)")
    @line_magic
    def machines(self, line: str) -> Machines:
        """The keepers on this ROS graph: where each runs, what it allows, what is placed on it, the round trip of
        the link to it, and whether this session holds its token (without it, a keeper is seen, nothing more)."""
        args = parse_argstring(self.machines, line)
        return look(timeout=args.timeout)
