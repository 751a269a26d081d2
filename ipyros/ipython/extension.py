"""``%load_ext ipyros`` and ``%unload_ext ipyros``: what the extension adds to a shell, and takes back.

Loading:

* registers the magics (:mod:`ipyros.ipython.magics`) and the tab completer (:mod:`ipyros.ipython.completion`,
  answered from a :class:`~ipyros.tools.graph.GraphCache` refreshed in the background);
* puts ``rosNode`` and ``build_messages`` in the user namespace;
* shows an :class:`~ipyros.core.errors.IpyrosError` raised at the prompt as one line, not a traceback;
* prints handler failures from ROS threads without wrecking the prompt
  (:func:`ipyros.ipython.magics.output.failure_report`);
* attaches to the ROS master, and prints one line saying which and how.

The prompt never waits on the network: when a master answers a short local check
(0.3 s at most) it is used at once; otherwise, if allowed, one is started on a
background thread while the prompt comes back. A node's ``create()`` waits for that
start, because both go through the backend's lock (the master connection, ROS 1).

Unloading undoes each of these; nodes the user created keep running (they belong to
the session, which stops them at exit), the ``%pub`` publisher is closed.
"""

from __future__ import annotations

import dataclasses
import logging
import os
import threading
import warnings
from collections import deque
from typing import Any, Optional

from ..core import plan as planning, streams
from ..core.errors import IpyrosError
from ..core.names import is_tool
from ..core.rules import rule
from ..dsl import build_messages, end_chains, rosNode
from ..files.export import ExportWarning
from ..files.savefile import SaveWarning
from ..node.session import Session, configure, current, started as session_started
from ..tools import collector
from ..tools.graph import GraphCache
from ..tools.probe import PromptPublisher
from . import completion, display, progress
from .magics import (
    ActionMagics,
    AgentMagics,
    DemoMagics,
    DrawingMagics,
    IntrospectMagics,
    MachineMagics,
    NodeMagics,
    PlotMagics,
    RateMagics,
    RecordMagics,
    RosMagics,
    SafetyMagics,
    TopicMagics,
    WrapMagics,
    cell_output,
)
from .magics.output import Printer, StderrLogHandler, failure_report, note_line

log = logging.getLogger(__name__)

#: Settings whose change must reach something already running.
_LIVE_SETTINGS = ["master_uri", "start_master", "graph_period", "log_level", "restart_basenodes"]


