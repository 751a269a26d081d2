"""A ROS node that advertises many topics, for graph and completion tests and benchmarks.

    python many_topics.py NODE_NAME COUNT [--prefix /bench/t] [--type std_msgs/String]
                          [--topics /a/b=geometry_msgs/Twist ...] [--subscribe /some/topic ...]

Publishes nothing; it only registers ``COUNT`` publishers named ``PREFIX0000`` ...
(one rospy node can hold thousands of Publishers), publishers for the ``--topics``
given as NAME=TYPE, and subscriptions on the topics given with ``--subscribe``. Prints ``ready`` on stdout once every registration is
done, then spins until SIGINT/SIGTERM, on which rospy unregisters from the master.
"""

import argparse
import importlib
import sys

import rospy


def message_class(type_name: str) -> type:
    package, name = type_name.split("/")
    return getattr(importlib.import_module(f"{package}.msg"), name)


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("node")
    parser.add_argument("count", type=int)
    parser.add_argument("--prefix", default="/many/t")
    parser.add_argument("--type", default="std_msgs/String")
    parser.add_argument("--topics", nargs="*", default=[], metavar="NAME=TYPE")
    parser.add_argument("--subscribe", nargs="*", default=[])
    args = parser.parse_args(rospy.myargv()[1:])

    rospy.init_node(args.node, anonymous=False, disable_signals=False)
    cls = message_class(args.type)
    width = max(4, len(str(args.count - 1)))
    # Held until exit: the registrations are the whole point of this node.
    keep = [rospy.Publisher(f"{args.prefix}{i:0{width}d}", cls, queue_size=1) for i in range(args.count)]
    for spec in args.topics:
        name, _, type_name = spec.partition("=")
        keep.append(rospy.Publisher(name, message_class(type_name), queue_size=1))
    keep += [rospy.Subscriber(name, rospy.AnyMsg, lambda _msg: None) for name in args.subscribe]
    print("ready", flush=True)
    rospy.spin()


if __name__ == "__main__":
    sys.exit(main())
