"""Jupyter widgets: ``%pub --widget`` is a form that publishes as its sliders move or at a rate (the form itself,
on either ROS, without a browser: a control's value set as a slider sets it); in a terminal it says widgets need
Jupyter. The magic in a real kernel: tests/ros1/test_kernel.py."""

from __future__ import annotations

import time

import pytest
from geometry_msgs.msg import Twist
from shell import error_of
from support import wait_for

pytest.importorskip("ipywidgets", reason="the test extra installs ipywidgets")

from ipyros.ipython.widgets import PublisherForm  # noqa: E402


def test_pub_widget_in_a_terminal_says_widgets_need_jupyter(ip):
    error = str(error_of(ip, "%pub --widget /wg/cmd geometry_msgs/Twist"))
    assert error.startswith("widgets need Jupyter: %pub --widget draws a form in a notebook; here give the message")


def test_a_publisher_form_publishes_as_its_controls_move_and_at_a_rate(make_node):
    heard: list = []
    make_node("wg_ear").new.subscribe("/wg/cmd", heard.append, msgType=Twist).create()
    pub = make_node("wg_pub").new.publish("/wg/cmd", msgType=Twist).create()
    form = PublisherForm("/wg/cmd", Twist, lambda msg: pub.write("/wg/cmd", msg))
    assert list(form.fields)[:3] == ["linear.x", "linear.y", "linear.z"]
    assert (form.fields["linear.x"].min, form.fields["linear.x"].max) == (-10.0, 10.0)
    form.rate.value = 20.0
    form.fields["linear.x"].value = 0.7  # at a rate: the next tick sends it
    form.play.value = True
    wait_for(lambda: any(m.linear.x == 0.7 for m in heard), timeout=30, what="the form's message, at its rate")
    form.play.value = False
    time.sleep(0.2)  # what was on its way arrives
    count = len(heard)
    time.sleep(0.3)
    assert len(heard) == count, "still publishing after the play button was released"
    form.fields["angular.z"].value = -0.3  # moved: sent once, at once
    wait_for(lambda: len(heard) > count, what="the message after the slider moved")
    assert (heard[-1].linear.x, heard[-1].angular.z) == (0.7, -0.3) and len(heard) == count + 1
    assert form.status.value == f"/wg/cmd: {form.sent} sent"
    form.close()


def test_params_widget_in_a_terminal_says_widgets_need_jupyter(ip):
    error = str(error_of(ip, "%params /wg --widget"))
    assert error.startswith("widgets need Jupyter: %params --widget draws sliders in a notebook; here set one with")


def test_a_params_form_sets_each_parameter_as_its_control_moves(make_node, session):
    from ipyros.ipython.widgets import ParamsForm

    nd = make_node("wg_params")
    nd.params["gain"] = 0.5
    nd.params["count"] = 3
    nd.params["label"] = "slow"
    nd.create()
    backend = session.backend
    ours = {f"{nd.fullname}/{key}" for key in ("gain", "count", "label")}
    wait_for(lambda: ours <= set(backend.params_under(nd.fullname)), timeout=20, what="the node's parameters")
    form = ParamsForm({k: v for k, v in backend.params_under(nd.fullname).items() if k in ours},
                      backend.describe_param, backend.write_param)
    gain, count, label = (form.fields[f"{nd.fullname}/{key}"] for key in ("gain", "count", "label"))
    assert (gain.min, gain.max, count.min, count.max) == (-10.0, 10.0, 0, 100)
    gain.value = 1.5
    count.value = 7
    label.value = "fast"
    wait_for(lambda: backend.read_param(f"{nd.fullname}/gain") == 1.5 and
             backend.read_param(f"{nd.fullname}/count") == 7 and backend.read_param(f"{nd.fullname}/label") == "fast",
             what="the parameters set as their controls moved")
    assert form.status.value == f"{nd.fullname}/label = 'fast'"
    form.close()


def test_bag_widget_in_a_terminal_says_widgets_need_jupyter(ip):
    error = str(error_of(ip, "%bag widget nd"))
    assert error.startswith("widgets need Jupyter: %bag widget draws the player's controls in a notebook")


def test_a_form_on_a_guarded_topic_spans_the_guards_limits_so_what_it_shows_passes(make_node):
    """%pub --widget on a topic a node of the session guards: the form publishes through that node (and its guard),
    and the guarded fields' sliders span the guard's limits, so that no slider shows what the robot will not get."""
    from ipyros.dsl import engine_of
    from ipyros.tools.probe import PromptPublisher

    heard: list = []
    make_node("wg_robot").new.subscribe("/wg/guarded", heard.append, msgType=Twist).create()
    nd = make_node("wg_guarded")
    nd.new.publish("/wg/guarded", msgType=Twist)
    nd.guard("/wg/guarded", limits={"linear.x": (-0.5, 0.5)})
    nd.create()
    publisher = PromptPublisher()
    assert publisher.guard("/wg/other", "geometry_msgs/Twist") is None
    owner, guard = publisher.guard("/wg/guarded", "geometry_msgs/Twist")
    assert owner == nd.name and guard.limits == {"linear.x": [-0.5, 0.5]}
    form = PublisherForm("/wg/guarded", Twist, lambda msg: publisher.publish("/wg/guarded", "geometry_msgs/Twist", msg),
                         None, (owner, guard.limits))
    assert (form.fields["linear.x"].min, form.fields["linear.x"].max) == (-0.5, 0.5)
    assert (form.fields["angular.z"].min, form.fields["angular.z"].max) == (-10.0, 10.0)
    assert "through the guard of wg_guarded" in form.widget.children[0].value
    wait_for(lambda: any(sent.topic == "/wg/guarded" and sent.connections for sent in engine_of(nd).sent()),
             timeout=30, what="the subscriber connected")
    form.fields["linear.x"].value = 2.0  # beyond the slider: it stops at the limit, and so does what is sent
    assert form.fields["linear.x"].value == 0.5
    wait_for(lambda: heard and heard[-1].linear.x == 0.5, timeout=30, what="the slider's value at the subscriber")
    form.close()