class Extension:
    """Everything ipyros adds to one shell; :meth:`load` adds it, :meth:`unload` takes it back."""

    def __init__(self, shell: Any) -> None:
        self.shell = shell
        self.settings = RosMagics(shell=shell)  # reads c.RosMagics.* from the shell's config
        self.printer = Printer(lambda: self.settings.rich_output)
        self.publisher = PromptPublisher()
        # The graph of whichever ROS the session runs: read through its backend (chosen when it is first needed).
        self.graph = GraphCache(lambda timeout: self.session.backend.graph_snapshot(timeout),
                                lambda: self.session.backend.where(), period=self.settings.graph_period)
        self.node_magics = NodeMagics(shell, self)
        self.plot_magics = PlotMagics(shell, self)
        self.record_magics = RecordMagics(shell, self)
        self.agent_magics = AgentMagics(shell, self)
        self.drawing_magics = DrawingMagics(shell, self)
        self.magics = [self.settings, TopicMagics(shell, self), RateMagics(shell, self), IntrospectMagics(shell, self),
                       self.node_magics, WrapMagics(shell, self), self.plot_magics, self.record_magics,
                       DemoMagics(shell, self), ActionMagics(shell, self), SafetyMagics(shell, self),
                       MachineMagics(shell, self), self.agent_magics, self.drawing_magics]
        self._completion: Optional[completion.Installed] = None
        self._freezer: Optional[collector.Freezer] = None  # takes what the session loaded out of full collections
        self._log_handler = StderrLogHandler()
        self._report = failure_report(lambda: self.settings.handler_tracebacks)
        self._saved: dict[str, Any] = {}
        self.names_before: Optional[dict] = None

    @property
    def session(self) -> Session:
        return current()

    # -- load ------------------------------------------------------------------------------
    def load(self) -> None:
        shell = self.shell
        if self.settings.ros and not session_started():  # before the session exists: it picks its ROS once
            os.environ["IPYROS_ROS"] = str(self.settings.ros)
        self._saved["config"] = self.session.config
        line = self._configure_session()
        for magics in self.magics:
            shell.register_magics(magics)
        shell.push(_NAMES, interactive=False)
        self._saved["custom_exc"] = (shell.custom_exceptions, shell.CustomTB)
        previous_tb = shell.CustomTB
        shell.set_custom_exc((*shell.custom_exceptions, IpyrosError),
                             lambda sh, etype, value, tb, tb_offset=None: _show_error(sh, previous_tb, etype, value,
                                                                                      tb, tb_offset))
        self._saved["report"] = self.session.report
        self.session.report = self._report
        self._saved["notice"] = self.session.notice
        self.session.notice = note_line
        self._saved["call_name"] = self.session.call_name
        self.session.call_name = self._variable_of
        self._saved["known_graph"] = self.session.known_graph
        self.session.known_graph = self._known_graph
        self._saved["progress"] = self.session.progress
        self.session.progress = progress.view(shell)
        streams.route()  # a thread's prints to where it says (%try keeps a handler's; Jupyter: below its cell)
        if cell_output.in_kernel(shell):
            self._saved["output_scope"] = self.session.output_scope
            self.session.output_scope = _output_below_the_cell
        self._saved["display"] = display.register(shell)  # nd, nd.status(), ... at the prompt: tables
        self._whole_names_in_menus()
        self._start_logging()
        shell.events.register("post_run_cell", self._after_cell)
        self.settings.observe(self._setting_changed, names=_LIVE_SETTINGS)
        self.graph.start()
        self._completion = completion.install(shell, self.graph)
        if self.settings.freeze_gc:  # once the catalog is warm and the graph read (ipyros.tools.collector)
            self._freezer = collector.Freezer(self._completion.warm, self.graph.wait_first)
        self._stop_nodes_before_namespace_goes()
        print(f"ipyros: {line or self._attach()}")

    def _stop_nodes_before_namespace_goes(self) -> None:
        """Close the session before the terminal's exit clears the user namespace.

        ``TerminalInteractiveShell.mainloop`` ends with ``_atexit_once()``, which empties the
        namespace before any ``atexit`` hook runs: handlers still called by ROS then failed
        on globals that were gone (``NameError: name 'speed' is not defined``). IPython has
        no exit event, so the shell's own method is wrapped, on this shell only.
        """
        shell = self.shell
        original = getattr(shell, "_atexit_once", None)
        if original is None:  # an IPython without it: the atexit hook closes the session
            return
        self._saved["atexit_once"] = original

        def close_session_first() -> None:
            if not getattr(shell, "_atexit_once_called", False):
                self.session.close()
            original()

        shell._atexit_once = close_session_first

    def _configure_session(self) -> Optional[str]:
        """Give the session the master settings (keeping the rest); a problem as one line."""
        session = self.session
        uri = self.settings.master_uri or session.config.master_uri
        # A process node name set on the session already (by a script, by a test) is kept when the trait is unset.
        name = _global(self.settings.process_node_name) or session.config.process_node_name
        config = dataclasses.replace(session.config, master_uri=_slashed(uri) if uri else None,
                                     start_master=self.settings.start_master, announce=_quiet,
                                     process_node_name=name, keep_recent=self.settings.try_history,
                                     restart_basenodes=self.settings.restart_basenodes)
        try:
            configure(config)
        except IpyrosError as error:  # already attached elsewhere: keep that master
            session.config = dataclasses.replace(session.config, announce=_quiet)
            return f"{error}"
        return None

    def _attach(self) -> str:
        """The load line: which ROS, and (ROS 1) the master, attached at once if one answers, else started in
        the background if allowed (the announcement the session would make of it is silenced: this line says it)."""
        return self.session.backend.connect(self.session, wait=False)

    def _whole_names_in_menus(self) -> None:
        """Show ROS names whole in the terminal's completion menu.

        IPython shortens a long completion with three slashes in the middle, as it does file
        paths (``/mobile_base/commands/velocity`` shows as ``/m…s/velocity``), which hides the
        very part that tells two topics apart. Unless the user has set ``min_elide``, it is
        turned off while ipyros is loaded.
        """
        shell = self.shell
        if hasattr(shell, "min_elide") and "min_elide" not in shell.config.get("TerminalInteractiveShell", {}):
            self._saved["min_elide"] = shell.min_elide
            shell.min_elide = 0

    def _start_logging(self) -> None:
        logger = logging.getLogger("ipyros")
        self._saved["logging"] = (logger.level, logger.propagate)
        logger.addHandler(self._log_handler)
        logger.propagate = False  # the root logger would print it a second time
        logger.setLevel(self.settings.log_level.upper())
        self._saved["showwarning"] = warnings.showwarning
        warnings.showwarning = self._show_warning

    def _show_warning(self, message: Any, category: type, filename: str, lineno: int, file: Any = None,
                      line: Optional[str] = None) -> None:
        """ipyros's own warnings (a save that needs a global, an export that left one out) as the one line they
        are, not Python's ``file:line: UserWarning`` with the magic's generated code under it."""
        if issubclass(category, (SaveWarning, ExportWarning)):
            note_line(str(message))
            return
        self._saved["showwarning"](message, category, filename, lineno, file, line)

    def _known_graph(self) -> Any:
        """The graph as the cache last read it (what TAB after ``nd.reuse.publish.`` offers)."""
        return self.graph.snapshot

    def _variable_of(self, node: Any) -> str:
        """The user's variable holding ``node`` (for advice like ``wnode.base.restart()``), else how to get it."""
        for namespace in (self.shell.user_ns, self.names_before or {}):  # a load that fails restores the latter
            names = sorted(k for k, v in list(namespace.items()) if v is node and not k.startswith("_"))
            if names:
                return names[0]
        return f"rosNode.running({node.fullname!r})" if node.created else node.name  # its variable holds another

    # -- while loaded ------------------------------------------------------------------------
    def _after_cell(self, result: Any = None) -> None:
        """``post_run_cell``: end the cell's declaration chains; swap edited handlers in; give new subscriptions
        their history size."""
        end_chains()
        self.node_magics.after_cell(result)
        self._keep_history(self.settings.try_history)

    def _keep_history(self, size: int) -> None:
        """Make every subscription of the session's nodes keep its last ``size`` messages (for %try)."""
        for node in list(self.session.nodes.values()):  # the nodes' engines
            for topic in node.model().subscriptions():
                slot = node.slot(planning.topic_slot(topic.resolved))
                if slot is not None and slot.recent.maxlen != size:
                    # A message arriving during the copy may be missed by the history; never by the handler.
                    slot.recent = deque(slot.recent, maxlen=size)

    def _setting_changed(self, change: Any) -> None:
        name, value = change["name"], change["new"]
        if name == "graph_period":
            self.graph.period = value
        elif name == "log_level":
            logging.getLogger("ipyros").setLevel(value.upper())
        elif name == "restart_basenodes":
            self.session.config = dataclasses.replace(self.session.config, restart_basenodes=value)
        else:  # master_uri, start_master
            problem = self._configure_session()
            print(f"ipyros: {problem or self._attach()}")

    # -- unload ------------------------------------------------------------------------------
    def unload(self) -> None:
        shell = self.shell
        if self._completion is not None:
            completion.uninstall(shell, self._completion)
            self._completion = None
        if self._freezer is not None:
            self._freezer.thaw()
            self._freezer = None
        self.graph.stop()
        self.plot_magics.stop_live()
        self.record_magics.stop()
        self.agent_magics.stop()
        self.drawing_magics.stop_live()
        self.settings.unobserve(self._setting_changed, names=_LIVE_SETTINGS)
        shell.events.unregister("post_run_cell", self._after_cell)
        logger = logging.getLogger("ipyros")
        logger.removeHandler(self._log_handler)
        logger.setLevel(self._saved["logging"][0])
        logger.propagate = self._saved["logging"][1]
        if warnings.showwarning == self._show_warning:
            warnings.showwarning = self._saved["showwarning"]
        session = self.session
        if session.report is self._report:
            session.report = self._saved["report"]
        if session.notice is note_line:
            session.notice = self._saved["notice"]
        if session.call_name == self._variable_of:
            session.call_name = self._saved["call_name"]
        if session.known_graph == self._known_graph:
            session.known_graph = self._saved["known_graph"]
        session.progress = self._saved.get("progress", session.progress)
        if "output_scope" in self._saved:
            session.output_scope = self._saved["output_scope"]
        streams.unroute()
        saved = self._saved["config"]
        try:
            session.backend.check_config(session, saved.master_uri)
            session.config = saved  # the master settings as they were before loading
        except IpyrosError:  # attached to another master meanwhile: keep it
            session.config = dataclasses.replace(session.config, announce=saved.announce)
        display.unregister(self._saved.pop("display", []))
        if "min_elide" in self._saved and shell.min_elide == 0:
            shell.min_elide = self._saved["min_elide"]
        shell.custom_exceptions, shell.CustomTB = self._saved["custom_exc"]
        if "atexit_once" in self._saved:
            del shell._atexit_once  # the class's method again
        shell.drop_by_id(_NAMES)
        for magics in self.magics:
            _unregister(shell, magics)
        self.publisher.close()


