"""Tab completion, answered from a GraphCache of a real master with a real publisher process.

Two tiers: the matcher called with a CompletionContext, and the whole IPython completer
(``Completer.completions``) of a real InteractiveShell. The DSL node in user_ns is a
small object whose ``model()`` returns a hand-built NodeModel: plain data, not a ROS mock.
"""

from __future__ import annotations

import time
import warnings
from typing import Optional

import pytest
from helpers import one_call
from IPython.core.completer import CompletionContext, provisionalcompleter
from IPython.core.interactiveshell import InteractiveShell
from ros1_fixtures import free_port, master_graph, wait_for
from shell import end_shell
from topic_nodes import many_topics
from traitlets.config import Config

from ipyros.core.model import BaseModel, NodeModel, ServiceModel, TimerModel, TopicModel
from ipyros.ipython import magics
from ipyros.ipython.completion import (
    IDENTIFIER,
    Catalog,
    RosMatcher,
    default_catalog,
    install,
    string_argument,
    uninstall,
)

LIVE = {
    "/ct/turtle1/cmd_vel": "geometry_msgs/Twist",
    "/ct/turtle1/pose": "geometry_msgs/Pose2D",
    "/ct/turtle1/color_sensor": "std_msgs/ColorRGBA",
    "/ct/turtle2/cmd_vel": "geometry_msgs/Twist",
    "/ct/cmd_vel": "geometry_msgs/Twist",
    "/ct/odom": "std_msgs/String",
}

CATALOG = Catalog(
    message_types=lambda: ["std_msgs/String", "geometry_msgs/TwistStamped", "geometry_msgs/Twist", "geometry_msgs/Pose"],
    service_types=lambda: ["std_srvs/SetBool", "std_srvs/Empty"],
    packages=lambda: ["turtlesim", "topic_tools", "turtle_tf"],
    executables=lambda pkg: {"turtlesim": ["turtlesim_node", "turtle_teleop_key", "draw_square"]}.get(pkg, []),
)


class FakeNode:
    """Stands in for a DSL node: completion only ever calls ``model()``."""

    def __init__(self, model: NodeModel):
        self._model = model

    def model(self) -> NodeModel:
        return self._model


def wrapping_model() -> NodeModel:
    """Like the paper's ``wnode``, in namespace /ct."""
    return NodeModel(
        name="wnode",
        namespace="/ct/",
        base=BaseModel(executable="turtlesim_node", package="turtlesim"),
        topics=[
            TopicModel("cmd_vel", "/ct/cmd_vel", "subscribe", "geometry_msgs/Twist", "new", "relay"),
            TopicModel("odom", "/ct/odom", "subscribe", "std_msgs/String", "reuse"),
            TopicModel("mobile_base/commands/velocity", "/ct/mobile_base/commands/velocity", "publish",
                       "geometry_msgs/Twist"),
            TopicModel("/ct/turtle1/zz_mine", "/ct/turtle1/zz_mine", "publish", "std_msgs/String"),
        ],
        timers=[TimerModel("tick", 1.0, "on_tick"), TimerModel("blink", 0.5, "on_blink")],
        services=[ServiceModel("reset", "/ct/reset", "std_srvs/Empty", "new", "do_reset")],
    )


@pytest.fixture(scope="module")
def graph(ros_master):
    with many_topics("compl_sim", 0, topics=LIVE, subscribe=("/ct/tf",)):
        cache = master_graph(ros_master, period=0.2).start()
        wait_for(lambda: set(LIVE) | {"/ct/tf"} <= set(cache.snapshot.topics), timeout=20,
                 what="the test node's topics in the graph")
        yield cache
        cache.stop()


@pytest.fixture
def ip():
    config = Config()
    config.HistoryManager.hist_file = ":memory:"
    shell = InteractiveShell.instance(config=config)
    # ipyros's magics, without loading the extension: the matcher reads their own parsers.
    shell.register_magics(*(cls(shell, None) for cls in (getattr(magics, name) for name in magics.__all__)
                            if cls is not magics.RosMagics))
    shell.user_ns["wnode"] = FakeNode(wrapping_model())
    shell.user_ns["nd"] = FakeNode(NodeModel(name="nd", topics=[
        TopicModel("/ct/turtle1/cmd_vel", "/ct/turtle1/cmd_vel", "publish", "geometry_msgs/Twist"),
        TopicModel("/ct/turtle1/pose", "/ct/turtle1/pose", "subscribe", "geometry_msgs/Pose2D", "new", "show"),
    ]))
    shell.user_ns["not_a_node"] = 42
    yield shell
    end_shell(shell)
    InteractiveShell.clear_instance()


