"""Export a DSL node to run without ipyros: one script, or a ROS package with a launch file.

The script walks the same plan the runtime opens (:func:`ipyros.core.plan.plan`), so the
script and the live node cannot disagree on wrapping: publishers, subscribers with the
handlers' sources, byte relays, timers, services, private params. Handler globals are
copied in where they can be: imports, plain literals, helper sources.

What is the same on both ROS is here: which handlers and globals go in and under which
names (:class:`Script`), the module's layout, the docstring (escaped: a name holding
``\"\"\"`` stays a name), writing the files (only inside the folder an export owns). What
each ROS writes differently (rospy or rclpy calls, a catkin package) is its backend's
*flavour* (``ros1/export.py``, ``ros2/export.py``), which the caller hands over (the DSL
asks the session's backend: ``backend.export_flavour()``).

A wrapping node's basenode runs remapped as ipyros runs it
(:func:`ipyros.core.remapping.basenode_remaps`): started and stopped by the script itself in
the one-file form (``nd.export("node.py")``), or by roslaunch next to the node in the
package form (``nd.export("my_node_pkg")``: a catkin package on ROS 1, an ament_python package
that colcon builds on ROS 2).
"""

from __future__ import annotations

import ast
import dataclasses
import getpass
import os
import re
import xml.etree.ElementTree as ET
from functools import partial
from pathlib import Path
from typing import Any, Callable, Mapping, Optional

from ..core import msgtypes
from ..core import plan as planning
from ..core.code import WRITER, Bindings, handler_slots, handler_source, import_of
from ..core.errors import IpyrosError, warn_user
from ..core.model import BaseModel, NodeModel
from ..core.remapping import base_namespace, base_node_name, basenode_remaps
from ..core.slots import call_arity
from .atomic import write_atomic
from .exportrules import RULES_FUNCTIONS, rules_source
from .kept import KeptNode

__all__ = ["ExportWarning", "Script", "check_package_name", "docstring", "export", "package_xml", "placed_on",
           "xml_comment", "xml_text"]

#: How a script starts and stops its basenode: plain Python, the same for rospy and rclpy.
BASENODE_FUNCTIONS = '''
def start_basenode():
    """Run the wrapped node as a child, in its own process group (so it is stopped as a whole)."""
    proc = subprocess.Popen(BASENODE, env={**os.environ, **BASENODE_ENV}, start_new_session=True)
    print(f"started basenode {BASENODE[0]} (pid {proc.pid})", flush=True)
    return proc


def stop_basenode(proc):
    """Stop it as roslaunch does: SIGINT, then SIGTERM, then SIGKILL, to its process group."""
    for sig in (signal.SIGINT, signal.SIGTERM, signal.SIGKILL):
        if proc.poll() is not None:
            return
        try:
            os.killpg(proc.pid, sig)
            proc.wait(5)
        except (ProcessLookupError, subprocess.TimeoutExpired):
            pass
'''


