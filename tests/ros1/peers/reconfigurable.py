#!/usr/bin/python3
"""Test peer: a dynamic_reconfigure server (dynamic_reconfigure's own TestConfig) as node NAME.

usage: reconfigurable.py NAME
Prints "ready" once it serves, and "reconfigured int_=N double_=X" each time it is reconfigured.
"""
import signal
import sys

import rospy
from dynamic_reconfigure.cfg import TestConfig
from dynamic_reconfigure.server import Server

from ipyros.demo.demonode import rospy_node  # ends at once when asked


def reconfigured(config, level):
    print(f"reconfigured int_={config['int_']} double_={config['double_']}", flush=True)
    return config


rospy_node(sys.argv[1], disable_signals=True)
signal.signal(signal.SIGTERM, lambda *_: rospy.signal_shutdown("stopped by the test"))
server = Server(TestConfig, reconfigured)
print("ready", flush=True)
rospy.spin()