@pytest.fixture
def matcher(ip, graph):
    return RosMatcher(ip, graph, CATALOG)


def ask(matcher: RosMatcher, text: str, limit: Optional[int] = None):
    """Call the matcher as IPython would, with the cursor at the end of ``text`` (IPython asks for 500 at most)."""
    lines = text.split("\n")
    token = text.split()[-1] if text.strip() and not text[-1].isspace() else ""
    for delim in "\"'(=:":
        token = token.rsplit(delim, 1)[-1]
    context = CompletionContext(token=token, full_text=text, cursor_position=len(lines[-1]),
                                cursor_line=len(lines) - 1, limit=limit)
    return matcher(context)


def texts(matcher: RosMatcher, text: str) -> list[str]:
    """The completions of text that ipyros answers (an empty list when nothing matches)."""
    result = ask(matcher, text)
    assert result["suppress"] is True, f"not answered: {text!r}"
    return [c.text for c in result["completions"] if c.text]  # "" stands for "no match", as in the terminal


# -- tier 1: the matcher with a CompletionContext ---------------------------------------
def test_topics_magic_completes_live_topics_by_prefix(matcher):
    result = ask(matcher, "%topics /ct/tur")
    assert [c.text for c in result["completions"]] == [
        "/ct/turtle1/cmd_vel", "/ct/turtle1/color_sensor", "/ct/turtle1/pose", "/ct/turtle2/cmd_vel"]
    assert result["suppress"] is True and result["matched_fragment"] == "/ct/tur" and result["ordered"]
    # Each completion says what the topic carries.
    assert [c.type for c in result["completions"]][:2] == ["geometry_msgs/Twist", "std_msgs/ColorRGBA"]
    assert texts(matcher, "%echo /ct/turtle1/p") == ["/ct/turtle1/pose"]
    assert "/ct/tf" in texts(matcher, "%topics /ct/t")  # subscribed-only topics are live too


def test_a_message_path_completes_the_fields_of_the_live_topics_type(matcher):
    assert texts(matcher, "%echo /ct/turtle1/cmd_vel.lin") == ["/ct/turtle1/cmd_vel.linear"]
    assert texts(matcher, "%echo /ct/turtle1/cmd_vel.linear.") == [f"/ct/turtle1/cmd_vel.linear.{f}" for f in "xyz"]
    assert texts(matcher, "%plot /ct/turtle1/cmd_vel angular.") == [f"angular.{f}" for f in "xyz"]


def test_relative_tail_completes_in_the_default_namespace(matcher):
    assert texts(matcher, "%echo ct/turtle1/c") == ["ct/turtle1/cmd_vel", "ct/turtle1/color_sensor"]


def test_topics_magic_options(matcher):
    assert texts(matcher, "%topics /ct --type geometry_msgs/Tw") == ["geometry_msgs/Twist", "geometry_msgs/TwistStamped"]
    assert texts(matcher, "%topics --type=geometry_msgs/P") == ["geometry_msgs/Pose"]
    assert texts(matcher, "%topics -t Tw") == ["geometry_msgs/Twist", "geometry_msgs/TwistStamped"]  # by short name
    assert texts(matcher, "%topics --node /compl") == ["/compl_sim"]
    # After an option's value, the next word is positional again.
    assert texts(matcher, "%topics --node /compl_sim /ct/turtle2") == ["/ct/turtle2/cmd_vel"]


def test_pub_magic_topic_then_type(matcher):
    assert texts(matcher, "%pub /ct/turtle2/") == ["/ct/turtle2/cmd_vel"]
    assert texts(matcher, "%pub /ct/turtle2/cmd_vel geometry_msgs/T") == [
        "geometry_msgs/Twist", "geometry_msgs/TwistStamped"]


