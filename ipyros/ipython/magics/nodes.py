"""``%handler``, ``%%handler``, ``%try``, ``%versions``, ``%revert``, ``%save_nodes``, ``%load_nodes``, ``%status``.

Working on the handlers of running nodes, and keeping them.

NODE is the variable holding a rosNode (``nd``), or a node's name in this session.
TOPIC is a subscribed topic as the node names it; a timer's name or a service also
work for ``%handler``.
"""

from __future__ import annotations

from typing import Any, Optional

from IPython.core.error import UsageError
from IPython.core.magic import line_cell_magic, line_magic, magics_class
from IPython.core.magic_arguments import magic_arguments, parse_argstring

from ...core.errors import IpyrosError
from ...core.names import is_tool
from ...dsl import engine_of, keeping, node_of, restore, rosNode
from ...files.modelfile import handler_sources
from ...node.session import current
from ...tools.editing import EditWatch, PendingEdit, fresh_name, handler_source, lambda_as_def, new_functions
from ...tools.plot import series_chart, series_figure
from ...tools.tryout import try_bag, try_candidate
from ..api import evaluate, find_node, split_head
from ..arguments import DSL_NODE, FUNCTION, OWN_TOPIC, argument
from ..display import session_table
from .cell_output import in_kernel
from .common import ExtensionMagics


