"""%load_ext ipyros / %unload_ext ipyros in a real InteractiveShell, the settings, and error display."""

from __future__ import annotations

import io
import logging
import os
import re
import subprocess
import sys
import textwrap

import pytest
from IPython.core.error import UsageError
from peer import Peer
from ros1_fixtures import free_port, wait_for
from shell import end_shell, error_of, interactive_shell, ok
from traitlets.config import Config

from ipyros import IpyrosError, build_messages, rosNode
from ipyros.ipython.completion import IDENTIFIER
from ipyros.ipython.extension import _loaded
from ipyros.ipython.magics import RosMagics
from ipyros.ros1 import master as master_mod

MAGICS = {"line": {"topics", "echo", "pub", "handler", "try", "status", "wrap"}, "cell": {"pub", "handler"}}


def ipyros_matchers(shell):
    return [m for m in shell.Completer.custom_matchers if getattr(m, "matcher_identifier", None) == IDENTIFIER]


def test_load_registers_everything_and_prints_one_line(ros_session, ros_master, capsys):
    with interactive_shell(load=False) as shell:
        before_exc = shell.custom_exceptions
        shell.run_line_magic("load_ext", "ipyros")
        lines = capsys.readouterr().out.strip().splitlines()
        assert lines == [f"ipyros: ROS master {ros_master} (found running)"]
        for kind, names in MAGICS.items():
            assert names <= set(shell.magics_manager.magics[kind])
        assert shell.user_ns["rosNode"] is rosNode and shell.user_ns["build_messages"] is build_messages
        assert any(isinstance(c, RosMagics) for c in shell.configurables)
        assert len(ipyros_matchers(shell)) == 1
        assert IpyrosError in shell.custom_exceptions and before_exc == ()
        extension = _loaded[id(shell)]
        assert ros_session.report is extension._report
        assert extension.graph.running
        shell.run_line_magic("load_ext", "ipyros")  # a second load: nothing more
        assert len(ipyros_matchers(shell)) == 1


def test_unload_takes_everything_back(ros_session):
    with interactive_shell(load=False) as shell:
        report, announce = ros_session.report, ros_session.config.announce
        callbacks = list(shell.events.callbacks["post_run_cell"])
        shell.run_line_magic("load_ext", "ipyros")
        graph = _loaded[id(shell)].graph
        shell.run_line_magic("unload_ext", "ipyros")
        for kind, names in MAGICS.items():
            assert not names & set(shell.magics_manager.magics[kind])
        assert not {"RosMagics", "TopicMagics", "NodeMagics", "WrapMagics"} & set(shell.magics_manager.registry)
        assert not [c for c in shell.configurables if type(c).__module__.startswith("ipyros")]
        assert not ipyros_matchers(shell)
        assert "rosNode" not in shell.user_ns and "build_messages" not in shell.user_ns
        assert shell.custom_exceptions == ()
        assert shell.events.callbacks["post_run_cell"] == callbacks
        assert ros_session.report is report and ros_session.config.announce is announce
        assert not graph.running and id(shell) not in _loaded
        assert logging.getLogger("ipyros").handlers == []
        # and it loads again
        shell.run_line_magic("load_ext", "ipyros")
        assert "topics" in shell.magics_manager.magics["line"]
        shell.run_line_magic("reload_ext", "ipyros")
        assert len(ipyros_matchers(shell)) == 1


def test_what_the_session_loaded_leaves_full_collections_while_loaded_and_only_then(ros_session):
    """A full garbage collection walked every object for 70-105 ms and stalled a TAB: once the session has
    loaded, its objects are frozen out of the collector's walk; unloading gives them back, and the setting
    turns it off (ipyros.tools.collector)."""
    import gc

    assert gc.get_freeze_count() == 0
    with interactive_shell(load=False) as shell:
        shell.run_line_magic("load_ext", "ipyros")
        wait_for(lambda: gc.get_freeze_count() > 0, timeout=60, what="the loaded objects to be frozen")
        shell.run_line_magic("unload_ext", "ipyros")
        assert gc.get_freeze_count() == 0
    config = Config()
    config.RosMagics.freeze_gc = False
    with interactive_shell(config) as shell:
        assert _loaded[id(shell)]._freezer is None and gc.get_freeze_count() == 0