#: A guard as the session ran it (ipyros.core.guard), standing alone in the exported node: plain Python, the same for
#: rospy and rclpy. The stop on silence runs here on a thread of the node's own, on the steady clock.
GUARD_FUNCTIONS = '''
class Guard:
    """What every message of a guarded output passes before it is published: limits (clamped, or dropped), NaN and
    infinities replaced by the stop message, a rate limit per field; after timeout s with nothing passed, the stop
    message at repeat Hz until a message passes (on the steady clock: never stopped by a stopped ROS clock). With
    rules (Rules: over what the robot senses, its inputs subscribed by listen), each command is judged by them
    first, and with none coming they are judged at repeat Hz and as each input comes: while they hold the stop
    message (an input stale, a stop rule, a last command they would now change), it goes out at repeat Hz."""

    def __init__(self, publish, stop, limits=None, rate=None, on_limit="clamp", timeout=None, repeat=10.0,
                 rules=None, listen=None, topic=""):
        self._out, self._stop, self.limits, self.rate = publish, stop, limits or {}, rate or {}
        self.on_limit, self.timeout, self.period = on_limit, timeout, 1.0 / repeat
        self._lock, self._last, self.passed_at = threading.Lock(), {}, time.monotonic()
        self.rules, self.heard, self.last, self._ruling, self._ruled_at = rules, {}, None, "", -math.inf
        self.said = f"guard {topic}:" if topic else "guard:"  # how its lines begin
        self._armed_at = time.monotonic() + 1.0  # its inputs' first messages awaited a second at most
        for name, cls in (rules.inputs.items() if rules is not None else ()):
            listen(name, cls, self._hearing(name))
        if timeout is not None or rules is not None:
            threading.Thread(target=self._watch, daemon=True).start()

    def publish(self, msg):
        with self._lock:
            msg = self.check(msg)
            if msg is not None:
                self.passed_at = time.monotonic()
                self._out(msg)

    def check(self, msg):
        if not _finite(msg):
            return copy.deepcopy(self._stop)
        if self.rules is not None:
            if not self._armed():
                return None  # its inputs not heard yet, at start: nothing judged, nothing sent (a second at most)
            try:
                why, judged = self.rules.judge(self.heard, time.monotonic(), msg)
                msg, why = (None, why) if why else self.rules.apply(judged, msg)
            except Exception:  # noqa: BLE001 - when in doubt, the stop message
                msg = None
            if msg is None:
                return copy.deepcopy(self._stop)
        msg = copy.deepcopy(msg)
        for path, (low, high) in self.limits.items():
            for owner, key, value in _values(msg, path):
                if not low <= value <= high:
                    if self.on_limit == "drop":
                        return None
                    _put(owner, key, type(value)(min(max(value, low), high)))
        now = time.monotonic()
        for path, most in self.rate.items():
            for place, (owner, key, value) in enumerate(_values(msg, path)):
                last = self._last.get((path, place))
                if last is not None:
                    step = most * (now - last[1])
                    value = type(value)(min(max(value, last[0] - step), last[0] + step))
                    _put(owner, key, value)
                self._last[(path, place)] = (value, now)
        if self.rules is not None:
            self.last = copy.deepcopy(msg)
        return msg

    def _armed(self):
        return time.monotonic() >= self._armed_at or all(topic in self.heard for topic in self.rules.topics)

    def _hearing(self, topic):
        def heard(msg):
            with self._lock:
                self.heard[topic] = (msg, time.monotonic())
            self._look()  # an obstacle, no command coming: the stop message now
        return heard

    def _look(self):
        """Its rules judged with no new command: the stop message at repeat Hz while they hold it, said once."""
        with self._lock:
            now = time.monotonic()
            if self.rules is None or not self._armed():
                return
            try:
                why = self.rules.idle(self.heard, now, self.last)
            except Exception as error:  # noqa: BLE001 - when in doubt, the stop message (and the watch goes on)
                why = f"its rules could not be judged ({error!r})"
            if why and now - self._ruled_at >= self.period:
                self._ruled_at = now
                self._out(copy.deepcopy(self._stop))
                self._last.clear()  # a rate-limited field starts again from the stop message
                self.last = copy.deepcopy(self._stop)  # the last command now: within the rules (checked at export)
            if why and not self._ruling:
                print(f"{self.said} {why}: the stop message goes out until its rules let a command pass", flush=True)
            elif self._ruling and not why and not self._ruling.startswith("the last command"):
                print(f"{self.said} its rules let commands pass again", flush=True)
            self._ruling = why

    def _watch(self):
        while True:
            wait = self.period
            with self._lock:
                now = time.monotonic()
                if self.timeout is not None and now - self.passed_at >= self.timeout:
                    self._out(copy.deepcopy(self._stop))
                    self._last.clear()  # a rate-limited field starts again from the stop message
                elif self.timeout is not None and self.rules is None:
                    wait = self.passed_at + self.timeout - now
            self._look()
            time.sleep(wait)


def _fields(msg):
    listed = getattr(type(msg), "get_fields_and_field_types", None)
    return list(listed()) if listed is not None else list(getattr(type(msg), "__slots__", ()))


def _finite(value):
    if isinstance(value, float):
        return math.isfinite(value)
    if isinstance(value, (bytes, bytearray, str)):
        return True
    if isinstance(value, (list, tuple)) or hasattr(value, "tolist"):
        items = value.tolist() if hasattr(value, "tolist") else value
        return all(_finite(item) for item in items)
    return all(_finite(getattr(value, name)) for name in _fields(value)) if _fields(value) else True


def _values(msg, path):
    """(owner, key, value) of each value the path (linear.x, axes[2], poses[*].x) names in msg."""
    found = [msg]
    steps = path.split(".")
    out = []
    for number, step in enumerate(steps):
        name, _, index = step.partition("[")
        index = index.rstrip("]")
        nxt = []
        for owner in found:
            value = getattr(owner, name)
            places = [None] if not index else range(len(value)) if index in ("*", ":") else [int(index)]
            for place in places:
                item = value if place is None else value[place]
                key = name if place is None else (name, place)
                (out.append((owner, key, item)) if number == len(steps) - 1 else nxt.append(item))
        found = nxt
    return out


def _put(owner, key, value):
    if isinstance(key, tuple):
        items = getattr(owner, key[0])
        if isinstance(items, tuple):
            items = list(items)
            items[key[1]] = value
            setattr(owner, key[0], items)
        else:
            items[key[1]] = value
    else:
        setattr(owner, key, value)


def _fill(msg, data):
    """msg with the fields of data (a dict, nested for nested messages) set: the guard's stop message."""
    for key, value in data.items():
        if isinstance(value, dict):
            _fill(getattr(msg, key), value)
        else:
            setattr(msg, key, value)
    return msg
'''

