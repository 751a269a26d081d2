"""A ROS 1 node exported as C++ (the paper's code generation): a catkin package that ``catkin_make`` builds.

``nd.export("my_pkg", language="cpp")`` writes the boilerplate a roscpp node needs, from the same
plan the session runs (:func:`ipyros.core.plan.plan`):

* every ``reuse`` relay as a byte relay (``topic_tools::ShapeShifter``: no deserialising), advertised
  up front with its declared type, so nothing is lost at the start of a stream; latching follows the
  source, as in the session; an action relay is its five topics;
* every ``new.publish``/``new.subscribe``/service/timer declared with its type, latching and queue;
* the node's parameters set at start unless given (``_key:=value`` wins) and read into members;
* each guard compiled in: limits by field path (clamped or dropped), NaN and infinities replaced by the
  stop message, rate limits, and the stop message after ``timeout`` s of silence on a steady timer
  (never the ROS clock); its rules over what the robot senses too, their inputs subscribed (:mod:`.cpp_rules`);
* each Python handler as a C++ method whose body is the handler's Python source, as a comment, to be
  ported by hand: ``PORTING.md`` lists them, with their topics and the globals they read.

The C++ types and the fields the guard checks are read from the message classes of this Python
(genpy's ``_slot_types``), so a path that does not exist fails here, not in the compiler.
"""

from __future__ import annotations

from typing import Any, Callable, Iterable, Optional

from ..core import plan as planning
from ..files.export import package_xml
from .cpp_rules import RULES_HELPERS, CppRules
from .cpp_text import cpp_type, ident, indent, message_class, string, visit

__all__ = ["Manifest", "cpp_package", "ported_line"]

_FLOATS = ("float32", "float64")

#: What writes a package's package.xml, given the files it lists and the mark of an export by ipyros.
Manifest = Callable[[Iterable[str], str], str]


def cpp_package(script: Any, package: str, launch: str) -> tuple[dict[str, tuple[str, int]], Manifest]:
    """The package's files besides package.xml (``src/<node>.cpp``, ``CMakeLists.txt``, the launch file, whose
    text ``launch`` is the same as the Python package's, ``PORTING.md``), and what writes its package.xml given
    the files it lists: the source rendered once, its message packages the manifest's and CMake's depends."""
    model = script.model
    writer = _Writer(script)
    source = writer.source()
    packages = writer.packages()
    files = {f"src/{model.name}.cpp": (source, 0o644),
             "CMakeLists.txt": (_cmake(package, model.name, packages), 0o644),
             f"launch/{model.name}.launch": (launch, 0o644),
             "PORTING.md": (writer.porting(package), 0o644)}
    what = f"{model.name}: a roscpp node exported by ipyros from the DSL node {planning.node_fullname(model)}"
    built = tuple(sorted({"roscpp", "topic_tools", *packages} - {package}))
    depends = sorted({*built, *([model.base.package] if model.base is not None and model.base.package else [])}
                     - {package})

    def manifest(listed: Iterable[str], mark_text: str) -> str:
        return package_xml(model, package, what, depends, listed, mark_text, format="2", buildtool="catkin",
                           build_too=built)

    return files, manifest


def ported_line(script: Any, package: str) -> Optional[str]:
    """The one line said at export: which handlers wait to be ported by hand (None if none)."""
    names = [script.names[slot] for slot in script.handlers]
    if not names:
        return None
    return (f"ipyros: {package}'s C++ has {len(names)} handler(s) to port by hand ({', '.join(sorted(names))}): "
            f"their Python source is beside each method; see {package}/PORTING.md")


def _cmake(package: str, node: str, packages: list[str]) -> str:
    components = " ".join(["roscpp", "topic_tools", *packages])
    return f"""\
cmake_minimum_required(VERSION 3.0.2)
project({package})

set(CMAKE_CXX_STANDARD 17)
find_package(catkin REQUIRED COMPONENTS {components})
catkin_package()

include_directories(${{catkin_INCLUDE_DIRS}})
add_executable({node} src/{node}.cpp)
target_link_libraries({node} ${{catkin_LIBRARIES}})

install(TARGETS {node} RUNTIME DESTINATION ${{CATKIN_PACKAGE_BIN_DESTINATION}})
install(DIRECTORY launch DESTINATION ${{CATKIN_PACKAGE_SHARE_DESTINATION}})
"""


