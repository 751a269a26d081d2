"""``%wrap``: wrap a basenode in one line, as ``rosrun`` would start it.

    %wrap turtlesim turtlesim_node --as turtle /turtle1/pose:=/t1/pose _background_r:=255
    %wrap my_robot_nodes planner --machine robot1     # started on robot1 by its keeper, relayed there

launches the basenode with its remaps and private parameters, discovers its interface,
declares all of it as ``reuse`` on a new wrapping node (see :func:`ipyros.tools.wrap.wrap`),
creates that node, binds it to the variable ``turtle`` and prints its interface.
"""

from __future__ import annotations

import keyword
import re
from typing import Any

import yaml
from IPython.core.error import UsageError
from IPython.core.magic import line_magic, magics_class
from IPython.core.magic_arguments import magic_arguments
from IPython.utils.process import arg_split  # how IPython splits magic lines

from ...core.model import BaseModel
from ...core.remapping import base_node_name
from ...dsl import rosNode
from ...tools.wrap import wrap
from ..arguments import EXECUTABLE, MACHINE, PACKAGE, TOPIC, argument
from .common import ExtensionMagics


@magics_class
class WrapMagics(ExtensionMagics):
    """The magic that wraps running ROS executables into DSL nodes."""

    @magic_arguments()
    @argument("package", complete=PACKAGE, help="the ROS package of the basenode")
    @argument("executable", complete=EXECUTABLE, help="the executable in that package, as rosrun finds it")
    @argument("extra", nargs="*", complete=TOPIC, help="as for rosrun: from:=to remaps the basenode's names, _param:=value sets "
              "a private parameter (YAML value), other words are its arguments (after --, words starting with -)")
    @argument("--as", dest="var", metavar="NAME",
              help="the variable to bind the wrapping node to, also its name (default: from the executable)")
    @argument("--name", help="the basenode's ROS node name (default: its own)")
    @argument("--ns", "--namespace", dest="namespace", help="the basenode's namespace")
    @argument("--machine", complete=MACHINE, help="the machine whose keeper runs the basenode and its relays "
              "(see %%machines); default: this one")
    @line_magic
    def wrap(self, line: str) -> None:
        """Wrap PACKAGE's EXECUTABLE: launch it, reuse its whole interface, bind the node to NAME."""
        # Remaps may follow the options, and words after -- are the basenode's own arguments:
        # argparse's default parse would refuse both.
        words = arg_split(line)
        own = words.index("--") if "--" in words else len(words)
        args = self.wrap.parser.parse_intermixed_args(words[:own])
        args.extra += words[own + 1:]
        if args.var is not None and not _is_variable(args.var):
            raise UsageError(f"--as {args.var}: give a Python variable name, e.g. --as turtle")
        remaps, params, extra_args = rosrun_words(args.extra)
        default = f"{base_node_name(BaseModel(executable=args.executable))}_wrapper"
        self._refuse_running_variable(args.var or _variable_for(default), "--as" if args.var else "")
        node = wrap(args.package, args.executable, args.var, node_name=args.name, namespace=args.namespace,
                    remaps=remaps or None, params=params or None, args=extra_args or None, machine=args.machine)
        variable = args.var or _variable_for(node.name)
        self.shell.user_ns[variable] = node
        self.ext.printer.show(node, f"bound to [bold]{variable}[/]")

    def _refuse_running_variable(self, variable: str, option: str) -> None:
        """Binding the new node must not drop the only handle on a node that runs (it would run on, unreachable)."""
        held = self.shell.user_ns.get(variable)
        if isinstance(held, rosNode) and held.created:
            how = f"--as {variable}" if option else f"the default variable {variable}"
            raise UsageError(f"{how} holds the running node {held.fullname}; give another name with --as, "
                             f"or stop that one first: {variable}.shutdown()")


def rosrun_words(words: list[str]) -> tuple[dict[str, str], dict[str, Any], list[str]]:
    """Split rosrun-style words into remaps (``a:=b``), private params (``_p:=v``) and arguments."""
    remaps: dict[str, str] = {}
    params: dict[str, Any] = {}
    rest: list[str] = []
    for word in words:
        name, sep, value = word.partition(":=")
        if not sep:
            rest.append(word)
        elif not name or not value:
            raise UsageError(f"{word!r}: a remap is from:=to and a parameter _name:=value")
        elif name.startswith("_") and len(name) > 1:
            try:
                params[name[1:]] = yaml.safe_load(value)
            except yaml.YAMLError:
                raise UsageError(f"{word!r}: cannot read the value {value!r} as YAML; quote it") from None
        else:
            remaps[name] = value
    return remaps, params, rest


def _is_variable(name: str) -> bool:
    return name.isidentifier() and not keyword.iskeyword(name)


def _variable_for(node_name: str) -> str:
    name = re.sub(r"\W", "_", node_name)
    return name if _is_variable(name) else f"node_{name}"
