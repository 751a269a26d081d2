"""The bad inputs a hostile afternoon found: each gets one line, and nothing is half-done."""

from __future__ import annotations

import pytest
import rospy
from geometry_msgs.msg import Twist
from peer import Peer
from ros1_fixtures import master_state, wait_for
from std_msgs.msg import Empty, String
from std_srvs.srv import SetBool, SetBoolResponse

from ipyros.core import errors


def one_line(error: BaseException) -> str:
    text = str(error)
    assert "\n" not in text, text
    return text


@pytest.mark.parametrize("value, message", [
    (object(), "is a object: the ROS parameter server holds bool, int, float, str"),
    (None, "the ROS parameter server has no null; to remove the parameter use del nd.params"),
    (2**70, "does not fit the 32-bit integer the ROS parameter server holds; pass it as a float"),
    ({1: "a"}, "has key 1: the parameter server takes string keys only"),
    ([1, {"a": object()}], "[1]/a = <object"),
])
def test_params_of_types_the_parameter_server_cannot_hold(make_node, ros_master, value, message):
    nd = make_node("bad_params")
    with pytest.raises(errors.DeclarationError) as before_create:
        nd.params["gain"] = value
    assert message in one_line(before_create.value)
    nd.create()
    with pytest.raises(errors.DeclarationError) as live:
        nd.params["gain"] = value
    assert message in one_line(live.value)
    assert "gain" not in nd.params
    nd.params["gain"] = [1, 2.5, "x", {"k": True}]  # what it holds is fine
    assert rospy.get_param("/bad_params/gain") == [1, 2.5, "x", {"k": True}]
    del nd.params["gain"]


@pytest.mark.parametrize("options, message", [
    (dict(remaps="notadict"), "baseNode(remaps='notadict'): give a dict of names"),
    (dict(remaps={"a": 1}), "give a dict of names"),
    (dict(args="notalist"), "baseNode(args='notalist'): give a list of strings"),
    (dict(args=[1, 2]), "give a list of strings"),
    (dict(params=[1]), "baseNode(params=[1]): give a dict of private parameters"),
    (dict(params={"rate": object()}), "parameter ~rate = <object"),
    (dict(params={"big": 2**40}), "does not fit the 32-bit integer"),
    (dict(namespace="my robot"), "invalid namespace 'my robot'"),
])
def test_basenode_options_of_the_wrong_shape(make_node, options, message):
    nd = make_node("bad_base")
    with pytest.raises(errors.DeclarationError) as caught:
        nd.baseNode("talker", **options)
    assert message in one_line(caught.value)
    assert nd.model().base is None


def test_namespaces_with_spaces_or_of_the_wrong_type(ros_session):
    from ipyros import rosNode

    for namespace, message in (("my robot", "invalid namespace 'my robot'"), (3, "namespace 3 is a int, not a string"),
                               ("/a/~b", "invalid namespace")):
        with pytest.raises(errors.TopicNameError) as caught:
            rosNode("bad_ns", namespace=namespace, session=ros_session)
        assert message in one_line(caught.value)
    assert rosNode("good_ns", namespace="robot1", session=ros_session).fullname == "/robot1/good_ns"


def test_a_name_that_is_not_a_string(make_node):
    with pytest.raises(errors.TopicNameError) as caught:
        make_node("bad_name").new.publish(123, msgType=Twist)
    assert "topic name 123 is a int, not a string" in one_line(caught.value)


def test_async_and_generator_handlers_are_refused(make_node):
    nd = make_node("bad_async")

    async def on_msg(msg):
        pass

    def each(msg):
        yield msg

    with pytest.raises(errors.HandlerError) as caught:
        nd.new.subscribe("/bad_async", handler=on_msg, msgType=String)
    assert "handler on_msg for bad_async /bad_async is an async def" in one_line(caught.value)
    with pytest.raises(errors.HandlerError, match="is a generator"):
        nd.timer(1.0, each)
    with pytest.raises(errors.HandlerError, match="async def"):
        nd.new.service("/bad_async_srv", SetBool, handler=on_msg)
    assert nd.model().topics == [] and nd.model().timers == [] and nd.model().services == []