def test_unload_keeps_a_rosnode_the_user_rebound(ros_session):
    with interactive_shell() as shell:
        ok(shell, "rosNode = 42")
        shell.run_line_magic("unload_ext", "ipyros")
        assert shell.user_ns["rosNode"] == 42


def test_ipyros_errors_show_as_one_line_and_other_errors_keep_their_traceback(ip, capsys):
    error = error_of(ip, "rosNode('bad name')")
    assert isinstance(error, IpyrosError)
    out = capsys.readouterr().out
    assert out.strip() == f"TopicNameError: {error}"
    assert "Traceback" not in out
    error_of(ip, "1/0")
    assert "Traceback" in capsys.readouterr().out


def test_bad_options_are_usage_errors_with_the_usage(ip, capsys):
    error = error_of(ip, "%topics --bogus")
    assert isinstance(error, UsageError) and "unrecognized arguments: --bogus" in str(error)
    assert "UsageError" in capsys.readouterr().err
    assert "--hz" in ip.find_line_magic("topics").__doc__  # what %topics? shows


def test_settings_come_from_the_shell_config(ros_session, ros_master):
    config = Config()
    config.RosMagics.hz_window = 0.25
    config.RosMagics.graph_period = 0.2
    config.RosMagics.echo_count = 3
    config.RosMagics.log_level = "debug"
    config.RosMagics.rich_output = False
    config.RosMagics.master_uri = ros_master.rstrip("/")
    with interactive_shell(config) as shell:
        extension = _loaded[id(shell)]
        settings = extension.settings
        assert (settings.hz_window, settings.echo_count, settings.rich_output) == (0.25, 3, False)
        assert extension.graph.period == 0.2 and extension.graph.where == ros_master
        assert logging.getLogger("ipyros").level == logging.DEBUG
        assert ros_session.config.master_uri == ros_master
    assert logging.getLogger("ipyros").level == logging.NOTSET


def test_config_magic_lists_and_sets_the_settings(ip, capsys, caplog):
    ip.run_line_magic("config", "")
    assert "RosMagics" in capsys.readouterr().out.split()
    ip.run_line_magic("config", "RosMagics")
    listing = capsys.readouterr().out
    for name in ("master_uri", "start_master", "graph_period", "log_level", "handler_tracebacks", "echo_count",
                 "hz_window", "try_history", "rich_output"):
        assert f"RosMagics.{name}" in listing
    extension = _loaded[id(ip)]
    ok(ip, "%config RosMagics.graph_period = 0.3")
    assert extension.graph.period == 0.3
    ok(ip, "%config RosMagics.log_level = 'INFO'")
    assert logging.getLogger("ipyros").level == logging.INFO
    ok(ip, "%config RosMagics.hz_window = -1")  # %config logs the refusal
    assert extension.settings.hz_window == 1.0
    assert "hz_window must be from 0.05 to 600 seconds, not -1" in caplog.text
    refused = {"graph_period = 1e9": "graph_period must be from 0.05 to 3600 seconds, not 1000000000.0",
               "hz_window = float('nan')": "hz_window must be from 0.05 to 600 seconds, not nan",
               "echo_count = 10**9": "echo_count must be from 0 to 1,000,000, not 1000000000",
               "try_history = -1": "try_history must be from 0 to 10,000, not -1",
               "master_uri = 'localhost'": "master_uri 'localhost' is not a ROS master URI; write it like "
                                           "'http://localhost:11311/'",
               "master_uri = 'http://robot/'": "master_uri 'http://robot/' is not a ROS master URI",
               "process_node_name = 'my node'": "process_node_name 'my node': invalid node name 'my node'",
               "ros = 3": "ros must be 1 (ROS 1), 2 (ROS 2) or 0 (found by itself), not 3"}
    before = {name: getattr(extension.settings, name) for name in ("graph_period", "hz_window", "echo_count",
                                                                   "try_history", "master_uri", "process_node_name",
                                                                   "ros")}
    for assignment, message in refused.items():
        caplog.clear()
        ok(ip, f"%config RosMagics.{assignment}")
        assert message in caplog.text, assignment
    assert {name: getattr(extension.settings, name) for name in before} == before


