"""An agent's requests wait for the person: told once, made only when approved, answered once."""

from __future__ import annotations

import threading

import pytest

from ipyros.mcp.approvals import NoSuchRequest, Requests


def test_a_request_is_told_and_made_only_when_approved():
    told, made = [], []
    requests = Requests(told.append)
    request = requests.ask("swap", "make h the handler", "a diff", lambda: made.append(1) or "done")
    assert request.number == 1 and request.state == "pending" and not made
    assert "the agent asks (#1): make h the handler\na diff" in told[0] and "%mcp approve 1" in told[0]
    assert requests.approve(1).answer == "done" and made == [1]
    with pytest.raises(NoSuchRequest, match="it was approved already"):
        requests.approve(1)
    with pytest.raises(NoSuchRequest, match="no such request"):
        requests.deny(7)


def test_a_denied_request_is_never_made_and_a_failing_one_says_why():
    made = []
    requests = Requests(lambda text: None)
    requests.ask("publish", "publish", "", lambda: made.append(1) or "sent")
    assert requests.deny(1).state == "denied" and not made

    def fails() -> str:
        raise ValueError("no such field 'linar'")

    requests.ask("call", "call", "", fails)
    answered = requests.approve(2)
    assert (answered.state, answered.answer) == ("failed", "ValueError: no such field 'linar'")
    assert requests.pending() == []


def test_two_answers_at_once_make_a_change_once():
    made = []
    requests = Requests(lambda text: None)
    requests.ask("swap", "swap", "", lambda: made.append(1) or "done")
    barrier = threading.Barrier(8)

    def answer() -> None:
        barrier.wait()
        try:
            requests.approve(1)
        except NoSuchRequest:
            pass

    threads = [threading.Thread(target=answer) for _ in range(8)]
    for thread in threads:
        thread.start()
    for thread in threads:
        thread.join()
    assert made == [1]


def test_stopping_denies_what_is_pending():
    requests = Requests(lambda text: None)
    for _ in range(3):
        requests.ask("publish", "publish", "", lambda: "sent")
    requests.approve(2)
    assert requests.deny_all("the server stopped") == 2
    assert [r.state for r in requests.latest()] == ["denied", "approved", "denied"]