#: The modules GUARD_FUNCTIONS uses, imported by a script with a guard; with what it defines, the script's own names.
GUARD_IMPORTS = ("copy", "math", "threading", "time")
GUARD_NAMES = {*GUARD_IMPORTS, *re.findall(r"^(?:def |class )?(\w+)\b(?:\(| =|:)", GUARD_FUNCTIONS + RULES_FUNCTIONS,
                                           re.M)}


class ExportWarning(UserWarning):
    """The exported script has names to fill in by hand (``NAME = None  # set me``)."""


def docstring(text: str) -> str:
    """``text`` as a triple-quoted string literal that reads back as exactly ``text``.

    Names in a docstring come from the user (an export path, a basenode's path): a ``\"\"\"``
    in one would end the docstring and make the rest of the name code. So backslashes and
    quotes are escaped, and the literal is checked to read back as the text it stands for.
    """
    body = text.replace("\\", "\\\\").replace('"', '\\"')
    literal = f'"""{body}"""'
    if ast.literal_eval(literal) != text:  # ipyros's bug, not the user's: never write it
        raise IpyrosError(f"cannot write {text[:60]!r} as a docstring")
    return literal


class Script:
    """What a script needs (imports, values, functions), collected while its flavour writes it.

    ``package`` None: one file that does everything, the basenode included. A package name:
    the script of that package, whose launch file starts the basenode (the script does not).
    The flavour asks it for the script's names of things: :meth:`cls` (a message or service
    class, imported once), ``names`` (each handler slot's function), :meth:`takes_event`,
    ``writers`` (the variables the handlers ``write`` through).
    """

    def __init__(self, node: KeptNode, flavour: Any, path: "str | os.PathLike[str]", namespace: Optional[dict],
                 package: Optional[str] = None, topic_types: Optional[Mapping[str, str]] = None) -> None:
        self.flavour, self.node, self.path, self.package = flavour, node, path, package
        self.topic_types = topic_types or {}  # topic → type, as the live graph showed them: the rules' inputs
        self.model: NodeModel = node.model()
        self.handlers: dict[str, Callable[..., Any]] = node.handlers()
        # The handlers' sources go in with their globals: a global named like a handler is that handler.
        self.bindings = Bindings(imports={flavour.LIBRARY: (flavour.LIBRARY, None)})
        self.imports = self.bindings.imports  # message classes join the handlers' imports
        self.names: dict[str, str] = {}  # slot → the handler's name in the script
        self.unset: dict[str, str] = {}  # global name → its "set me" line
        sources = {slot: self._handler(slot, f"{node.name} {label}") for slot, label in handler_slots(self.model)}
        self.writers = sorted({w for src in sources.values() for w in WRITER.findall(src)}) or ["this_node"]
        for slot, _label in handler_slots(self.model):
            fn = self.handlers[slot]
            self.bindings.bind(fn, sources[slot], namespace, skip=partial(self._skip, fn))
            for name in [n for n in self.bindings.unbound if n not in self.unset]:
                self.unset[name] = f"{name} = None  # set me: used by handler {fn.__name__}"

    # -- what the flavour asks ----------------------------------------------------------------
    @property
    def starts_base(self) -> bool:
        """Whether the script runs the basenode itself (the single-file export of a wrapping node)."""
        return self.model.base is not None and self.package is None

    def cls(self, type_name: str, kind: str = "msg") -> str:
        """The script's name for a message/service class, imported once (``pkg_Type`` if taken)."""
        package, short = type_name.split("/")
        origin = (f"{package}.{kind}", short)
        for name in (short, f"{package}_{short}"):
            if not self._taken(name) and self.imports.setdefault(name, origin) == origin:
                return name
        raise IpyrosError(f"the exported script cannot name {type_name}: {short} and {package}_{short} are taken")

    def takes_event(self, slot: str) -> bool:
        """Whether the timer handler of ``slot`` takes the timer event."""
        return bool(call_arity(self.handlers[slot], "timer", self.names[slot]))

    def takes_action(self, slot: str) -> bool:
        """Whether the action handler of ``slot`` takes the action beside the goal (``def h(goal, action)``)."""
        return call_arity(self.handlers[slot], "action", self.names[slot]) == 2

    def writes_to(self) -> dict[str, str]:
        """Each publication of the plan → the name the handlers ``write`` to it by."""
        targets = {t.resolved: planning.write_target(self.model, t.resolved) for t in self.model.topics}
        return {target: topic for topic, target in targets.items() if target is not None}

    def plan(self) -> list[Any]:
        """The endpoints, publishers first: a handler may write as soon as its subscriber is up. A guard is not an
        endpoint of its own here: its output publishes through it (:meth:`guard`)."""
        return sorted((s for s in planning.plan(self.model) if not isinstance(s, planning.GuardSpec)),
                      key=lambda s: not isinstance(s, planning.PublishSpec))

    def guard(self, topic: str, publish: str) -> Optional[str]:
        """The script's guard on the output ``topic`` around ``publish`` (an expression: what publishes a
        message), an expression with a ``publish(msg)`` of its own; None if the output is not guarded."""
        guard = self.model.guard(topic)
        if guard is None:
            return None
        cls = self.cls(guard.type)
        stop = f"_fill({cls}(), {guard.stop!r})" if guard.stop else f"{cls}()"
        options = {"limits": {p: tuple(b) for p, b in guard.limits.items()} or None, "rate": guard.rate or None,
                   "on_limit": guard.on_limit if guard.on_limit != "clamp" else None, "timeout": guard.timeout,
                   "repeat": guard.repeat}
        text = "".join(f", {key}={value!r}" for key, value in options.items() if value is not None)
        if guard.rules or guard.stale:  # its inputs subscribed as the flavour subscribes (best effort)
            ruled = rules_source(guard, msgtypes.resolve_message(guard.type)[1], self.cls, self.topic_types)
            text += f", rules={ruled}, listen={self.flavour.LISTEN}, topic={guard.resolved!r}"
        return f"Guard({publish}, {stop}{text})"

    # -- the script -----------------------------------------------------------------------------
    def render(self) -> str:
        flavour = self.flavour
        main = flavour.main(self)  # first: it adds the message imports
        base = self._base_argv() if self.starts_base else None
        stdlib = flavour.stdlib(self, base is not None)
        if self.model.guards:
            stdlib = sorted({*stdlib, *GUARD_IMPORTS})
        head = [flavour.shebang(), docstring(flavour.about(self)), *(f"import {m}" for m in stdlib),
                *flavour.before_imports(self), "", *self.bindings.import_lines(skip=stdlib), *flavour.imports(self)]
        values = [*self.bindings.values.values(), *self.unset.values()]
        if values:
            head += ["", "# Globals the handlers read, as they were at export.", *values]
        parts = ["\n".join(head), *flavour.handle(self), f"{' = '.join(self.writers)} = NodeHandle()"]
        if base is not None and self.model.base is not None:
            parts.append("# The basenode, remapped so that it talks only to this node on the topics it wraps.\n"
                         "BASENODE = [\n" + "".join(f"    {arg!r},\n" for arg in base) + "]\n"
                         f"BASENODE_ENV = {self.model.base.env!r}  # its launch file's <env> tags, if any")
            parts.append(BASENODE_FUNCTIONS.strip("\n"))
        parts += flavour.helpers(self)
        if self.model.guards:
            parts.append(GUARD_FUNCTIONS.strip("\n"))
        if any(g.rules or g.stale for g in self.model.guards):
            parts.append(RULES_FUNCTIONS.strip("\n"))
        parts += [src.rstrip("\n") for src in self.bindings.functions.values()]
        parts.append("def main():\n" + "".join(f"    {line}\n" for line in main).rstrip("\n"))
        parts.append('if __name__ == "__main__":\n    main()')
        return "\n\n\n".join(parts) + "\n"

    def placed_base(self) -> BaseModel:
        """The basenode as ipyros runs it: its name and namespace filled in, its own remaps composed with the
        wrapping's (:func:`ipyros.core.remapping.basenode_remaps`, one remap per name)."""
        model = self.model
        assert model.base is not None
        return dataclasses.replace(model.base, node_name=base_node_name(model.base), namespace=base_namespace(model),
                                   remaps=basenode_remaps(model, self.flavour.action_parts))

    def _base_argv(self) -> list[str]:
        """The basenode's command line as ipyros launches it (its executable found now, as the backend finds it)."""
        return self.flavour.base_command(self.placed_base())

    # -- collecting -----------------------------------------------------------------------------
    def _handler(self, slot: str, label: str) -> str:
        fn = self.handlers[slot]
        source = handler_source(fn, label)
        name = fn.__name__
        if name == "<lambda>":  # a name of its own: on_turtle1_pose, timer_tick, ...
            name = re.sub(r"\W+", "_", slot.replace("topic ", "on ", 1)).strip("_")
            source = f"{name} = {source}"
        functions = self.bindings.functions
        if functions.get(name, source) != source:
            raise IpyrosError(f"two different handlers of {self.node.name} are named {name}; "
                              "rename one (def another_name(msg): ...) and declare it again")
        functions[name], self.names[slot] = source, name
        return source

    def _skip(self, fn: Callable[..., Any], name: str, value: Any) -> bool:
        """Globals the script binds itself: the node the handlers write with; refuse one it needs for itself."""
        if name in self.writers:
            return True
        if name in self.flavour.SCRIPT_NAMES | GUARD_NAMES and import_of(value, fn.__module__) != (name, None):
            raise IpyrosError(f"handler {fn.__name__} uses the global {name}, a name the exported script "
                              "needs for itself; rename it")
        return False

    def _taken(self, name: str) -> bool:
        """Whether ``name`` means something else than an import in the script."""
        return name in self.writers or (self.bindings.has(name) and name not in self.imports)


