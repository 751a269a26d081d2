"""Files and names from elsewhere run nothing: a model file is data, and every name is checked where it enters.

A model file travels like data (an attachment, a repository): loading one starts no
process and runs no code unless asked (``trust=True``, ``%load_nodes --trust``), and the
refusal says what would run. A name given to the DSL (a package, a parameter, a remap, an
executable) is checked against ROS's rules where it enters the model, and what is written
into Python or XML is written by a serialiser for that language, so a name can never
become code in an exported script or a launch file.
"""

from __future__ import annotations

import ast
import json
import sys
from pathlib import Path

import pytest
import yaml
from shell import error_of
from std_msgs.msg import String

from ipyros import rosNode
from ipyros.core import errors
from ipyros.files import modelfile as keep

FORMAT = {keep.FORMAT_KEY: keep.FORMAT}


def model_file(tmp_path: Path, node: dict, name: str = "model.yaml") -> Path:
    path = tmp_path / name
    path.write_text(yaml.safe_dump({**FORMAT, "node": node}))
    return path


def test_a_model_file_whose_basenode_would_run_a_program_is_refused_without_trust(tmp_path, session):
    planted = tmp_path / "planted"
    path = model_file(tmp_path, {"name": "innocent", "base": {"executable": "/bin/sh",
                                                             "args": ["-c", f"touch {planted}"]}})
    with pytest.raises(errors.IpyrosError) as caught:
        rosNode.load(path, {}, create=True, session=session)
    text = str(caught.value)
    assert f"{path} would run the basenode /bin/sh -c 'touch {planted}'" in text and "trust=True" in text
    assert "\n" not in text and not planted.exists()
    assert all(n.name != "innocent" for n in session.nodes.values())
    with pytest.raises(errors.BaseNodeError):  # trusted, it runs (and /bin/sh ends at once: a dead basenode)
        rosNode.load(path, {}, create=True, session=session, trust=True)
    assert planted.exists()


@pytest.mark.parametrize("base, says", [
    ({"executable": "talker", "package": "rospy_tutorials", "args": ["--rate", "5"]},
     "the basenode talker --rate 5 of package rospy_tutorials"),
    ({"executable": "x", "launch": "/robot/bringup.launch", "launch_node": "/planner"},
     "the basenode /planner of the launch file /robot/bringup.launch (and the rest of that file)"),
])
def test_the_refusal_says_what_would_run(tmp_path, base, says):
    with pytest.raises(errors.IpyrosError, match="would run " + says.replace("(", r"\(").replace(")", r"\)")):
        rosNode.load(model_file(tmp_path, {"name": "x", "base": base}), {})


def test_load_nodes_refuses_it_too(ip, tmp_path):  # noqa: F811
    planted = tmp_path / "planted"
    path = model_file(tmp_path, {"name": "innocent_magic", "base": {"executable": "/bin/sh",
                                                                   "args": ["-c", f"touch {planted}"]}})
    error = error_of(ip, f"%load_nodes {path}")
    assert "would run the basenode /bin/sh" in str(error) and "%load_nodes --trust" in str(error)
    assert not planted.exists() and "innocent_magic" not in ip.user_ns


def test_a_model_without_code_or_basenode_loads_without_trust(tmp_path, session):
    path = model_file(tmp_path, {"name": "plain_model", "topics": [
        {"name": "/plain/out", "resolved": "/plain/out", "direction": "publish", "type": "std_msgs/String"}],
        "params": {"gain": 2}})
    nd = rosNode.load(path, {}, session=session)
    assert nd.model().topic("/plain/out", "publish") is not None and nd.params["gain"] == 2


@pytest.mark.parametrize("text, says", [
    ("&a [1,1,1,1,1,1,1,1,1,1]\n", None),  # fine: one alias
    ("a: &a [1,2,3,4,5,6,7,8,9]\nb: &b [*a,*a,*a,*a,*a,*a,*a,*a,*a]\nc: &c [*b,*b,*b,*b,*b,*b,*b,*b,*b]\n"
     "d: &d [*c,*c,*c,*c,*c,*c,*c,*c,*c]\ne: &e [*d,*d,*d,*d,*d,*d,*d,*d,*d]\nf: &f [*e,*e,*e,*e,*e,*e,*e,*e,*e]\n"
     "g: &g [*f,*f,*f,*f,*f,*f,*f,*f,*f]\nh: [*g,*g,*g,*g,*g,*g,*g,*g,*g]\n", "expands to more than"),
    ("[" * 5000 + "]" * 5000, "nested too deeply"),
])
def test_a_model_file_that_is_a_bomb_is_one_line(tmp_path, text, says):
    path = tmp_path / "bomb.yaml"
    path.write_text(text)
    with pytest.raises(errors.IpyrosError) as caught:
        rosNode.load(path)
    assert "\n" not in str(caught.value)
    if says:
        assert says in str(caught.value)


