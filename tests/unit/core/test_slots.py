"""Handler slots: the one door into user code (:mod:`ipyros.core.slots`). A swap is atomic, a handler's exception
is a report and never a dead callback, its figures are counted."""

from __future__ import annotations

import threading

import pytest

from ipyros.core import slots
from ipyros.core.errors import HandlerError


def reports():
    got: list[slots.HandlerFailure] = []
    return got, got.append


def test_the_slot_calls_whatever_handler_it_holds_now():
    seen = []
    slot = slots.HandlerSlot("n /x", lambda m: seen.append(("old", m)), lambda f: None)
    slot(1)
    slot.swap(lambda m: seen.append(("new", m)))
    slot(2)
    assert seen == [("old", 1), ("new", 2)] and slot.figures().calls == 2


def test_a_handler_without_an_argument_and_what_it_returns():
    slot = slots.HandlerSlot("n t", lambda: 42, lambda f: None, pass_argument=False)
    assert slot.run(None) == (True, 42)


@pytest.mark.parametrize("error", [ValueError("bad"), SystemExit(3), KeyboardInterrupt(), GeneratorExit()])
def test_every_exception_of_a_handler_is_reported_with_its_own_traceback_never_raised(error):
    got, report = reports()

    def handler(msg):
        raise error

    slot = slots.HandlerSlot("n /x", handler, report)
    worker = threading.Thread(target=lambda: slot.run("m"))  # off the main thread: Ctrl-C there is the user's
    worker.start()
    worker.join()
    assert len(got) == 1 and got[0].error is error and got[0].handler == "handler" and got[0].label == "n /x"
    assert "in handler" in got[0].traceback and "core/slots.py" not in got[0].traceback  # its own, not ours
    assert slot.figures().errors == 1


def test_ctrl_c_at_the_prompt_while_a_handler_is_tried_there_is_the_users():
    slot = slots.HandlerSlot("n /x", lambda m: (_ for _ in ()).throw(KeyboardInterrupt()), lambda f: None)
    with pytest.raises(KeyboardInterrupt):
        slot.run("m")


def test_reports_of_one_slot_are_at_most_one_per_interval_and_the_rest_counted():
    got, report = reports()
    slot = slots.HandlerSlot("n /x", lambda m: 1 / 0, report, report_interval=60.0)
    for _ in range(5):
        slot.run("m")
    assert len(got) == 1 and slot.figures().errors == 5
    slot._last_report = -1e9  # the interval has passed
    slot.run("m")
    assert len(got) == 2 and got[1].suppressed == 4


def test_a_closing_slot_fails_silently():
    got, report = reports()
    slot = slots.HandlerSlot("n /x", lambda m: 1 / 0, report)
    slot.closing = True
    slot.run("m")
    assert got == [], "a closing slot says nothing"


def test_recent_messages_are_kept_as_they_arrived():
    slot = slots.HandlerSlot("n /x", lambda m: m.append("changed"), lambda f: None, keep=2)
    for i in range(3):
        slot.run([i], pristine=slots.Pristine(lambda i=i: [i]))
    assert slot.recent_messages() == [[1], [2]]


def test_the_arrival_is_told_to_the_handler_it_came_with():
    seen = []
    came = slots.Arrival("talker", 12, False)
    slot = slots.HandlerSlot("n /x", lambda m: seen.append(slots.arrival()), lambda f: None)
    slot.run("m", came=came)
    assert seen == [came]


def test_an_action_handler_gets_the_goal_and_the_call_as_it_takes_them():
    seen = []
    two = slots.HandlerSlot("n a", lambda goal, call: seen.append((goal, call)), lambda f: None, pass_argument=2)
    one = slots.HandlerSlot("n a", lambda goal: seen.append(goal), lambda f: None, pass_argument=1)
    two.run(slots.GoalArguments(("g", "c")))
    one.run(slots.GoalArguments(("g", "c")))
    assert seen == [("g", "c"), "g"]


def test_a_wrong_answer_found_later_is_reported_without_a_traceback():
    got, report = reports()
    slot = slots.HandlerSlot("n s", lambda r: None, report)
    slot.fail(ValueError("returned None, not a SetBool.Response"))
    assert got[0].traceback == "returned None, not a SetBool.Response\n"


def test_figures_of_a_quiet_slot():
    figures = slots.HandlerSlot("n /x", print, lambda f: None).figures()
    assert (figures.calls, figures.errors, figures.rate_hz, figures.mean_ms) == (0, 0, 0.0, 0.0)


@pytest.mark.parametrize("handler, what, takes", [
    (lambda m: None, "subscribe", True),
    (lambda: None, "timer", False),
    (lambda event=None: None, "timer", True),
    (lambda goal, call: None, "action", 2),
    (lambda goal: None, "action", True),
    (print, "subscribe", True),
])
def test_call_arity_says_what_a_handler_takes(handler, what, takes):
    assert slots.call_arity(handler, what, "n /x") == takes


def gen(msg):
    yield msg


async def coro(msg):
    return msg


@pytest.mark.parametrize("handler, says", [
    (3, "handler for n /x is int 3, not a function; pass the function itself"),
    (lambda: None, "must take one argument, the message"),
    (lambda a, b: None, "must take one argument, the message"),
    (gen, "is a generator (it yields)"),
    (coro, "is an async def"),
])
def test_a_handler_ros_cannot_call_is_refused_in_one_line(handler, says):
    with pytest.raises(HandlerError) as caught:
        slots.call_arity(handler, "subscribe", "n /x")
    assert says in str(caught.value) and "\n" not in str(caught.value)