@magics_class
class NodeMagics(ExtensionMagics):
    """Magics that edit, try and watch the handlers of the session's nodes."""

    def __init__(self, shell: Any, ext: Any) -> None:
        super().__init__(shell, ext)
        self.edits = EditWatch()

    def after_cell(self, result: Any = None) -> None:
        """``post_run_cell``: swap in the handlers whose edited source was just run."""
        for news in self.edits.check(self.shell.user_ns):
            print(f"ipyros: {news}")

    # -- %handler / %%handler ----------------------------------------------------------------
    @magic_arguments()
    @argument("node", complete=DSL_NODE, help="the variable holding the rosNode")
    @argument("topic", complete=OWN_TOPIC, direction="subscribe", help="the subscribed topic whose handler to edit (or a timer's name, or a service)")
    @line_cell_magic
    def handler(self, line: str, cell: Optional[str] = None) -> None:
        """Edit the live handler of TOPIC on NODE.

        %handler NODE TOPIC puts the source of the function now handling TOPIC in the next
        input; edit it and run it, and the new function replaces the live one (no message
        is lost). This needs the source: it works for handlers typed at the prompt or
        imported from a file (a lambda comes as a def of a new name), not for functions made
        by exec.

        %%handler NODE TOPIC runs the cell, which defines the new handler (a def), and swaps
        it in at once.
        """
        args = parse_argstring(self.handler, line)
        node = find_node(self.shell, args.node)
        engine = engine_of(node)
        relayed = engine.handlers_of.relayed_target(args.topic)
        if relayed is not None and cell is None:
            self._offer_pass_through(node, relayed)
            return
        target = relayed or engine.handlers_of.find_target(args.topic)
        old = None if relayed is not None else engine.handlers_of.current_handler(target)
        if cell is None:
            if getattr(old, "__name__", "") == "<lambda>" and (
                    as_def := lambda_as_def(old, fresh_name(target, self.shell.user_ns))) is not None:
                name = as_def.split("(", 1)[0][len("def "):]
                self.edits.expect(PendingEdit(node, target, name, old))
                self.shell.set_next_input(as_def.rstrip("\n"))
                print(f"ipyros: the handler of {node.name} {target.label} is a lambda, here as def {name}: "
                      "edit it and run it, and it replaces the lambda")
                return
            source = handler_source(old, args.node, target)
            self.edits.expect(PendingEdit(node, target, old.__name__, old))
            self.shell.set_next_input(source.rstrip("\n"))
            print(f"ipyros: edit {old.__name__} and run it: it replaces the handler of {node.name} {target.label}")
            return
        self.edits.forget(node, target)
        before = dict(self.shell.user_ns)
        result = self.shell.run_cell(cell)
        old_name = old.__name__ if old is not None else fresh_name(target, {})
        if not result.success:  # its error was shown; the cell magic fails too, in one line
            keeps = f"keeps its handler {old_name}" if old is not None else "stays relayed"
            raise IpyrosError(f"the cell failed, so {node.name} {target.label} {keeps}")
        defined = new_functions(before, self.shell.user_ns)
        if not defined:
            raise UsageError(f"the cell defines no function; define the new handler of {target.label} "
                             f"with def, e.g. def {old_name}(msg): ...")
        name = old_name if old_name in defined else None
        if name is None and len(defined) > 1:
            raise UsageError(f"the cell defines {', '.join(sorted(defined))}; which is the handler? "
                             f"name it {old_name}, like the one it replaces")
        name = name or next(iter(defined))
        engine_of(node).handlers_of.redeclare(target, defined[name])
        print(f"ipyros: {node.name} {target.label} is now handled by the new {name}")

    # -- %try ------------------------------------------------------------------------------
    @magic_arguments(name="try")
    @argument("node", complete=DSL_NODE, help="the variable holding the rosNode")
    @argument("topic", complete=OWN_TOPIC, direction="subscribe", help="the subscribed topic")
    @argument("candidate", nargs="*", complete=FUNCTION, help="the candidate handler: a function's name, or any expression "
              "giving a function (a lambda), the rest of the line")
    @argument("-n", "--last", type=int, help="only the last N messages (default: all the node keeps, "
              "c.RosMagics.try_history)")
    @argument("--bag", default=None, help="every message of TOPIC in this bag instead (offline: the node need not "
              "run, nothing is published), each write on a guarded output through its guard; returns the outcome "
              "(r.total, r.differing, r.outputs, r.guarded)")
    @argument("--plot", metavar="FIELD", default=None,
              help="with --bag: draw FIELD of both sides' outputs over bag time (linear.x, or /cmd_vel.linear.x)")
    @line_magic("try")
    def try_handler(self, line: str) -> Any:
        """Run CANDIDATE on the last messages TOPIC brought to NODE, beside the live handler.

        Nothing is swapped. Each handler gets its own copy of each message; what it prints
        and what it writes through node.write() is captured and shown, not published.
        Anything else it does (globals, parameters, its own publishers) happens for real.
        With --bag FILE, every message of TOPIC recorded in FILE (and those of the node's other
        subscriptions, through their live handlers, in recorded order): r = %try nd /scan new --bag run
        """
        head, expression = split_head(line, self.try_handler.parser, lambda index, word: index < 2)
        args = parse_argstring(self.try_handler, head)
        if not expression:
            raise UsageError("give the candidate handler after NODE and TOPIC, e.g. %try nd /chatter new_handler")
        if args.last is not None and args.last < 1:
            raise UsageError(f"-n must be 1 or more, not {args.last}")
        node = find_node(self.shell, args.node)
        candidate = evaluate(self.shell, expression, "candidate handler")
        if args.plot is not None and args.bag is None:
            raise UsageError("--plot draws a try over a bag, over bag time: give --bag FILE too")
        if args.bag is not None:
            if args.last is not None:
                raise UsageError("-n counts the node's last messages; with --bag every message of the bag is tried")
            trial = try_bag(node, args.topic, candidate, args.bag)
            if args.plot is not None:
                self._plot_trial(trial, args.plot)
            return trial  # shown as the cell's result: r = %try ... keeps it
        self.ext.printer.show(try_candidate(node, args.topic, candidate, args.last))
        return None

    def _plot_trial(self, trial: Any, field: str) -> None:
        """Both sides' FIELD over bag time: a chart of characters in a terminal, a figure in Jupyter."""
        drawn, series = trial.series(field)
        title = f"{drawn} over bag time, from {trial.bag}"
        if in_kernel(self.shell):
            import io

            from IPython.display import Image, display

            buffer = io.BytesIO()
            series_figure(title, series, "bag time (s)").savefig(buffer, format="png", dpi=80)
            display(Image(data=buffer.getvalue()))
        else:
            width = max(20, self.ext.printer.console().width - 14)
            print(series_chart(title, series, "bag time (s)", width=width))

    # -- %versions / %revert -------------------------------------------------------------------
    @magic_arguments()
    @argument("node", complete=DSL_NODE, help="the variable holding the rosNode")
    @argument("topic", complete=OWN_TOPIC, direction="subscribe",
              help="the subscribed topic (or a timer's name, or a service)")
    @line_magic
    def versions(self, line: str) -> None:
        """Every function the handler of TOPIC on NODE was given, oldest first; (now) marks the live one.

        %revert NODE TOPIC N brings version N back; nd.versions(TOPIC)[N - 1].source is its source.
        """
        args = parse_argstring(self.versions, line)
        self.ext.printer.show(find_node(self.shell, args.node).versions(args.topic))

    @magic_arguments()
    @argument("node", complete=DSL_NODE, help="the variable holding the rosNode")
    @argument("topic", complete=OWN_TOPIC, direction="subscribe",
              help="the subscribed topic (or a timer's name, or a service)")
    @argument("version", type=int, help="the version number, as %%versions lists it")
    @line_magic
    def revert(self, line: str) -> None:
        """Serve TOPIC on NODE with handler VERSION again, live (no message lost)."""
        args = parse_argstring(self.revert, line)
        node = find_node(self.shell, args.node)
        node.revert(args.topic, args.version)
        version = node.versions(args.topic)[args.version - 1]
        print(f"ipyros: {node.name} {args.topic} is handled by version {args.version} ({version.name}) again")

    # -- %save_nodes / %load_nodes ----------------------------------------------------------------
    @magic_arguments()
    @argument("path", help="the file to write: .py (runnable DSL code), or .yaml / .json (one node's model)")
    @argument("node", nargs="*", complete=DSL_NODE, help="the variables holding the rosNodes (default: every running node)")
    @line_magic
    def save_nodes(self, line: str) -> None:
        """Save nodes to PATH: the DSL declarations and the source of every handler and helper.

        Run the file to bring them back (python3 PATH, %run PATH, or %load_nodes PATH).
        """
        args = parse_argstring(self.save_nodes, line)
        nodes = [find_node(self.shell, name) for name in args.node]
        if not nodes:  # every node of the user's: ipyros's own tool nodes (%pub's, %echo's) are not saved
            nodes = [node_of(engine) for engine in current().nodes.values() if not is_tool(engine.name)]
            left_out = {}
            for node in nodes:  # save what can be saved; say what could not, and why
                try:
                    handler_sources([engine_of(node)], self.shell.user_ns)
                except IpyrosError as error:
                    left_out[node.fullname] = str(error).removeprefix("nothing saved: ")
            nodes = [node for node in nodes if node.fullname not in left_out]
            for name, why in left_out.items():
                print(f"ipyros: not saved: {name}: {why}")
        if not nodes:
            raise UsageError("no rosNode is running in this session that can be saved; name the node to save: "
                             "%save_nodes PATH nd")
        if not args.path.endswith(".py"):
            if len(nodes) != 1:
                raise UsageError(f"{args.path}: a model file holds one node; name it, or save to a .py file")
            written = nodes[0].save(args.path, self.shell.user_ns)
        else:
            written = keeping.save_nodes([engine_of(n) for n in nodes], args.path, self.shell.user_ns)
        print(f"ipyros: saved {', '.join(n.fullname for n in nodes)} to {written}")

    @magic_arguments()
    @argument("node", complete=DSL_NODE, help="the variable holding the rosNode")
    @argument("path", help="my_node.py (one script), or a directory: a ROS package (ROS 1: catkin; ROS 2: "
              "ament_python, built by colcon)")
    @argument("--cpp", action="store_true",
              help="ROS 1: the package's node in roscpp C++, its handlers left to port by hand (PORTING.md)")
    @line_magic
    def export(self, line: str) -> None:
        """Export NODE to run without ipyros: nd.export(PATH) at the prompt (with --cpp, language="cpp").

        The script or package holds the node's endpoints, handlers, parameters and guards, and for a
        wrapping node its basenode, started remapped as ipyros ran it.
        """
        args = parse_argstring(self.export, line)
        node = find_node(self.shell, args.node)
        written = node.export(args.path, self.shell.user_ns, language="cpp" if args.cpp else "python")
        print(f"ipyros: exported {node.fullname} to {written}")

    @magic_arguments()
    @argument("path", help="a file written by %%save_nodes or nd.save()")
    @argument("--trust", action="store_true",
              help="run the code a model file (.yaml/.json) carries: its imports and handler sources")
    @line_magic
    def load_nodes(self, line: str) -> None:
        """Bring back the nodes saved in PATH, running; their handlers land in this namespace (editable).

        A .py file is Python and runs as %run would run it. A model file (.yaml/.json) looks
        like data, so the code in it runs only with --trust.
        """
        args = parse_argstring(self.load_nodes, line)
        user_ns = self.shell.user_ns
        before = self.ext.names_before = dict(user_ns)
        try:
            if args.path.endswith(".py"):
                nodes = restore(args.path, user_ns)
            else:
                nodes = [rosNode.load(args.path, user_ns, create=True, trust=args.trust)]
        except BaseException:
            # A load that fails leaves the namespace as it was: a variable it had rebound would name a node that
            # never ran, and the running node it held would be lost to the user (and to its handlers).
            for name in [n for n in user_ns if n not in before]:
                del user_ns[name]
            user_ns.update({name: value for name, value in before.items() if user_ns.get(name) is not value})
            raise
        finally:
            self.ext.names_before = None
        running = ", ".join(f"{n.fullname} ({'running' if n.created else 'declared'})" for n in nodes)
        print(f"ipyros: loaded {running or 'no nodes'} from {args.path}")

    def _offer_pass_through(self, node: Any, target: Any) -> None:
        """A relayed topic has no handler to edit: offer one that passes each message on as it came."""
        engine = engine_of(node)
        name = fresh_name(target, self.shell.user_ns)
        resolved = engine.resolve_as("reuse", target.name, "topic")
        source = (f"def {name}(msg):\n"
                  f"    {engine.called}.write({resolved!r}, msg)  # passed on as it came: change it, or write another\n")
        self.edits.expect(PendingEdit(node, target, name, None))
        self.shell.set_next_input(source.rstrip("\n"))
        print(f"ipyros: {node.name} relays {resolved} unchanged; here is a handler that passes each message on: edit "
              f"it and run it, and it takes the relay's place")

    # -- %status ------------------------------------------------------------------------------
    @magic_arguments()
    @argument("node", nargs="?", complete=DSL_NODE, help="the variable holding the rosNode; none: list the session's nodes")
    @line_magic
    def status(self, line: str) -> None:
        """Per topic and timer of NODE: calls, message rate, handler time (mean, max), exceptions.

        Without NODE: the rosNodes running in this session (created and not shut down).
        """
        args = parse_argstring(self.status, line)
        if args.node:
            self.ext.printer.show(find_node(self.shell, args.node).status())
            return
        # ipyros's own tool nodes (the %pub publisher, %echo's listener) are not the user's.
        session = current()
        nodes = [node_of(engine) for engine in session.nodes.values() if not is_tool(engine.name)]
        if not nodes:
            print("no rosNode of yours is running in this session")
            return
        self.ext.printer.show(session_table(nodes, self.shell.user_ns, session.process.name))