class _Writer:
    """The C++ source of one node, written from its plan."""

    def __init__(self, script: Any) -> None:
        self.script, self.model = script, script.model
        self.specs = planning.plan(self.model)
        self.types: set[str] = set()  # message and service types the node names (their headers)

    # -- what the package depends on ----------------------------------------------------------------
    def packages(self) -> list[str]:
        """The message packages the source names (after :meth:`source`)."""
        return sorted({t.split("/")[0] for t in self.types})

    # -- the source ---------------------------------------------------------------------------------
    def source(self) -> str:
        self.types = set()
        self.ruled = False  # a guard has rules: their helpers go in once
        self.finite = _Finite()
        members: list[str] = []
        setup: list[str] = []
        methods: list[str] = []
        guards: list[str] = []
        for spec in self.specs:
            if isinstance(spec, planning.PublishSpec):
                self.types.add(spec.type)
                pub = f"pub_{ident(spec.topic)}_"
                members.append(f"ros::Publisher {pub};")
                setup.append(f"{pub} = nh_.advertise<{cpp_type(spec.type)}>({string(spec.topic)}, kQueue, "
                             f"{'true' if spec.latch else 'false'});")
                guard = self.model.guard(spec.topic)
                if guard is not None:
                    guards.append(self._guard(guard))
                    name = f"guard_{ident(spec.topic)}_"
                    members.append(f"std::unique_ptr<{self._guard_class(guard)}> {name};")
                    setup.append(f"{name}.reset(new {self._guard_class(guard)}(nh_, {pub}));")
            elif isinstance(spec, planning.RelaySpec) and self.model.guard(spec.target) is not None:
                guard = self.model.guard(spec.target)
                self.types.add(spec.type)
                guards.append(self._guard(guard))
                pub, name, sub = (f"{kind}_{ident(spec.target)}_" for kind in ("pub", "guard", "relay"))
                members += [f"ros::Publisher {pub};", f"std::unique_ptr<{self._guard_class(guard)}> {name};",
                            f"ros::Subscriber {sub};"]
                setup += [f"// {spec.source} -> {spec.target}: a guarded relay reads the values it checks",
                          f"{pub} = nh_.advertise<{cpp_type(spec.type)}>({string(spec.target)}, kQueue);",
                          f"{name}.reset(new {self._guard_class(guard)}(nh_, {pub}));",
                          f"{sub} = nh_.subscribe<{cpp_type(spec.type)}>({string(spec.source)}, kQueue, "
                          f"[this](const {cpp_type(spec.type)}::ConstPtr& msg) {{ {name}->publish(*msg); }}, "
                          "ros::VoidConstPtr(), noDelay());"]
            elif isinstance(spec, planning.RelaySpec):
                self.types.add(spec.type)
                members.append(f"std::unique_ptr<ByteRelay> relay_{ident(spec.target)}_;")
                setup.append(f"relay_{ident(spec.target)}_.reset(ByteRelay::make<{cpp_type(spec.type)}>(nh_, "
                             f"{string(spec.source)}, {string(spec.target)}));")
            elif isinstance(spec, planning.ActionRelaySpec):
                package, stem = spec.type.split("/")
                parts = (("goal", f"{package}/{stem}ActionGoal", True), ("cancel", "actionlib_msgs/GoalID", True),
                         ("status", "actionlib_msgs/GoalStatusArray", False),
                         ("feedback", f"{package}/{stem}ActionFeedback", False),
                         ("result", f"{package}/{stem}ActionResult", False))
                setup.append(f"// the action {spec.target}: its five topics, goals and cancels in, the rest out")
                for part, type_name, inward in parts:
                    self.types.add(type_name)
                    source, target = f"{spec.source}/{part}", f"{spec.target}/{part}"
                    if inward:
                        source, target = target, source
                    members.append(f"std::unique_ptr<ByteRelay> relay_{ident(target)}_;")
                    setup.append(f"relay_{ident(target)}_.reset(ByteRelay::make<{cpp_type(type_name)}>(nh_, "
                                 f"{string(source)}, {string(target)}));")
            elif isinstance(spec, planning.SubscribeSpec):
                self.types.add(spec.type)
                method = self.script.names[spec.slot]
                members.append(f"ros::Subscriber sub_{method}_;")
                setup.append(f"sub_{method}_ = nh_.subscribe({string(spec.topic)}, kQueue, &{self._class()}::{method}, "
                             "this, noDelay());")
                methods.append(self._method(spec.slot, f"void {method}(const {cpp_type(spec.type)}::ConstPtr& msg)",
                                            "(void)msg;", f"each message on {spec.topic}"))
            elif isinstance(spec, planning.TimerSpec):
                method = self.script.names[spec.slot]
                members.append(f"ros::Timer timer_{method}_;")
                setup.append(f"timer_{method}_ = nh_.createTimer(ros::Duration({spec.period!r}), "
                             f"&{self._class()}::{method}, this, {'true' if spec.oneshot else 'false'});")
                methods.append(self._method(spec.slot, f"void {method}(const ros::TimerEvent& event)",
                                            "(void)event;", f"every {spec.period:g} s" if not spec.oneshot else
                                            f"once, {spec.period:g} s after start"))
            elif isinstance(spec, planning.ServiceSpec):
                self.types.add(spec.type)
                method = self.script.names[spec.slot]
                srv = cpp_type(spec.type)
                members.append(f"ros::ServiceServer srv_{method}_;")
                setup.append(f"srv_{method}_ = nh_.advertiseService({string(spec.name)}, &{self._class()}::{method}, "
                             "this);")
                methods.append(self._method(spec.slot, f"bool {method}({srv}::Request& request, {srv}::Response& "
                                                       "response)",
                                            "(void)request; (void)response;\n    return true;",
                                            f"each call of {spec.name}"))
            elif isinstance(spec, planning.ServiceRelaySpec):
                self.types.add(spec.type)
                srv = cpp_type(spec.type)
                member = f"srv_{ident(spec.target)}_"
                members.append(f"ros::ServiceServer {member};")
                setup.append(f"{member} = nh_.advertiseService<{srv}::Request, {srv}::Response>({string(spec.target)}, "
                             f"[source = std::string({string(spec.source)})]({srv}::Request& request, "
                             f"{srv}::Response& response) {{ return ros::service::call(source, request, response); "
                             "});")
            elif isinstance(spec, planning.ActionServerSpec):
                setup.append(f"// the action server {spec.name} ({spec.type}, handler "
                             f"{self.script.names[spec.slot]}) is not generated: see PORTING.md")
        params = self._params()
        self.types.update(self.finite.types)
        includes = sorted({f"#include <{t.split('/')[0]}/{t.split('/')[1]}.h>" for t in self.types})
        return _SOURCE.format(
            doc=self._doc(), includes="\n".join(includes), guards="\n\n".join(dict.fromkeys(guards)),
            finite=(self.finite.text() if self.finite.done else "") + (RULES_HELPERS if self.ruled else ""),
            cls=self._class(), setup=indent("\n".join(params[1] + setup), 4),
            members=indent("\n".join(params[0] + members), 2), methods=indent("\n\n".join(methods), 2),
            node=string(self.model.name), byte_relay=_BYTE_RELAY.strip("\n"))

    def _class(self) -> str:
        return "".join(part.title() for part in ident(self.model.name).split("_")) + "Node"

    def _doc(self) -> str:
        return (f"// {self.model.name}: a roscpp node exported by ipyros from the DSL node "
                f"{planning.node_fullname(self.model)}.\n// Its handlers are to be ported by hand: see PORTING.md.")

    def _params(self) -> tuple[list[str], list[str]]:
        """Members holding the node's parameters, and the lines that set (unless given) and read them."""
        members, setup = [], []
        for key, value in self.model.params.items():
            name = key.lstrip("~_")
            kind = {bool: "bool", int: "int", float: "double", str: "std::string"}.get(type(value))
            if kind is None:
                setup.append(f"// the parameter ~{name} ({type(value).__name__}): read it with "
                             f"pnh_.getParam(\"{name}\", value) into an XmlRpc::XmlRpcValue")
                continue
            literal = ("true" if value else "false") if kind == "bool" else \
                string(value) if kind == "std::string" else repr(value)
            member = f"param_{ident(name)}_"
            members.append(f"{kind} {member};")
            setup += [f"if (!pnh_.hasParam({string(name)})) pnh_.setParam({string(name)}, {kind}({literal}));",
                      f"pnh_.getParam({string(name)}, {member});"]
        return members, setup

    def _method(self, slot: str, signature: str, body: str, when: str) -> str:
        name = self.script.names[slot]
        source = self.script.bindings.functions.get(name, "")
        comment = "\n".join(f"  // {line}" if line else "  //" for line in source.rstrip("\n").splitlines())
        return (f"// Called {when}. To port from the Python handler {name}:\n{signature} {{\n{comment}\n"
                f"  {body}\n}}")

    # -- guards -------------------------------------------------------------------------------------
    def _guard_class(self, guard: Any) -> str:
        return "Guard_" + ident(guard.resolved)

    def _guard(self, guard: Any) -> str:
        """A class of its own for one guarded output: the checks written out for its message type."""
        cls = message_class(guard.type)
        cpp = cpp_type(guard.type)
        self.types.add(guard.type)
        self.finite.of(guard.type)
        limits, rates = [], []
        for path, (low, high) in guard.limits.items():
            limits.append(visit(cls, path, "m", lambda place, v, low=low, high=high: (
                f"if ({v} < {low!r} || {v} > {high!r}) {{ "
                + ("return false; }" if guard.on_limit == "drop" else
                   f"{v} = std::min(std::max({v}, _t<decltype({v})>({low!r})), _t<decltype({v})>({high!r})); }}"))))
        for path, most in guard.rate.items():
            rates.append(visit(cls, path, "m", lambda place, v, path=path, most=most: (
                f"{{ auto key = std::string({string(path)}) + \"#\" + std::to_string({place}); "
                f"auto last = last_.find(key); "
                f"if (last != last_.end()) {{ double step = {most!r} * (now - last->second.second).toSec(); "
                f"{v} = std::min(std::max(double({v}), last->second.first - step), last->second.first + step); }} "
                f"last_[key] = std::make_pair(double({v}), now); }}")))
        stop = "\n".join(f"    stop_.{field} = {value};" for field, value in _assignments(guard.stop or {}))
        if guard.estop_topic:  # std_msgs/Bool: true holds the stop message, whatever else arrives
            self.types.add("std_msgs/Bool")
            stop += (f"\n    estop_ = nh.subscribe<std_msgs::Bool>({string(guard.estop_topic)}, 10, "
                     "[this](const std_msgs::Bool::ConstPtr& msg) { std::lock_guard<std::mutex> lock(mutex_); "
                     "held_ = msg->data; });")
        timeout = "-1.0" if guard.timeout is None else repr(float(guard.timeout))
        ruled = CppRules(guard, self.script.topic_types) if guard.rules or guard.stale else None
        if ruled is not None:
            self.types |= ruled.types
            self.ruled = True
            stop += ("\n" if stop else "") + indent(ruled.setup(), 4)
        return _GUARD.format(cls=self._guard_class(guard), cpp=cpp, topic=guard.resolved,
                             limits=indent("\n".join(limits), 4) or "    // no limits", stop=stop,
                             rates=indent("\n".join(rates), 4) or "    // no rate limits", timeout=timeout,
                             period=repr(1.0 / guard.repeat), passes="check" if ruled is None else "pass",
                             rules_look="" if ruled is None else "\n    look(now.toSec());",
                             rules="" if ruled is None else "\n\n" + indent(ruled.methods(), 2) + "\n\n"
                             + indent(ruled.members(), 2))

    # -- PORTING.md ---------------------------------------------------------------------------------
    def porting(self, package: str) -> str:
        rows = []
        for spec in self.specs:
            slot = getattr(spec, "slot", None)
            if slot is None:
                continue
            fn = self.script.handlers[slot]
            name = self.script.names[slot]
            where = getattr(spec, "topic", None) or getattr(spec, "name", "")
            kind = type(spec).__name__.removesuffix("Spec").replace("ActionServer", "action server")
            reads = sorted(n for n in fn.__code__.co_names if n in getattr(fn, "__globals__", {})
                           and n not in self.script.writers)
            todo = "write an actionlib server (not generated)" if isinstance(spec, planning.ActionServerSpec) \
                else f"the method {name} of {self._class()}"
            rows.append(f"| `{name}` | {kind} | `{where}` | {', '.join(f'`{r}`' for r in reads) or '-'} | {todo} |")
        table = "\n".join(["| handler | kind | on | globals it reads | in the C++ |", "|---|---|---|---|---|", *rows]) \
            if rows else "No handlers: the node is all relays and declarations, nothing to port."
        return f"""# Porting {package} to C++

`src/{self.model.name}.cpp` was generated by ipyros from the DSL node `{planning.node_fullname(self.model)}`.
Its relays, publishers, subscribers, timers, services, parameters and guards are complete C++; each
Python handler is a method whose body is the handler's source as a comment, to be ported by hand.
Write to an output through its publisher member (a guarded one through its guard's `publish`).

{table}

Build it in a catkin workspace (`catkin_make`); `roslaunch {package} {self.model.name}.launch` starts it
(and, for a wrapping node, its basenode, remapped as ipyros ran it).
"""