#: What the extension puts in the user's namespace (and takes back, if the user has not rebound them).
_NAMES = {"rosNode": rosNode, "rule": rule, "build_messages": build_messages}


def _output_below_the_cell(node: rosNode) -> Optional[cell_output.NodeOutput]:
    """A node created from a cell prints below that cell; ipyros's own tool nodes print nowhere of their own."""
    if is_tool(node.name) or threading.current_thread() is not threading.main_thread():
        return None
    return cell_output.NodeOutput(cell_output.OutputArea())


def _global(name: str) -> Optional[str]:
    """A node name from the settings as a global name; empty means "not set"."""
    name = name.strip()
    return ("/" + name.lstrip("/")) if name else None


def _quiet(text: str) -> None:
    """The session's announcement, silenced while the extension is loaded (its load line says it)."""


def _show_error(shell: Any, previous: Any, etype: type, value: BaseException, tb: Any,
                tb_offset: Optional[int] = None) -> Optional[list[str]]:
    """The custom exception handler: an IpyrosError as one line; others to the previous handler."""
    if not isinstance(value, IpyrosError):
        return previous(etype, value, tb, tb_offset=tb_offset)
    name = etype.__name__
    if str(getattr(shell, "colors", "nocolor")).lower() != "nocolor":
        name = f"\x1b[31;1m{name}\x1b[0m"
    text = " ".join(str(value).split())  # one line, whatever a library put in it
    if len(text) > 2000:  # a value quoted whole would fill the screen
        text = f"{text[:1000]} ... {text[-400:]} ({len(text):,} characters)"
    stb = [f"{name}: {text}"]
    shell._showtraceback(etype, value, stb)  # a kernel sends it as the cell's error
    return stb


