"""A ROS node that advertises many topics, for graph and completion tests and benchmarks.

    python many_topics.py NODE_NAME COUNT [--prefix /bench/t] [--type std_msgs/String] [--nodes N]
                          [--topics /a/b=geometry_msgs/Twist ...] [--subscribe /some/topic ...]

Publishes nothing; it only registers ``COUNT`` publishers named ``PREFIX0000`` ...
(one rospy node can hold thousands of Publishers), publishers for the ``--topics``
given as NAME=TYPE, and subscriptions on the topics given with ``--subscribe``. Prints ``ready`` on stdout once every registration is
done, then spins until SIGINT/SIGTERM, on which rospy unregisters from the master.

``--nodes N`` deals the ``COUNT`` publishers out to N nodes, as a robot's graph has them: rospy allows one
node a process, so this process registers them with the master under the names ``NODE_NAME_000`` ...
itself (the master's ``registerPublisher``, with this node's URI), and takes them back at exit. What the
master then says of its graph (``getSystemState``) is that of N nodes, which is all a graph reader sees.
"""

import argparse
import importlib
import sys

import rosgraph
import rospy


def message_class(type_name: str) -> type:
    package, name = type_name.split("/")
    return getattr(importlib.import_module(f"{package}.msg"), name)


def register_for_nodes(base: str, nodes: int, topics: list[str], type_name: str) -> None:
    """Register ``topics`` with the master as published by ``nodes`` nodes named after ``base``, dealt out in
    turn, in one XML-RPC multicall (the master takes them); they are unregistered the same way at shutdown."""
    from xmlrpc.client import MultiCall, ServerProxy

    master, uri = ServerProxy(rosgraph.get_master_uri()), rospy.get_node_uri()
    width = max(3, len(str(nodes - 1)))
    owned = [(f"{base}_{i % nodes:0{width}d}", topic) for i, topic in enumerate(topics)]

    def each(method: str, *extra: str) -> None:
        calls = MultiCall(master)
        for caller, topic in owned:
            getattr(calls, method)(caller, topic, *extra)
        for code, message, _ in calls():
            if code != 1:
                raise RuntimeError(f"{method}: {message}")

    each("registerPublisher", type_name, uri)

    def unregister() -> None:
        try:
            each("unregisterPublisher", uri)
        except OSError:  # the master went first
            pass

    rospy.on_shutdown(unregister)


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("node")
    parser.add_argument("count", type=int)
    parser.add_argument("--prefix", default="/many/t")
    parser.add_argument("--type", default="std_msgs/String")
    parser.add_argument("--topics", nargs="*", default=[], metavar="NAME=TYPE")
    parser.add_argument("--subscribe", nargs="*", default=[])
    parser.add_argument("--nodes", type=int, default=1)
    args = parser.parse_args(rospy.myargv()[1:])

    rospy.init_node(args.node, anonymous=False, disable_signals=False)
    cls = message_class(args.type)
    width = max(4, len(str(args.count - 1)))
    names = [f"{args.prefix}{i:0{width}d}" for i in range(args.count)]
    if args.nodes > 1:
        register_for_nodes(rospy.get_name(), args.nodes, names, args.type)
        names = []
    # Held until exit: the registrations are the whole point of this node.
    keep = [rospy.Publisher(name, cls, queue_size=1) for name in names]
    for spec in args.topics:
        name, _, type_name = spec.partition("=")
        keep.append(rospy.Publisher(name, message_class(type_name), queue_size=1))
    keep += [rospy.Subscriber(name, rospy.AnyMsg, lambda _msg: None) for name in args.subscribe]
    print("ready", flush=True)
    rospy.spin()


if __name__ == "__main__":
    sys.exit(main())
