"""``%demo``: start and stop the demo robot (:mod:`ipyros.tools.robot`) from the prompt.

    %demo                         the turtle (paper, section III-B), and what to type next
    %demo kobuki                  the Kobuki stand-in (section III-C): base and speed monitor
    %demo kobuki planner:=true    with the launch file's argument set, as roslaunch takes it
    %demo --list                  the demo robots and their arguments
    %demo --stop                  stop it

The robot's nodes are child processes of the session: they stop with ``%demo --stop``,
when another demo robot starts, and when the session ends.
"""

from __future__ import annotations

from IPython.core.error import UsageError
from IPython.core.magic import line_magic, magics_class
from IPython.core.magic_arguments import magic_arguments, parse_argstring
from rich.table import Table

from ...tools.robot import ROBOTS, demo_robot, launch_args, running_robot, stop_demo_robot
from ..arguments import DEMO_ROBOT, argument
from .common import ExtensionMagics


@magics_class
class DemoMagics(ExtensionMagics):
    """The magic that runs ipyros's demo robots."""

    @magic_arguments()
    @argument("robot", nargs="?", default="turtle", complete=DEMO_ROBOT, help=f"which demo robot: {', '.join(ROBOTS)} (default: turtle)")
    @argument("args", nargs="*", metavar="name:=value", help="arguments of its launch file (see --list)")
    @argument("--stop", action="store_true", help="stop the demo robot")
    @argument("--list", action="store_true", help="list the demo robots and their arguments")
    @line_magic
    def demo(self, line: str) -> None:
        """Start a demo robot (default: the turtle) as child processes of the session, and say what to try."""
        args = parse_argstring(self.demo, line)
        if ":=" in args.robot:  # %demo max_speed:=3: arguments for the default robot
            args.args.insert(0, args.robot)
            args.robot = "turtle"
        if args.stop or args.list:
            if args.args or line.split()[0] in ROBOTS:
                raise UsageError("--stop and --list take no robot and no arguments: %demo --stop")
            if args.list:
                self.ext.printer.show(robots_table())
            else:
                stopped = stop_demo_robot()
                print(f"ipyros: demo robot {stopped.kind} stopped" if stopped else "ipyros: no demo robot is running")
            return
        wanted = launch_words(args.args)
        before = running_robot()
        robot = demo_robot(args.robot, **wanted)
        if before is not None and before is not robot:
            print(f"ipyros: the demo robot {before.kind} was stopped first: one demo robot runs at a time")
        self.ext.printer.show(robot)
        print(robot.hint())


def launch_words(words: list[str]) -> dict[str, str]:
    """``["max_speed:=3", "planner:=true"]`` → ``{"max_speed": "3", "planner": "true"}``."""
    found: dict[str, str] = {}
    for word in words:
        name, sep, value = word.partition(":=")
        if not sep or not name or not value:
            raise UsageError(f"{word!r}: give launch arguments as name:=value, e.g. max_speed:=3.0 (see %demo --list)")
        found[name] = value
    return found


def robots_table() -> Table:
    """The demo robots: what each is, and the arguments of its launch file with their defaults."""
    table = Table(title="demo robots (%demo NAME \\[name:=value ...])", title_justify="left", show_lines=True)
    for column in ("name", "what it is", "arguments (default)"):
        table.add_column(column)
    for name, kind in ROBOTS.items():
        arguments = "\n".join(f"{a.name}:={kind.defaults.get(a.name, a.default)}  {a.doc}"
                              for a in launch_args(kind.path))
        table.add_row(name, kind.about, arguments)
    return table