class _Finite:
    """``finite(m)`` for a message type and every message type inside it: false if any float is NaN or infinite."""

    def __init__(self) -> None:
        self.done: dict[str, str] = {}
        self.types: set[str] = set()

    def of(self, type_name: str) -> None:
        if type_name in self.done:
            return
        self.done[type_name] = ""  # while it is written: a type may hold itself through an array
        self.types.add(type_name)
        cls = message_class(type_name)
        checks = []
        for field, slot_type in zip(cls.__slots__, cls._slot_types):
            base, array = slot_type.partition("[")[0], "[" in slot_type
            if base in _FLOATS:
                checks.append(f"  for (auto v : m.{field}) if (!std::isfinite(v)) return false;" if array else
                              f"  if (!std::isfinite(m.{field})) return false;")
            elif "/" in base or base == "Header":
                nested = "std_msgs/Header" if base == "Header" else base
                self.of(nested)
                checks.append(f"  for (const auto& e : m.{field}) if (!finite(e)) return false;" if array else
                              f"  if (!finite(m.{field})) return false;")
        self.done[type_name] = (f"inline bool finite(const {cpp_type(type_name)}& m) {{\n"
                                + "".join(line + "\n" for line in checks) + "  (void)m;\n  return true;\n}")

    def text(self) -> str:
        declared = "\n".join(f"inline bool finite(const {cpp_type(t)}& m);" for t in self.done)
        return declared + "\n" + "\n".join(self.done.values())