def test_the_rostopic_rosservice_rosnode_magics_complete_live_names_and_templates(matcher):
    assert texts(matcher, "%hz /ct/turtle1/pose /ct/turtle2/") == ["/ct/turtle2/cmd_vel"]
    assert texts(matcher, "%bw /ct/od") == ["/ct/odom"] and texts(matcher, "%delay /ct/od") == ["/ct/odom"]
    assert texts(matcher, "%node compl_") == ["compl_sim"] and texts(matcher, "%nodes /compl") == ["/compl_sim"]
    assert texts(matcher, "%params /compl") == ["/compl_sim"]
    assert texts(matcher, "%call /x std_srvs/Set") == ["std_srvs/SetBool"]
    assert texts(matcher, "%call /x std_srvs/SetBool ") == ["{data: false}"]  # the request, to edit and send


def test_pub_magic_offers_the_live_type_then_a_template(matcher):
    # After the topic: the type it carries first, then the others.
    assert texts(matcher, "%pub /ct/turtle1/pose ")[:2] == ["geometry_msgs/Pose2D", "geometry_msgs/Pose"]
    result = ask(matcher, "%pub /ct/turtle1/pose ")
    assert result["completions"][0].type == "carried by /ct/turtle1/pose"
    # After the type: the whole message, every field at its default, which %pub reads back.
    (template,) = texts(matcher, "%pub /ct/turtle2/cmd_vel geometry_msgs/Twist ")
    assert template == "{linear: {x: 0.0, y: 0.0, z: 0.0}, angular: {x: 0.0, y: 0.0, z: 0.0}}"
    from ipyros.core.msgbuild import build_message, parse_data

    assert build_message("geometry_msgs/Twist", parse_data(template)).linear.x == 0.0
    assert texts(matcher, "%pub /ct/odom std_msgs/String ") == ["{data: ''}"]
    assert texts(matcher, "%pub /ct/odom std_msgs/String {da") == []  # typing the data: nothing to add
    assert texts(matcher, "%pub /ct/odom std_msgs/Strin ") == []  # an unknown type: %pub will say so


def test_try_and_status_magics_complete_nodes_and_subscriptions(matcher):
    assert texts(matcher, "%status w") == ["wnode"]
    assert texts(matcher, "%try ") == ["nd", "wnode"]
    assert "/ct/turtle1/pose" in texts(matcher, "%try nd /ct/turtle1/p")


def test_versions_revert_and_save_magics_complete_nodes(matcher):
    assert texts(matcher, "%versions w") == ["wnode"]
    assert texts(matcher, "%revert wnode c") == ["cmd_vel"]
    assert texts(matcher, "%save_nodes lab.py w") == ["wnode"]
    assert texts(matcher, "%save_nodes lab.py nd w") == ["wnode"]
    assert texts(matcher, "%demo k") == ["kobuki"]


def test_handler_magic_node_then_its_subscriptions(matcher):
    assert texts(matcher, "%handler ") == ["nd", "wnode"]  # variables holding DSL nodes, nothing else
    assert texts(matcher, "%handler w") == ["wnode"]
    assert texts(matcher, "%handler wnode ") == ["cmd_vel", "odom"]
    assert texts(matcher, "%handler wnode c") == ["cmd_vel"]
    assert texts(matcher, "%handler nd /") == ["/ct/turtle1/pose"]
    # An unknown node name: fall back to the live topics.
    assert texts(matcher, "%handler ghost /ct/turtle2") == ["/ct/turtle2/cmd_vel"]


def test_wrap_magic_package_executable_and_topic_options(matcher):
    assert texts(matcher, "%wrap turt") == ["turtle_tf", "turtlesim"]
    assert texts(matcher, "%wrap turtlesim turtle") == ["turtle_teleop_key", "turtlesim_node"]
    assert texts(matcher, "%wrap turtlesim turtlesim_node --reuse /ct/turtle1/p") == ["/ct/turtle1/pose"]
    assert texts(matcher, "%wrap turtlesim turtlesim_node --remap /ct/odom:=/ct/turtle2/") == ["/ct/turtle2/cmd_vel"]
    assert texts(matcher, "%wrap nosuchpkg ") == []