def _unregister(shell: Any, magics: Any) -> None:
    """Take one Magics instance out of the shell (IPython has no API to unregister)."""
    manager = shell.magics_manager
    for kind, table in magics.magics.items():
        for name, method in table.items():
            if manager.magics[kind].get(name) == method:
                del manager.magics[kind][name]
    if manager.registry.get(type(magics).__name__) is magics:
        del manager.registry[type(magics).__name__]
    if magics in shell.configurables:
        shell.configurables.remove(magics)


def _slashed(uri: str) -> str:
    return uri if uri.endswith("/") else uri + "/"


# -- the entry points -----------------------------------------------------------------------
_loaded: dict[int, Extension] = {}


def load_ipython_extension(ipython: Any) -> None:
    """Load ipyros into ``ipython`` (``%load_ext ipyros``); a second load does nothing."""
    if id(ipython) in _loaded:
        return
    extension = Extension(ipython)
    _loaded[id(ipython)] = extension
    try:
        extension.load()
    except BaseException:
        del _loaded[id(ipython)]
        raise


def unload_ipython_extension(ipython: Any) -> None:
    """Unload ipyros from ``ipython`` (``%unload_ext ipyros``)."""
    extension = _loaded.pop(id(ipython), None)
    if extension is not None:
        extension.unload()


__all__ = ["Extension", "load_ipython_extension", "unload_ipython_extension"]