# -- a folder of files the export owns ------------------------------------------------------------

#: The first line of the comment that marks a manifest as ipyros's: a later export may replace the
#: package, and only the files that comment lists.
MARK = "Exported by ipyros"
_LISTED = re.compile(r"<!-- " + MARK + r"\b.*?^\s*files: ([^\n]*)$", re.S | re.M)


def _previous_export(directory: Path) -> set[str]:
    """The files an earlier ipyros export listed in ``directory``; refuse a directory holding anything else."""
    if not directory.exists():
        return set()
    if not directory.is_dir():
        raise IpyrosError(f"{directory} is a file: export to a directory (a ROS package) or to a .py script")
    present = {p.relative_to(directory).as_posix() for p in directory.rglob("*") if not p.is_dir()}
    if not present:
        return set()
    try:
        found = _LISTED.search((directory / "package.xml").read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError):
        found = None
    if found is None:
        shown = ", ".join(sorted(present)[:3]) + (", ..." if len(present) > 3 else "")
        raise IpyrosError(f"{directory} holds files that ipyros did not export ({shown}): export to a new or empty "
                          "directory")
    # Only names of files inside the folder count: a package.xml may have been edited to list ../anything.
    listed = {name for name in found.group(1).split() if _inside(directory, name)}
    foreign = sorted(present - listed - {"package.xml"})
    if foreign:
        raise IpyrosError(f"{directory} is an earlier ipyros export, but holds files it did not write "
                          f"({', '.join(foreign[:3])}{', ...' if len(foreign) > 3 else ''}): move them away, or export "
                          "to another directory")
    return listed