def test_dsl_string_arguments_complete_topics(matcher):
    # An unknown receiver: the method name alone says it is a topic.
    assert texts(matcher, 'x.subscribe(topic="/ct/turtle2') == ["/ct/turtle2/cmd_vel"]
    assert texts(matcher, "y.publish(topic='/ct/turtle1/p") == ["/ct/turtle1/pose"]
    assert texts(matcher, 'x.new.subscribe("/ct/turtle1/col') == ["/ct/turtle1/color_sensor"]


def test_dsl_node_topics_come_first(matcher):
    # nd.write: the node's publications first, then the live topics.
    assert texts(matcher, 'nd.write("/ct/turtle1/') == [
        "/ct/turtle1/cmd_vel", "/ct/turtle1/color_sensor", "/ct/turtle1/pose"]
    assert texts(matcher, 'wnode.write("/ct/turtle1/')[0] == "/ct/turtle1/zz_mine"
    # Relative names as the node declared them, in the node's namespace (/ct/).
    assert texts(matcher, 'wnode.write("')[:2] == ["/ct/turtle1/zz_mine", "mobile_base/commands/velocity"]
    assert texts(matcher, 'wnode.write("turtle1/')[:2] == ["turtle1/zz_mine", "turtle1/cmd_vel"]
    # subscribe: own subscriptions first (odom before the live /ct/cmd_vel... duplicates dropped).
    assert texts(matcher, 'wnode.new.subscribe(topic="') [:2] == ["cmd_vel", "odom"]
    assert texts(matcher, 'wnode.new.subscribe(topic="turtle2/') == ["turtle2/cmd_vel"]
    assert texts(matcher, 'wnode.reuse.subscribe(topic="c') == ["cmd_vel"]


def test_a_limit_gives_the_first_completions_of_the_same_order(matcher):
    """IPython asks for 500 at most: with 10,000 live topics the rest would be most of a TAB's time."""
    for text in ("%topics /ct/tur", 'nd.write("/ct/turtle1/', 'wnode.write("'):
        whole = texts(matcher, text)
        assert len(whole) >= 3
        assert [c.text for c in ask(matcher, text, limit=2)["completions"]] == whole[:2], text


def test_dsl_chain_over_continuation_lines(matcher):
    cell = ('{\nwnode.new\n    .subscribe(topic="cmd_vel", handler=relay, msgType=Twist)\n'
            '    .publish(topic = "/ct/')
    found = texts(matcher, cell)
    assert found[:2] == ["/ct/mobile_base/commands/velocity", "/ct/turtle1/zz_mine"]  # publications, as global
    assert "/ct/turtle1/pose" in found
    assert texts(matcher, cell[: -len('"/ct/')] + '"/ct/turtle1/zz_mine", msgType="geometry_msgs/Tw') == [
        "geometry_msgs/Twist", "geometry_msgs/TwistStamped"]


def test_dsl_types_services_timers_base(matcher):
    assert texts(matcher, 'x.subscribe("/a", f, "geometry_msgs/Po') == ["geometry_msgs/Pose"]
    assert texts(matcher, 'x.publish("/a", type="std') == ["std_msgs/String"]
    assert texts(matcher, 'anything(msgType="geometry_msgs/Tw') == ["geometry_msgs/Twist", "geometry_msgs/TwistStamped"]
    assert texts(matcher, 'wnode.new.service("reset", srvType="std_srvs/') == ["std_srvs/Empty", "std_srvs/SetBool"]
    assert texts(matcher, 'wnode.new.service("reset", type="std_srvs/S') == ["std_srvs/SetBool"]
    assert texts(matcher, 'wnode.new.service("/ct/re') == ["/ct/reset"]
    assert texts(matcher, 'wnode.remove(timer="') == ["blink", "tick"]
    assert texts(matcher, 'wnode.remove("') == ["/ct/turtle1/zz_mine", "cmd_vel", "mobile_base/commands/velocity", "odom"]
    assert texts(matcher, 'wnode.unsubscribe("') == ["cmd_vel", "odom"]
    assert texts(matcher, 'wnode.baseNode("turtles') == ["turtlesim_node"]  # package from the model
    assert texts(matcher, 'wnode.basePackage("turtle') == ["turtle_tf", "turtlesim"]


