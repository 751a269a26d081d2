"""Peer: a basenode that publishes a type a session may lack (test_msgs/msg/Builtins on ``odd``) beside a
std_msgs/String (``plain``) and subscribes to ``plain_in``. Spins until Ctrl-C."""
import sys
from pathlib import Path

import ipyros

sys.path.insert(0, str(Path(ipyros.__file__).resolve().parent / "demo"))
from demonode import DemoNode  # noqa: E402
from std_msgs.msg import String  # noqa: E402
from test_msgs.msg import Builtins  # noqa: E402

node = DemoNode("custom_types")
odd, plain = node.publisher("odd", Builtins), node.publisher("plain", String)
node.subscribe("plain_in", String, lambda msg: None)
print("custom_types ready", flush=True)
node.run(5.0, lambda: (odd.publish(Builtins()), plain.publish(String(data="plain"))))