def _inside(directory: Path, name: str) -> bool:
    """Whether ``directory / name`` is a file of ``directory`` itself (no ``..``, no link leading out)."""
    target = directory / name
    return not Path(name).is_absolute() and ".." not in Path(name).parts and \
        os.path.realpath(target).startswith(os.path.realpath(directory) + os.sep)


# REP 144: lower case letters, digits and single underscores, starting with a letter.
_PACKAGE_NAME = re.compile(r"[a-z][a-z0-9]*(?:_[a-z0-9]+)*")


def check_package_name(name: str) -> str:
    """``name`` if it is a valid ROS package name (REP 144), else a one-line :class:`IpyrosError`."""
    if len(name) < 2 or not _PACKAGE_NAME.fullmatch(name):
        raise IpyrosError(f"{name!r} is not a valid ROS package name (lower case letters, digits and single "
                          "underscores, starting with a letter): export to a directory named like my_robot_node")
    return name


def maintainer() -> tuple[str, str]:
    """Who maintains an exported package: the user, with catkin_create_pkg's placeholder address (``user@todo.todo``)."""
    try:
        user = getpass.getuser()
    except (KeyError, OSError):  # no name for this uid (e.g. in a container)
        user = "ipyros"
    return user, re.sub(r"[^-a-zA-Z0-9_%+]", "_", user) + "@todo.todo"