def _assignments(values: dict[str, Any], prefix: str = "") -> list[tuple[str, str]]:
    """``stop_.<field> = <value>`` pairs for a stop message given as (nested) fields."""
    out: list[tuple[str, str]] = []
    for key, value in values.items():
        if isinstance(value, dict):
            out += _assignments(value, f"{prefix}{key}.")
        elif isinstance(value, bool):
            out.append((prefix + key, "true" if value else "false"))
        elif isinstance(value, (int, float)):
            out.append((prefix + key, repr(value)))
        elif isinstance(value, str):
            out.append((prefix + key, string(value)))
        elif isinstance(value, (list, tuple)):
            out.append((prefix + key, "{" + ", ".join(string(v) if isinstance(v, str) else repr(v)
                                                       for v in value) + "}"))
    return out


_BYTE_RELAY = r'''
// Runs each callback in the thread its message arrived on (roscpp's network thread), not after a hand-off to the
// spinner's: a relay then forwards a message as soon as it is read, as the session's own relay does (the hand-off
// doubled a small message's latency through the relay).
class InlineQueue : public ros::CallbackQueueInterface {
 public:
  void addCallback(const ros::CallbackInterfacePtr& callback, uint64_t) override { callback->call(); }
  void removeByID(uint64_t) override {}
};

// Forwards a topic as bytes (no deserialising): advertised up front with its declared type, so that
// subscribers connect before the first message; latched once a latched message arrives, as the source is.
class ByteRelay {
 public:
  template <class M>
  static ByteRelay* make(ros::NodeHandle& nh, const std::string& source, const std::string& target) {
    auto* relay = new ByteRelay(nh, target);
    relay->advertise_ = [relay, target](bool latch) {
      relay->pub_ = relay->nh_.advertise<M>(target, kQueue, latch);
    };
    relay->advertise_(false);
    static InlineQueue inline_queue;
    ros::NodeHandle inline_nh(nh);
    inline_nh.setCallbackQueue(&inline_queue);
    relay->sub_ = inline_nh.subscribe(source, kQueue, &ByteRelay::forward, relay, noDelay());
    return relay;
  }

 private:
  ByteRelay(ros::NodeHandle& nh, const std::string& target) : nh_(nh), target_(target) {}

  void forward(const ros::MessageEvent<topic_tools::ShapeShifter const>& event) {
    const auto& header = event.getConnectionHeader();
    auto latching = header.find("latching");
    if (!latched_ && latching != header.end() && latching->second == "1") {
      latched_ = true;
      advertise_(true);
    }
    pub_.publish(event.getConstMessage());
  }

  ros::NodeHandle nh_;
  std::string target_;
  std::function<void(bool)> advertise_;
  ros::Publisher pub_;
  ros::Subscriber sub_;
  bool latched_ = false;
};
'''