@pytest.mark.parametrize("period", [1e-12, 0, -1, float("inf"), float("nan"), "1", True])
def test_timer_periods_out_of_range(make_node, period):
    nd = make_node("bad_timer").create()
    with pytest.raises(errors.DeclarationError) as caught:
        nd.timer(period, lambda: None, name="t")
    assert "timer period must be a number of seconds from 0.0001 (10 kHz) up" in one_line(caught.value)
    assert nd.model().timers == []


def test_reuse_on_a_running_node_without_a_basenode(make_node):
    nd = make_node("bad_reuse").create()
    for declare in (lambda: nd.reuse.publish("/bad_reuse/x", msgType=Twist),
                    lambda: nd.reuse.subscribe("/bad_reuse/y", msgType=Twist)):
        with pytest.raises(errors.DeclarationError) as caught:
            declare()
        assert "bad_reuse reuses" in one_line(caught.value) and "but has no basenode" in str(caught.value)
    assert nd.model().topics == []


@pytest.mark.parametrize("call, spec, message", [
    ("subscribe", "std_srvs/Empty", "'std_srvs/Empty' is a service type, not a message type"),
    ("service", "std_msgs/Empty", "'std_msgs/Empty' is a message type, not a service type"),
])
def test_a_service_type_where_a_message_type_goes_and_back(make_node, call, spec, message):
    nd = make_node("bad_kind")
    with pytest.raises(errors.MessageTypeError) as caught:
        if call == "subscribe":
            nd.new.subscribe("/bad_kind", handler=print, msgType=spec)
        else:
            nd.new.service("/bad_kind", spec, handler=print)
    assert message in one_line(caught.value)


def test_a_service_handler_answering_the_wrong_type(make_node, failures):
    answers = {"value": "yes"}
    nd = make_node("bad_answer")
    nd.new.service("/bad_answer/set", SetBool, handler=lambda request: answers["value"]).create()
    rospy.wait_for_service("/bad_answer/set", timeout=10)
    call = rospy.ServiceProxy("/bad_answer/set", SetBool)
    with pytest.raises(rospy.ServiceException, match="returned 'yes', which is not a SetBoolResponse"):
        call(True)
    assert len(failures) == 1
    assert "the handler of service /bad_answer/set returned 'yes', which is not a SetBoolResponse" in str(
        failures[0].error)
    answers["value"] = SetBoolResponse(success="surely")  # the right class, a field of the wrong type
    with pytest.raises(rospy.ServiceException, match="which is not a SetBoolResponse"):
        call(True)
    answers["value"] = SetBoolResponse(success=True, message="done")
    assert call(True).message == "done"  # and the service still serves
    assert nd.status().row("/bad_answer/set").errors == 2


def test_a_later_node_cannot_take_a_live_external_nodes_name(make_node, ros_master):
    with Peer("publish_type.py", "/bad_taken", "std_msgs/Empty") as peer:
        peer.wait_line("ready")
        external = wait_for(lambda: master_state(ros_master)["pub"].get("/bad_taken"), what="the peer")[0]
        make_node("bad_first").create()  # the process node is there already (the test session's)
        namespace, name = external.rsplit("/", 1)
        taker = make_node(name, namespace=namespace or "/")
        with pytest.raises(errors.NodeStateError) as caught:
            taker.new.publish("/bad_taken_too", msgType=Empty).create()
        assert f"a node named {external} is already running; give this node another name" in one_line(caught.value)
        assert not taker.created
        assert "/bad_taken_too" not in master_state(ros_master)["pub"]
        peer.proc.stdin.write("\n")  # the peer is still fine
        assert peer.proc.poll() is None


def test_a_chain_shows_everything_it_declared(make_node):
    nd = make_node("long_chain")
    chain = nd.new
    for i in range(6):
        chain = chain.publish(f"/long_chain/t{i}", msgType=Empty)
    shown = repr(chain)
    assert all(f"publish /long_chain/t{i} [std_msgs/Empty]" in shown for i in range(6)), shown