def package_xml(model: NodeModel, package: str, description: str, depends: list[str], files: Any, mark_text: str,
                *, format: str, buildtool: Optional[str] = None, build_type: Optional[str] = None,
                build_too: tuple[str, ...] = ()) -> str:
    """package.xml, written by an XML library (every name escaped), with the comment that marks it as ipyros's
    (listing the files the export wrote: a later export replaces those, and only those). ``build_too``: the
    dependencies a C++ node is built against (``<depend>``); the others are ``<exec_depend>``."""
    user, email = maintainer()
    root = ET.Element("package", format=format)
    for tag, text in (("name", package), ("version", "0.0.0"), ("description", description + ".")):
        ET.SubElement(root, tag).text = text
    ET.SubElement(root, "maintainer", email=email).text = user
    ET.SubElement(root, "license").text = "TODO"
    if buildtool:
        ET.SubElement(root, "buildtool_depend").text = buildtool
    for dependency in depends:  # those a C++ node is built against too: <depend>
        ET.SubElement(root, "depend" if dependency in build_too else "exec_depend").text = dependency
    if build_type:
        ET.SubElement(ET.SubElement(root, "export"), "build_type").text = build_type
    ET.indent(root, space="  ")
    mark = ET.Comment(f" {mark_text} from the DSL node {planning.node_fullname(model)}.\n"
                      "     Exporting again replaces the package: this file and the files listed here (and only these).\n"
                      f"     files: {' '.join(sorted(files))}\n")
    return ('<?xml version="1.0"?>\n' + ET.tostring(mark, encoding="unicode") + "\n"
            + ET.tostring(root, encoding="unicode") + "\n")


def xml_comment(*lines: str) -> Any:  # an ET.Element: a comment's, of a tag that is no string
    """A comment of a launch file's top level, one line each (``--`` may not stand in an XML comment)."""
    return ET.Comment(" " + "\n       ".join(lines).replace("--", "- -") + " ")


def placed_on(base: Any) -> list[str]:
    """What a package's launch file says of a basenode the session placed on a machine: where to start it."""
    if not getattr(base, "machine", None):
        return []
    return [f"In the session it ran on machine {base.machine} (its keeper started it there): install and start",
            "this package on that machine, so that the basenode and the node relaying it run beside the robot."]


def xml_text(root: ET.Element) -> str:
    """``root`` as an indented XML file."""
    ET.indent(root, space="  ")
    return '<?xml version="1.0"?>\n' + ET.tostring(root, encoding="unicode") + "\n"


