"""ipyros.node.basestart's pure parts: the hint given when a basenode never shows up in the graph."""
from ipyros.node.basestart import names_like


def test_names_like_a_missing_basenode_are_typos_namespaces_and_suffixes():
    seen = ["/absent_bsae", "/robot/absent_base", "/absent_base_1", "/set_param_peer", "/rosout"]
    assert set(names_like("/absent_base", seen)) == {"/absent_bsae", "/robot/absent_base", "/absent_base_1"}


def test_names_that_merely_share_letters_are_no_hint():
    assert names_like("/absent_base", ["/set_param_peer", "/talker", "/turtlesim"]) == []
