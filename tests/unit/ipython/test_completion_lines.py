"""What TAB completes, read from the line alone: magic arguments and the string arguments of DSL calls."""

from __future__ import annotations

import pytest

from ipyros.core.model import NodeModel, TopicModel
from ipyros.ipython import completion, magics
from ipyros.ipython.arguments import (
    DSL_NODE,
    EXECUTABLE,
    FIELD,
    MSG_PATH,
    MSG_TEMPLATE,
    MSG_TYPE,
    NODE,
    OWN_TOPIC,
    PACKAGE,
    SERVICE,
    SRV_TYPE,
    TOPIC,
    argument,
    grammar_of,
)
from ipyros.ipython.completion import call_want, magic_want, string_argument


class Declared:
    """Something in the user's namespace with a model(): what the completer takes for a DSL node."""

    def __init__(self, model: NodeModel) -> None:
        self._model = model

    def model(self) -> NodeModel:
        return self._model


def line_magics() -> dict:
    """Every line magic of ipyros by name, as the shell's magics manager has them (unbound here)."""
    found = {}
    for name in magics.__all__:
        cls = getattr(magics, name)
        found.update({magic: getattr(cls, method) for magic, method in cls.magics["line"].items()})
    return found


LINE_MAGICS = line_magics()
NODE_MODEL = NodeModel("nd", topics=[TopicModel("/turtle1/cmd_vel", "/turtle1/cmd_vel", "publish", "g/Twist")])
USER_NS = {"nd": Declared(NODE_MODEL), "f": open}


@pytest.mark.parametrize("line, kind, fragment", [
    ("%topics /tur", TOPIC, "/tur"),
    ("%topics --type geometry_msgs/Tw", MSG_TYPE, "geometry_msgs/Tw"),
    ("%topics --node /tu", NODE, "/tu"),
    ("%echo ", MSG_PATH, ""),
    ("%echo /odom.pose.", MSG_PATH, "/odom.pose."),
    ("%plot /odom lin", FIELD, "lin"),
    ("%plot /odom.twist.x /odom.po", FIELD, "/odom.po"),
    ("%pub /t ", MSG_TYPE, ""),
    ("%pub /t std_msgs/String ", MSG_TEMPLATE, ""),
    ("%pub -r 5 /t std_msgs/Str", MSG_TYPE, "std_msgs/Str"),
    ("%handler ", DSL_NODE, ""),
    ("%handler nd /t", OWN_TOPIC, "/t"),
    ("%wrap topic_tools r", EXECUTABLE, "r"),
    ("%wrap top", PACKAGE, "top"),
    ("%call /reset ", SRV_TYPE, ""),
    ("%call ", SERVICE, ""),
    ("%hz /a /b /c", TOPIC, "/c"),
    ("%plot /tu", MSG_PATH, "/tu"),  # the magics whose own parsers say so: no second table to forget them in
    ("%record out.bag /tu", TOPIC, "/tu"),
    ("%record out.bag /a /b", TOPIC, "/b"),
    ("%echo -n 3 /tu", MSG_PATH, "/tu"),
    ("%topics -n /tu", NODE, "/tu"),
    ("%topics --node=/tu", NODE, "/tu"),
    ("%try nd /t ", "function", ""),
    ("%demo ", "demo robot", ""),
    ("%wrap topic_tools relay in:=/tu", TOPIC, "/tu"),
])
def test_magic_lines(line, kind, fragment):
    want = magic_want(line, USER_NS, LINE_MAGICS)
    assert want is not None and (want.kind, want.fragment) == (kind, fragment)


@pytest.mark.parametrize("line", [
    "%pub /t std_msgs/String {data: 1} ",  # the template is the message's first word only
    "%echo /t --field ",  # a value not completed
    "%revert nd /t ",  # a version number
    "%save_nodes ",  # a path: IPython's own file completion
])
def test_words_not_completed_are_left_to_ipython(line):
    assert magic_want(line, USER_NS, LINE_MAGICS) is None


def test_a_magic_typed_without_percent_counts_only_when_automagic_would_run_it():
    assert magic_want("topics /t", USER_NS, LINE_MAGICS, automagic=False) is None
    assert magic_want("topics /t", USER_NS, LINE_MAGICS).kind == TOPIC
    assert magic_want("topics /t", {"topics": 1}, LINE_MAGICS) is None