def test_not_ours_is_left_to_ipython(matcher, ip):
    for text in ['print("/ct', 'open("/ct/tur', "x = 1", 'f.write("/ct', "%time /ct", "%topics --type",
                 'x.subscribe(callback="/ct', 'x.subscribe(["/ct', 'a = """/ct']:
        result = ask(matcher, text)
        assert result["completions"] == [] and result["suppress"] is False, text
    assert texts(matcher, "topics /ct/tur")  # automagic: the line runs %topics, so it completes as %topics
    ip.automagic = False
    try:
        result = ask(matcher, "topics /ct/tur")  # without automagic it is Python
        assert result["completions"] == [] and result["suppress"] is False
    finally:
        ip.automagic = True


def test_completion_evaluates_nothing(matcher, ip):
    calls = []

    class Sneaky:
        def model(self):
            calls.append("model")
            raise RuntimeError("boom")

    ip.user_ns["make"] = lambda: calls.append("make")
    ip.user_ns["sneaky"] = Sneaky()
    ip.user_ns["items"] = [FakeNode(wrapping_model())]
    # Calls and subscripts in the receiver are never evaluated; no model, so write() is not ours.
    assert ask(matcher, 'make().write("')["suppress"] is False
    assert ask(matcher, 'items[0].write("')["suppress"] is False
    assert calls == []
    # A model() that raises only loses the node's own topics.
    assert texts(matcher, 'sneaky.new.subscribe(topic="/ct/turtle2') == ["/ct/turtle2/cmd_vel"]
    assert calls == ["model"]


def test_master_down_answers_instantly_from_local_data(ip):
    dead = master_graph(f"http://127.0.0.1:{free_port()}/", period=0.05).start()
    try:
        assert dead.wait_first(2) and not dead.snapshot.master_up
        dead.stop()  # the last snapshot stays; TAB must answer from it and the catalog, never the network

        def no_network(timeout):
            raise AssertionError("TAB read the graph")

        dead.source = no_network
        down = RosMatcher(ip, dead, CATALOG)
        assert texts(down, "%topics /ct/tur") == []
        assert texts(down, "%topics /") == []  # not the file system's root
        assert texts(down, 'wnode.write("') == ["/ct/turtle1/zz_mine", "mobile_base/commands/velocity"]
        assert texts(down, "%topics --type geometry_msgs/Tw") == ["geometry_msgs/Twist", "geometry_msgs/TwistStamped"]
    finally:
        dead.stop()