def _export_package(node: KeptNode, flavour: Any, directory: Path, namespace: Optional[dict],
                    topic_types: Mapping[str, str],
                    language: str = "python") -> Path:
    """Write the package ``directory`` (named after it): the flavour says which files, this writes them."""
    package = check_package_name(directory.name)
    model = node.model()
    script_name, script_mode = flavour.script_file(package, model.name)
    script_path = directory / script_name
    script = Script(node, flavour, script_path, namespace, package=package, topic_types=topic_types)
    if language == "cpp":  # the handlers' sources, collected as for a script, go beside their C++ methods
        files, manifest = flavour.cpp_package(script, package)
    else:
        text = script.render()
        compile(text, str(script_path), "exec")  # a generated script that does not compile is ipyros's bug
        files = {script_name: (text, script_mode), **flavour.package_files(script, package)}
        manifest = partial(flavour.manifest, script, package)
    stale = _previous_export(directory) - set(files)
    try:
        for folder in {str(Path(name).parent) for name in files} - {"."}:
            (directory / folder).mkdir(parents=True, exist_ok=True)
    except OSError as error:
        raise IpyrosError(f"cannot create {directory}: {error.strerror}") from None
    # The manifest first, listing every file that may be there: an export cut short is still replaceable.
    write_atomic(directory / "package.xml", manifest([*files, *stale], MARK))
    for name, (content, mode) in files.items():
        write_atomic(directory / name, content, mode=mode)
    if stale:
        for name in stale:
            if _inside(directory, name):  # listed by an earlier export, and checked so: never a file elsewhere
                (directory / name).unlink(missing_ok=True)
        write_atomic(directory / "package.xml", manifest(files, MARK))
    if language == "cpp":
        said = flavour.cpp_said(script, package)
        if said:
            warn_user(said, ExportWarning)
    else:
        _warn_unset(script, script_path)
    return directory


def export(node: KeptNode, path: "str | os.PathLike[str]", flavour: Any, namespace: Optional[dict] = None,
           language: str = "python", topic_types: Optional[Mapping[str, str]] = None) -> Path:
    """Export ``node`` to run without ipyros, written for ``flavour``'s ROS; return what was written.

    ``path`` ending in ``.py``: one standalone script of that ROS (rospy or rclpy)
    that does everything, for a wrapping node starting and stopping its basenode itself.

    Any other ``path``: a directory, made a ROS package named after it (drop it into a
    workspace's ``src/``). ROS 1, a catkin package (or put its parent on ``ROS_PACKAGE_PATH``)::

        package.xml              exec_depend on rospy, the message packages, the basenode's
        CMakeLists.txt           catkin_make installs the script and the launch file
        scripts/<node>           the node: rosrun <package> <node>
        launch/<node>.launch     the node with its params, and its basenode with its remaps

    ROS 2, an ament_python package that ``colcon build`` builds::

        package.xml              format 3: exec_depend on rclpy, the message packages, the basenode's
        setup.py, setup.cfg      the console script <node> (ros2 run <package> <node>)
        resource/<package>       the ament index's marker
        <package>/<node>.py      the node, a module with main()
        launch/<node>.launch.xml the node with its params file, and its basenode with its remaps
        config/<node>.yaml       the node's parameters

    An existing directory is replaced only if it is an earlier export (its package.xml
    says so, and it holds nothing else): nobody's own package is overwritten.

    Handler globals are looked up in their closure, ``namespace`` (IPython's ``user_ns``)
    and their module: modules and importable names become imports, plain literals become
    assignments, the user's helper functions are copied; anything else becomes
    ``NAME = None  # set me`` and an :class:`ExportWarning` lists them.
    """
    if language == "cpp" and Path(path).suffix == ".py":
        raise IpyrosError(f"export({str(path)!r}, language='cpp'): C++ goes in a package: give a directory "
                          "named like my_node_pkg")
    if Path(path).suffix != ".py":
        return _export_package(node, flavour, Path(os.path.abspath(Path(path).expanduser())), namespace,
                               topic_types or {}, language)
    script = Script(node, flavour, path, namespace, topic_types=topic_types)
    text = script.render()
    compile(text, str(path), "exec")  # a generated script that does not compile is ipyros's bug: fail here
    written = write_atomic(path, text, mode=0o755)
    _warn_unset(script, written)
    return written


def _warn_unset(script: Script, written: Path) -> None:
    if script.unset:
        warn_user(f"ipyros: {written} needs values for {', '.join(script.unset)} (marked '# set me'): "
                  "they are not plain literals or importable", ExportWarning)
