"""A thread's printing to a sink of its own while every other thread prints as usual (:mod:`ipyros.core.streams`)."""

from __future__ import annotations

import contextlib
import io
import sys
import threading

import pytest

from ipyros.core import streams


@pytest.fixture
def routed():
    """A StringIO routed as sys.stdout in the test's body (pytest puts its own streams back between a test's
    phases, so a fixture's sys.stdout would not last into the body): ``with routed as out:``."""

    @contextlib.contextmanager
    def around():
        saved = sys.stdout, sys.stderr
        sys.stdout, sys.stderr = io.StringIO(), io.StringIO()
        out = sys.stdout
        streams.route()
        try:
            yield out
        finally:
            streams.unroute()
            sys.stdout, sys.stderr = saved

    return around()


def test_a_threads_text_goes_to_its_sink_and_the_others_text_where_it_went(routed):
    kept = io.StringIO()
    with routed as out:
        with streams.into(kept):
            print("mine")
            other = threading.Thread(target=print, args=("theirs",))
            other.start()
            other.join()
        print("after")
    assert kept.getvalue() == "mine\n" and out.getvalue() == "theirs\nafter\n"


def test_route_is_once_and_unroute_gives_the_stream_back(routed):
    with routed as out:
        first = sys.stdout
        streams.route()
        assert sys.stdout is first and streams.routed()
        streams.unroute()
        assert sys.stdout is out and not streams.routed()


def test_sinks_nest_and_enter_leave_restore_the_one_before(routed):
    outer, inner = io.StringIO(), io.StringIO()
    with routed as out:
        previous = streams.enter(outer)
        print("a")
        with streams.into(inner):
            print("b")
        print("c")
        streams.leave(previous)
        print("d")
    assert (outer.getvalue(), inner.getvalue(), out.getvalue()) == ("a\nc\n", "b\n", "d\n")


def test_the_routed_stream_is_the_original_in_everything_else(routed):
    with routed as out:
        assert sys.stdout.getvalue == out.getvalue  # an attribute of the StringIO behind it
        assert not sys.stdout.isatty()