def test_master_gone_completion_offers_the_last_graph_marked_stale(ip, ros_home):
    """A master that goes away mid-session: TAB still offers what it last knew, saying so."""
    import subprocess

    from topic_nodes import stop

    uri = f"http://127.0.0.1:{free_port()}/"
    master = subprocess.Popen(["rosmaster", "--core", "-p", uri.rsplit(":", 1)[1].strip("/"), "-w", "3"],
                              stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    cache = master_graph(uri, period=0.05, timeout=0.3)
    try:
        wait_for(lambda: _registered(uri), timeout=20, what="the master to answer")
        cache.start()
        wait_for(lambda: "/stale/topic" in cache.snapshot.topics, what="the topic in the graph")
        stop(master)
        wait_for(lambda: not cache.snapshot.master_up, what="the master seen down")
        result = ask(RosMatcher(ip, cache, CATALOG), "%topics /stale/")
        assert [c.text for c in result["completions"]] == ["/stale/topic"]
        assert "std_msgs/String (master down; as of " in result["completions"][0].type
        assert cache.snapshot.stale and not cache.snapshot.master_up
    finally:
        cache.stop()
        stop(master)


def _registered(uri: str) -> bool:
    """Register a publisher of /stale/topic with the master at ``uri``; whether it answered."""
    try:
        return one_call(uri).registerPublisher(
            "/stale_node", "/stale/topic", "std_msgs/String", "http://127.0.0.1:9/")[0] == 1
    except OSError:
        return False


def test_string_argument_scanner():
    arg = string_argument('nd.new.subscribe(topic="/a", handler=f)\n  .publish(topic = "/tu')
    assert arg is not None and arg.fragment == "/tu" and arg.keyword == "topic" and arg.index == 0
    assert arg.chain == ("nd", "new", "subscribe", "publish") and not arg.root_called
    arg = string_argument('rosNode("x").new.publish("/a", "geo')
    assert arg.chain == ("rosNode", "new", "publish") and arg.root_called and arg.index == 1
    assert string_argument('s = "a(b" # "(\nf(x, "q').fragment == "q"  # strings and comments skipped
    assert string_argument('f("done")') is None
    assert string_argument('f(g("a") + "b') is None


def test_default_catalog_scans_this_machine():
    catalog = default_catalog()
    assert "geometry_msgs/Twist" in catalog.message_types()
    assert "std_srvs/Empty" in catalog.service_types()
    assert "topic_tools" in catalog.packages()
    assert "relay" in catalog.executables("topic_tools")
    assert catalog.message_types() is catalog.message_types()  # scanned once


# -- tier 2: through IPython's completer ------------------------------------------------
def complete(ip, text: str):
    """What the terminal would offer: IPython's completions less empty texts (it skips those)."""
    with provisionalcompleter(), warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return [c for c in ip.Completer.completions(text, len(text)) if c.text]


def test_through_the_shell(ip, graph):
    handle = install(ip, graph, CATALOG)
    try:
        found = complete(ip, "%topics /ct/tur")
        assert [c.text for c in found] == [
            "/ct/turtle1/cmd_vel", "/ct/turtle1/color_sensor", "/ct/turtle1/pose", "/ct/turtle2/cmd_vel"]
        assert {c.start for c in found} == {len("%topics ")}
        # Jedi and the file matcher are suppressed; our order (own topics first) is kept.
        text = 'wnode.write("/ct/turtle1/'
        found = complete(ip, text)
        assert [c.text for c in found] == ["/ct/turtle1/zz_mine", "/ct/turtle1/cmd_vel", "/ct/turtle1/color_sensor",
                                           "/ct/turtle1/pose"]
        assert {c.start for c in found} == {text.index('"') + 1}
        assert [c.text for c in complete(ip, 'x.subscribe(topic="/ct/turtle2')] == ["/ct/turtle2/cmd_vel"]
        assert [c.text for c in complete(ip, "%topics --type=geometry_msgs/Tw")] == [
            "geometry_msgs/Twist", "geometry_msgs/TwistStamped"]
        assert [c.text for c in complete(ip, "%wrap turtlesim turtle")] == ["turtle_teleop_key", "turtlesim_node"]
        assert [c.text for c in complete(ip, "%handler w")] == ["wnode"]
        # After %pub TOPIC: the type the live topic carries first, as the terminal's menu gets them.
        assert [c.text for c in complete(ip, "%pub /ct/turtle1/pose ")][:2] == ["geometry_msgs/Pose2D",
                                                                                "geometry_msgs/Pose"]
        # %try's candidate: the user's functions, not IPython's %clear.
        ip.user_ns.update(clamp=lambda m: m, closer=lambda m: m, cl_not_a_function=3)
        assert [c.text for c in complete(ip, "%try wnode /ct/cmd_vel cl")] == ["clamp", "closer"]
        found = complete(ip, "%pub /ct/odom std_msgs/String ")  # a template, inserted at the cursor
        assert [(c.text, c.start) for c in found] == [("{data: ''}", len("%pub /ct/odom std_msgs/String "))]
        # Ours but nothing matches: no file names crowd in (the file matcher would list /ct...).
        assert complete(ip, "%topics /ct/nothing") == []
        assert complete(ip, 'x.subscribe(topic="/') != [] and all(c.text.startswith("/") and c.text != "/usr/"
                                                                   for c in complete(ip, 'x.subscribe(topic="/'))
        # Ordinary Python completion still works.
        assert "not_a_node" in [c.text for c in complete(ip, "not_a")]
    finally:
        uninstall(ip, handle)
    assert not any(getattr(m, "matcher_identifier", None) == IDENTIFIER for m in ip.Completer.custom_matchers)
    assert "wnode" not in [c.text for c in complete(ip, "%handler w")]  # no longer ours
    uninstall(ip, handle)  # harmless twice


def test_completion_is_fast_through_the_shell(ip, graph):
    handle = install(ip, graph, CATALOG)
    try:
        complete(ip, "%topics /ct/")  # warm-up
        started = time.perf_counter()
        for _ in range(20):
            complete(ip, 'wnode.new.subscribe(topic="/ct/tur')
        assert (time.perf_counter() - started) / 20 < 0.05
    finally:
        uninstall(ip, handle)