_GUARD = """\
// The guard on {topic}: every message that leaves on it passes here. NaN or an infinity anywhere:
// the stop message goes instead; limits clamp (or drop); rate limits bound the change a second; after
// the timeout with nothing passed, or while its e-stop topic says true, the stop message at its rate,
// on a steady timer (not the ROS clock).
class {cls} {{
 public:
  {cls}(ros::NodeHandle& nh, ros::Publisher pub) : pub_(pub), passed_(ros::SteadyTime::now()) {{
{stop}
    watch_ = nh.createSteadyTimer(ros::WallDuration(0.01), &{cls}::watch, this);
  }}

  void publish(const {cpp}& in) {{
    std::lock_guard<std::mutex> lock(mutex_);
    {cpp} m = in;
    if (held_ || !finite(m)) {{
      m = stop_;
    }} else if (!{passes}(m)) {{
      return;  // dropped: a value outside its limits (or, with rules, before their inputs are heard)
    }}
    passed_ = ros::SteadyTime::now();
    pub_.publish(m);
  }}

 private:
  bool check({cpp}& m) {{
{limits}
    ros::SteadyTime now = ros::SteadyTime::now();
    (void)now;
{rates}
    return true;
  }}

  void watch(const ros::SteadyTimerEvent&) {{
    std::lock_guard<std::mutex> lock(mutex_);
    ros::SteadyTime now = ros::SteadyTime::now();{rules_look}
    bool silent = timeout_ > 0 && (now - passed_).toSec() >= timeout_;
    if (!(silent || held_) || (now - stopped_).toSec() < period_) return;
    pub_.publish(stop_);
    stopped_ = now;
    last_.clear();  // a rate-limited field starts again from the stop message
  }}

  ros::Publisher pub_;
  {cpp} stop_;
  std::mutex mutex_;
  ros::SteadyTime passed_, stopped_;
  ros::SteadyTimer watch_;
  ros::Subscriber estop_;
  bool held_ = false;  // an e-stop holds the stop message
  std::map<std::string, std::pair<double, ros::SteadyTime>> last_;
  const double timeout_ = {timeout};
  const double period_ = {period};{rules}
}};"""

_SOURCE = """\
{doc}
#include <ros/callback_queue_interface.h>
#include <ros/ros.h>
#include <topic_tools/shape_shifter.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <stdexcept>
#include <string>
#include <type_traits>
#include <vector>

{includes}

template <class T>
using _t = std::remove_cv_t<std::remove_reference_t<T>>;  // a field's own type, to clamp it in

// As the session's endpoints: a burst is queued, not dropped at roscpp's usual 10 (0: no bound, as the
// session's rospy queues; give a number to bound memory under a sustained overload, and lose messages then),
// and small messages go out at once (TCP_NODELAY asked of every publisher this node subscribes to).
constexpr uint32_t kQueue = 0;
inline ros::TransportHints noDelay() {{ return ros::TransportHints().tcpNoDelay(); }}

{byte_relay}

{finite}

{guards}

class {cls} {{
 public:
  {cls}() : pnh_("~") {{
{setup}
  }}

 private:
{methods}

  ros::NodeHandle nh_, pnh_;
{members}
}};

int main(int argc, char** argv) {{
  ros::init(argc, argv, {node});
  {cls} node;
  ros::spin();
  return 0;
}}
"""