def test_deeply_nested_json_is_one_line(tmp_path):
    path = tmp_path / "deep.json"
    path.write_text("[" * 100000 + "]" * 100000)
    with pytest.raises(errors.IpyrosError, match="nested too deeply"):
        rosNode.load(path)


@pytest.mark.parametrize("declare, says", [
    (lambda nd: nd.basePackage('x"""\nimport os; os.system("id")\n"""'), "invalid package name"),
    (lambda nd: nd.basePackage("a</exec_depend><build_depend>evil"), "invalid package name"),
    (lambda nd: nd.basePackage("$(eval 1+1)"), "invalid package name"),
    (lambda nd: nd.baseNode("talker", params={"$(eval 1)": 1}), "invalid parameter name"),
    (lambda nd: nd.baseNode("talker", remaps={"$(eval x)": "/a"}), "invalid remap"),
    (lambda nd: nd.baseNode("talker", remaps={"scan": "a b"}), "invalid remap"),
    (lambda nd: nd.baseNode("talk\ner"), "control characters"),
    (lambda nd: nd.baseNode("$(find x)/talker"), "'$('"),
])
def test_names_are_checked_where_they_enter_the_model(make_node, declare, says):
    nd = make_node("names_checked")
    with pytest.raises(errors.DeclarationError) as caught:
        declare(nd)
    assert says in str(caught.value) and "\n" not in str(caught.value)
    assert nd.model().base is None


@pytest.mark.parametrize("key", ["", "$(eval 1)", "a b", "/abs", "~x", "1a", "a//b"])
def test_node_params_take_only_parameter_names(make_node, key):
    nd = make_node("params_checked")
    for state in ("declared", "running"):
        with pytest.raises(errors.DeclarationError):
            nd.params[key] = 5
        if state == "declared":
            nd.create()
    assert dict(nd.params) == {}


def test_an_export_path_with_quotes_stays_a_name(make_node, tmp_path):
    nd = make_node("quoted_export")
    nd.new.publish("/quoted/out", msgType=String)
    folder = tmp_path / 'a"""\nimport os; os.system("touch planted")\n"""b'
    folder.mkdir()
    script = nd.export(folder / 'x""".py')
    tree = ast.parse(script.read_text())
    docstring = ast.get_docstring(tree, clean=False)
    assert 'x""".py' in docstring
    assert not any(isinstance(node, ast.Expr) and isinstance(node.value, ast.Call) for node in tree.body), \
        "no statement of the docstring's text reached the module"


def test_a_basenode_path_with_quotes_stays_a_name(make_node, tmp_path):
    folder = tmp_path / 'b""" + open("planted", "w").name + """'
    folder.mkdir()
    node_script = folder / "node.py"
    node_script.write_text("print('a node')\n")
    nd = make_node("quoted_base").baseNode(str(node_script))
    nd.reuse.publish("/quoted/base_out", type=String)
    script = nd.export(tmp_path / "wrapper.py")
    tree = ast.parse(script.read_text())
    basenode = next(n for n in tree.body if isinstance(n, ast.Assign) and getattr(n.targets[0], "id", "") == "BASENODE")
    argv = ast.literal_eval(basenode.value)
    assert argv[:2] == [sys.executable, str(node_script)]


def test_an_intercepted_service_makes_the_round_trip(make_node, tmp_path, session):
    """A model file that %save_nodes writes loads back: reuse.service + new.service on one name."""
    from std_srvs.srv import SetBool

    node_script = Path(__file__).resolve().parent / "peers" / "listen.py"
    nd = make_node("intercepted_service").baseNode(str(node_script))
    nd.reuse.service("/intercepted/set", type=SetBool)
    nd.new.service("/intercepted/set", SetBool, handler=answer_set)
    path = nd.save(tmp_path / "intercepted.yaml")
    loaded = rosNode.load(path, {"answer_set": answer_set}, trust=True, session=session)
    assert loaded.model() == nd.model()
    assert json.loads(json.dumps(loaded.model().to_dict())) == nd.model().to_dict()


def answer_set(request):
    return None
