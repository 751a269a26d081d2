"""The seam between a backend and the session (core/sessionlink.py): after a ROS 1 master restart, the basenodes that
did not register again are restarted or reported, each in one line, from what the session says is running."""

from __future__ import annotations

from ipyros.core.sessionlink import RunningBase, restart_unregistered


def bases(restarted: list[str]) -> list[RunningBase]:
    return [RunningBase(name, node, called, lambda name=name: restarted.append(name))
            for name, node, called in (("/move_base", "nav", "nd"), ("/laser", "scan", "sc"))]


def test_a_basenode_not_registered_again_is_reported_with_the_line_that_restarts_it():
    restarted: list[str] = []
    said = restart_unregistered(bases(restarted), lambda name: name == "/laser", restart=False)
    assert said == ["ipyros: basenode /move_base of nav did not register with the restarted master (ROS 1 nodes do "
                    "not); restart it: nd.base.restart()"]
    assert restarted == []


def test_with_restart_basenodes_each_one_not_registered_is_restarted_and_said_so():
    restarted: list[str] = []
    said = restart_unregistered(bases(restarted), lambda name: False, restart=True)
    assert restarted == ["/move_base", "/laser"]
    assert said[1] == "ipyros: basenode /laser of scan did not register with the restarted master; restarted it"


def test_a_basenode_that_cannot_be_restarted_is_said_and_the_others_are_still_restarted():
    restarted: list[str] = []
    failing = RunningBase("/move_base", "nav", "nd", lambda: 1 / 0)
    said = restart_unregistered([failing, *bases(restarted)[1:]], lambda name: False, restart=True)
    assert said[0].startswith("ipyros: basenode /move_base of nav did not register with the restarted master and "
                              "could not be restarted (division by zero); restart it: nd.base.restart()")
    assert restarted == ["/laser"]
