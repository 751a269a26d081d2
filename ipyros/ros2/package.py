"""The ROS 2 package form of an export: an ament_python package that ``colcon build`` builds.

:func:`ipyros.files.export.export` writes the files this module lays out, beside the node's
module (the rclpy script of :mod:`.export`, as ``<package>/<node>.py`` with ``main()``)::

    package.xml               format 3; exec_depend on rclpy, the message packages, the basenode's
    setup.py, setup.cfg       the console script <node>, installed where ``ros2 run`` looks
    resource/<package>        the ament index's marker: ``ros2 run`` and ``find-pkg-share`` find it
    <package>/__init__.py
    launch/<node>.launch.xml  the node with its params file, and a wrapping node's basenode placed and
                              remapped as ipyros ran it: ``ros2 launch`` and ipyros's ``baseLaunch`` read it
    config/<node>.yaml        the node's parameters (ROS 2's params file)

In the package the node does not start its basenode: the launch file does, as roslaunch does for
the ROS 1 package. Text only: no ROS package is imported here.
"""

from __future__ import annotations

import xml.etree.ElementTree as ET
from typing import Any, Iterable

import yaml

from ..core import names
from ..core import plan as planning
from ..core.errors import IpyrosError
from ..files.export import package_xml, placed_on, xml_comment, xml_text

__all__ = ["manifest", "package_files"]

_SETUP_PY = '''\
"""{package}: exported by ipyros. colcon build installs it; ros2 run {package} {node} runs the node."""

from glob import glob

from setuptools import setup

setup(
    name={package!r},
    version="0.0.0",
    packages=[{package!r}],
    data_files=[
        ("share/ament_index/resource_index/packages", ["resource/{package}"]),
        ("share/{package}", ["package.xml"]),
        ("share/{package}/launch", glob("launch/*.launch.xml")),
        ("share/{package}/config", glob("config/*.yaml")),
    ],
    install_requires=["setuptools"],
    zip_safe=True,
    description={description!r},
    license="TODO",
    entry_points={{"console_scripts": ["{node} = {package}.{node}:main"]}},
)
'''

_SETUP_CFG = """\
[develop]
script_dir=$base/lib/{package}
[install]
install_scripts=$base/lib/{package}
"""


def package_files(script: Any, package: str) -> dict[str, tuple[str, int]]:
    """The package's files besides the node's module and package.xml."""
    model = script.model
    files = {"setup.py": (_SETUP_PY.format(package=package, node=model.name, description=_about(script)), 0o644),
             "setup.cfg": (_SETUP_CFG.format(package=package), 0o644),
             f"resource/{package}": ("", 0o644),
             f"{package}/__init__.py": ("", 0o644),
             f"launch/{model.name}.launch.xml": (_launch_xml(script, package), 0o644)}
    if _has_params(script):
        files[f"config/{model.name}.yaml"] = (_params_yaml(script), 0o644)
    return files


def _has_params(script: Any) -> bool:
    model = script.model
    return bool(model.params or (model.base is not None and model.base.params))


def manifest(script: Any, package: str, files: Iterable[str], mark_text: str) -> str:
    """package.xml (format 3, ament_python), with the comment that marks it as ipyros's."""
    return package_xml(script.model, package, _about(script), _dependencies(script, package), files, mark_text,
                       format="3", build_type="ament_python")


def _about(script: Any) -> str:
    model = script.model
    what = f"{model.name}: an rclpy node exported by ipyros from the DSL node {planning.node_fullname(model)}"
    if model.base is not None:
        what += f", and a launch file that starts it next to its basenode {model.base.package}/{model.base.executable}"
    return what


def _dependencies(script: Any, package: str) -> list[str]:
    """rclpy, the interface packages the node imports (``pkg.msg``/``.srv``/``.action``), the basenode's package."""
    needs = {"rclpy"}
    for module, _attr in script.imports.values():
        top, _, sub = module.partition(".")
        if sub in ("msg", "srv", "action"):
            needs.add(top)
    if script.model.guards or any(isinstance(s, (planning.ActionServerSpec, planning.ActionRelaySpec))
                                  for s in script.plan()):
        needs.add("action_msgs")
    if script.model.base is not None and script.model.base.package:
        needs.add(script.model.base.package)
    return sorted(needs - {package})


def _params_yaml(script: Any) -> str:
    """ROS 2's params file: a section for the node and one for its basenode (each under its full name, then
    ``ros__parameters``). YAML keeps each value's type, which a launch file's ``value=`` would guess."""
    model = script.model
    sections = {}
    if model.params:
        sections[planning.node_fullname(model)] = {key.lstrip("~_"): value for key, value in model.params.items()}
    if model.base is not None and model.base.params:
        base = script.placed_base()
        sections[names.join(base.namespace or "/", base.node_name)] = \
            {key.lstrip("~_"): value for key, value in base.params.items()}
    return yaml.safe_dump({name: {"ros__parameters": values} for name, values in sections.items()}, sort_keys=False)


def _launch_xml(script: Any, package: str) -> str:
    """The launch file (ROS 2 XML): the exported node with its params file, and for a wrapping node its
    basenode placed and remapped as ipyros runs it (so it talks only to the exported node on the names it wraps)."""
    model = script.model
    root = ET.Element("launch")
    root.append(xml_comment(f"{model.name}, exported by ipyros from the DSL node {planning.node_fullname(model)}.",
                         f"ros2 launch {package} {model.name}.launch.xml starts it" +
                         (" and its basenode, as under ipyros." if model.base is not None else ".")))
    # No name=: ros2 launch would give it as -r __node:=..., which renames every node of the process (the
    # exported node's service caller too); the node's code names it, as ipyros named it.
    node = _node(root, package, model.name, "", model.namespace)
    params_file = {"from": f"$(find-pkg-share {package})/config/{model.name}.yaml"}
    if model.params:
        ET.SubElement(node, "param", params_file)
    if model.base is None:
        return xml_text(root)
    base = script.placed_base()
    if not base.package or not base.executable:
        raise IpyrosError(f"{model.name}'s basenode has no package, and a launch file starts nodes by package: "
                          "declare it with .basePackage('package') (its package in the ament index), or export to "
                          "a .py script, which starts it by its path")
    bad = next((arg for arg in base.args if "$(" in arg), None)
    if bad is not None:
        raise IpyrosError(f"basenode argument {bad!r} holds '$(', which ros2 launch would expand: "
                          "export to a .py script instead, or change the argument")
    root.append(xml_comment(f"The basenode {base.package}/{base.executable}, remapped onto {model.name}'s internal names:",
                         f"it talks to the rest of the graph only through {model.name}, on the names it wraps.",
                         *placed_on(base)))
    extra = {"args": " ".join(base.args)} if base.args else {}
    base_node = _node(root, base.package, base.executable, base.node_name, base.namespace, **extra)
    for name, value in base.env.items():
        ET.SubElement(base_node, "env", name=name, value=value)
    for source, target in base.remaps.items():
        ET.SubElement(base_node, "remap", {"from": source, "to": target})
    if base.params:
        ET.SubElement(base_node, "param", params_file)
    return xml_text(root)


def _node(parent: ET.Element, package: str, executable: str, name: str, namespace: str, **attributes: str) -> ET.Element:
    placed = {"namespace": namespace.rstrip("/")} if namespace and namespace != "/" else {}
    return ET.SubElement(parent, "node", pkg=package, exec=executable, **({"name": name} if name else {}), **placed,
                         output="screen", **attributes)