def test_changing_the_master_after_attaching_says_it_is_too_late(ip, ros_master, capsys):
    ok(ip, "%config RosMagics.master_uri = 'http://localhost:1/'")
    out = capsys.readouterr().out
    assert f"already uses the master at {ros_master}" in out


def test_handler_failures_print_the_handler_traceback(ip, capsys):
    ok(ip, textwrap.dedent("""\
        from std_msgs.msg import UInt32
        def fragile(msg):
            return 1 / (msg.data - msg.data)
        fnd = rosNode('ext_fragile').new.subscribe('/ext_fragile', fragile, msgType=UInt32).create()
        """))
    try:
        with Peer("publish_seq.py", "/ext_fragile", 3, 50) as peer:
            peer.wait_line("done")
        err = wait_for(lambda: capsys.readouterr().err or None, what="the failure report")
        assert "ipyros: handler fragile failed on ext_fragile /ext_fragile; the node keeps running" in err
        assert "ZeroDivisionError: division by zero" in err and "return 1 / (msg.data - msg.data)" in err
        ok(ip, "%config RosMagics.handler_tracebacks = False")
        _loaded[id(ip)].session.report(_failure())
        assert capsys.readouterr().err.strip() == (
            "ipyros: handler h failed on n /t; the node keeps running: ValueError: boom")
    finally:
        ok(ip, "fnd.shutdown()")


def _failure():
    from ipyros.core.slots import HandlerFailure

    return HandlerFailure("n /t", "h", ValueError("boom"), "Traceback ...", 0)


def test_no_master_and_no_start_returns_at_once_and_says_so(ros_session, capsys):
    uri = f"http://127.0.0.1:{free_port()}/"
    config = Config()
    config.RosMagics.start_master = False
    previous = ros_session.config
    connection = ros_session.backend.connection
    connection.master, attached = None, connection.master  # as if nothing was attached yet
    try:
        config.RosMagics.master_uri = uri
        with interactive_shell(config):
            out = capsys.readouterr().out
    finally:
        connection.master, ros_session.config = attached, previous
    assert f"ipyros: no ROS master answers at {uri}; start roscore there" in out


@pytest.mark.timeout(60)
def test_embedded_master_starts_in_the_background_and_outlives_the_load(tmp_path, ros_home):
    """In a fresh interpreter (its own session): load returns at once, the master comes up, nodes use it."""
    port = free_port()
    uri = f"http://127.0.0.1:{port}/"
    script = tmp_path / "embedded.py"
    script.write_text(textwrap.dedent(f"""
        import time, sys
        from IPython.core.interactiveshell import InteractiveShell
        from traitlets.config import Config
        c = Config(); c.HistoryManager.hist_file = ':memory:'
        ip = InteractiveShell.instance(config=c)
        from ipyros.ros1 import master
        ip.run_line_magic('load_ext', 'ipyros')
        print('master up when the load returned:', master.answers('{uri}', 0.05), flush=True)
        while not master.answers('{uri}'):
            time.sleep(0.05)
        time.sleep(0.5)  # the thread that started it has finished its work: the master must live on
        ip.run_cell("nd = rosNode('embedded_user').create(); print('created', nd.ros_name)")
        print('done', flush=True)
        sys.stdin.read()
    """))
    env = {**os.environ, "ROS_MASTER_URI": uri}
    proc = subprocess.Popen([sys.executable, str(script)], stdin=subprocess.PIPE, stdout=subprocess.PIPE,
                            stderr=subprocess.STDOUT, text=True, env=env)
    try:
        lines = []
        for line in proc.stdout:  # type: ignore[union-attr]
            lines.append(line.strip())
            if line.startswith("done"):
                break
        assert f"ipyros: no ROS master answered at {uri}; starting one there (it stops when this session exits)" \
            in lines, lines
        # The load did not wait for it: rosmaster takes most of a second to come up.
        assert "master up when the load returned: False" in lines, lines
        assert "created /embedded_user" in lines, lines
        assert master_mod.answers(uri)
        # Loading again names it in one plain line: no brackets inside brackets.
        described = master_mod.MasterHandle(uri, started=True).describe()
        assert re.fullmatch(r"ROS master \S+ \([^()]*\)", described), described
    finally:
        proc.stdin.close()  # type: ignore[union-attr]
        proc.wait(20)
    wait_for(lambda: not master_mod.answers(uri, timeout=0.2), timeout=10, what="the master to stop with the session")