def test_a_node_is_known_for_its_own_topics():
    want = magic_want("%handler nd ", USER_NS, LINE_MAGICS)
    assert want.model is NODE_MODEL and want.direction == "subscribe"


def test_not_ours():
    assert magic_want("%timeit x", USER_NS, {**LINE_MAGICS, "timeit": lambda line: None}) is None
    assert magic_want("x = 1", USER_NS, LINE_MAGICS) is None


def test_the_grammar_is_the_parsers_own():
    """A magic declared with complete= completes by it; one without completes nothing."""
    from IPython.core.magic_arguments import magic_arguments

    @magic_arguments()
    @argument("name", complete=NODE)
    @argument("values", nargs="*")
    @argument("-t", "--type", complete=MSG_TYPE)
    @argument("--flag", action="store_true")
    def sample(line):
        """A sample magic."""

    grammar = grammar_of(sample)
    assert [w.kind for w in grammar.positional] == [NODE, None]
    assert grammar.options["--flag"] is None and grammar.options["-t"].kind == MSG_TYPE
    assert magic_want("%sample --flag -t std", USER_NS, {"sample": sample}).kind == MSG_TYPE
    assert magic_want("%sample --flag /tu", USER_NS, {"sample": sample}).kind == NODE

    @magic_arguments()
    @argument("path")
    def plain(line):
        """Nothing completed."""

    assert grammar_of(plain) is None and magic_want("%plain x", USER_NS, {"plain": plain}) is None


@pytest.mark.parametrize("source, fragment, keyword, index, chain, called", [
    ('nd.new.subscribe(topic="/tur', "/tur", "topic", 0, ("nd", "new", "subscribe"), False),
    ("nd.new.publish('/a', msgType='geometry_msgs/Tw", "geometry_msgs/Tw", "msgType", 1, ("nd", "new", "publish"), False),
    ('nd.write("', "", None, 0, ("nd", "write"), False),
    ('(nd.new\n   .subscribe("/x", h, Pose)\n   .publish(topic="/cm', "/cm", "topic", 0,
     ("nd", "new", "subscribe", "publish"), False),
    ('rosNode("x").new.subscribe("/a', "/a", None, 0, ("rosNode", "new", "subscribe"), True),
])
def test_string_arguments(source, fragment, keyword, index, chain, called):
    arg = string_argument(source)
    assert arg == completion.StringArgument(fragment, keyword, index, chain, called)


@pytest.mark.parametrize("source", ['x = "/tur', 'nd.write("a" + "b', '"""nd.write("', 'f(x) # nd.write("'])
def test_strings_that_are_not_arguments(source):
    assert string_argument(source) is None


def test_what_a_call_argument_completes():
    assert call_want(string_argument('nd.new.subscribe(topic="/t'), USER_NS).kind == TOPIC
    assert call_want(string_argument('nd.write("'), USER_NS).model is NODE_MODEL
    assert call_want(string_argument('f.write("'), USER_NS) is None  # a file's write is not ours
    assert call_want(string_argument('x.anything(msgType="std'), USER_NS).kind == MSG_TYPE
    assert call_want(string_argument('nd.service("/s", "'), USER_NS).kind == SRV_TYPE


class Graph:
    def __init__(self, topics: dict) -> None:
        from ipyros.core.graph import GraphSnapshot

        self.snapshot = GraphSnapshot(topics=topics)


@pytest.mark.parametrize("line, offered", [
    ("%echo /sample.poi", [("/sample.points", "unit_msgs/Vector3[]")]),
    ("%echo /sample.points[:]{x>0}.", [("/sample.points[:]{x>0}." + f, "float64") for f in "xyz"]),
    ("%echo /sample.points.", []),  # an array: an index or a slice first
    ("%echo /sample.label.", []),  # a string has no fields
    ("%echo /unknown.a", []),  # a topic the graph does not know: no type to read
    ("%plot /sample points[0].", [("points[0]." + f, "float64") for f in "xyz"]),
    ("%plot /sample.count /sample.ga", [("/sample.gains", "float64[]")]),
])
def test_tab_completes_the_fields_of_a_path_from_the_topics_type(line, offered):
    want = magic_want(line, USER_NS, LINE_MAGICS)
    answerer = completion.Answerer(Graph({"/sample": "unit_msgs/Sample"}), None)
    assert [(c.text, c.type) for c in answerer.completions(want, USER_NS)] == offered