class _Terminal(io.StringIO):
    def isatty(self) -> bool:
        return True


def test_rich_output_colours_a_terminal_and_plain_output_does_not(ip, monkeypatch):
    from rich.table import Table

    printer = _loaded[id(ip)].printer
    table = Table("topic")
    table.add_row("[bold]/x[/]")
    for rich, coloured in ((True, True), (False, False)):
        ok(ip, f"%config RosMagics.rich_output = {rich}")
        terminal = _Terminal()
        monkeypatch.setattr(sys, "stdout", terminal)
        printer.show(table)
        monkeypatch.undo()
        assert ("\x1b[" in terminal.getvalue()) is coloured
        assert "/x" in terminal.getvalue()


def test_completion_answers_from_the_extensions_graph(ip, rate_topic):
    from IPython.core.completer import provisionalcompleter

    graph = _loaded[id(ip)].graph
    wait_for(lambda: rate_topic in graph.snapshot.topics, what="the background refresh to see the topic")
    text = "%echo /ext_ra"
    with provisionalcompleter():
        completions = [c.text for c in ip.Completer.completions(text, len(text))]
    assert rate_topic in completions


@pytest.fixture
def rate_topic():
    with Peer("publish_rate.py", "/ext_rate", 10) as peer:
        peer.wait_line("ready")
        yield "/ext_rate"


def test_every_magic_has_a_help_text_that_reads_right(ip, capsys):
    """%name? shows each magic's docstring and usage: under its own name, with no argparse leftovers."""
    from ipyros.ipython.extension import _loaded as loaded

    extension = loaded[id(ip)]
    names = sorted({name for magics in extension.magics for kind in ("line", "cell")
                    for name in magics.magics[kind]})
    assert {"topics", "echo", "hz", "pub", "wrap", "handler", "try", "status", "save_nodes", "load_nodes"} <= set(names)
    for name in names:
        capsys.readouterr()
        ip.run_line_magic("pinfo", f"%{name}")
        text = capsys.readouterr().out
        assert "Docstring:" in text and len(text.split("Docstring:", 1)[1].strip()) > 40, f"%{name} has no help"
        garbled = re.search(r"option_strings|%\(|%[sd]\b|'dest': ", text)
        assert garbled is None, f"%{name}? shows {garbled and garbled.group()!r}:\n{text}"
        usage = re.search(r"::\s+(%\S+)", text)
        assert usage is None or usage.group(1) == f"%{name}", f"%{name}? shows its usage under another name:\n{text}"


def test_terminal_menus_show_ros_names_whole(ros_session):
    """IPython shortens long completions with three slashes in the middle, as file paths; ROS names stay whole
    while ipyros is loaded (unless the user set min_elide), and the setting comes back at unload."""
    from IPython.terminal.interactiveshell import TerminalInteractiveShell
    from IPython.terminal.ptutils import _elide

    name = "/robot/mobile_base/commands/velocity"
    for configured in (None, 20):
        config = Config()
        config.HistoryManager.hist_file = ":memory:"
        config.TerminalInteractiveShell.simple_prompt = True
        if configured is not None:
            config.TerminalInteractiveShell.min_elide = configured
        TerminalInteractiveShell.clear_instance()
        shell = TerminalInteractiveShell.instance(config=config)
        try:
            assert _elide(name, "", min_elide=shell.min_elide) != name  # what IPython does by itself
            shell.run_line_magic("load_ext", "ipyros")
            if configured is None:
                assert _elide(name, "", min_elide=shell.min_elide) == name
            else:
                assert shell.min_elide == configured, "the user's own setting is kept"
            shell.run_line_magic("unload_ext", "ipyros")
            assert shell.min_elide == (configured or 30)
        finally:
            if "ipyros" in shell.extension_manager.loaded:
                shell.run_line_magic("unload_ext", "ipyros")
            end_shell(shell)
            TerminalInteractiveShell.clear_instance()
