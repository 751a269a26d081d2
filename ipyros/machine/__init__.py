"""The keeper of a robot's machine: ``python -m ipyros.machine --name robot1``.

Run it on the robot's own computer, beside its ROS (a ROS 1 master there, or a ROS 2 domain the laptop shares): a
session on a laptop then places guards on it (``nd.guard(topic, ..., machine="robot1")``), which the robot keeps
even when the link to the laptop is lost, and basenodes of the packages it allows (``.machine("robot1")``). It needs ROS and ipyros's ROS-free parts, not IPython. See
:mod:`ipyros.processes.keeper` for what it does and how a session talks to it.
"""

from __future__ import annotations

import argparse
import importlib.util
import os
import sys
from pathlib import Path
from typing import Optional

__all__ = ["main"]


def _parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="python -m ipyros.machine",
                                     description="Keep what ipyros sessions place on this machine: guards, and "
                                                 "basenodes of the packages it allows.")
    parser.add_argument("--name", required=True, help="this machine's name, as sessions place on it (e.g. robot1)")
    parser.add_argument("--allow", action="append", default=[], metavar="PACKAGE",
                        help="a package whose executables sessions may start here as basenodes (again for more); "
                             "none by default")
    parser.add_argument("--discovery-server", type=int, default=None, metavar="PORT",
                        help="ROS 2: run a Fast DDS discovery server here on PORT, for networks where multicast does "
                             "not carry discovery (sessions set ROS_DISCOVERY_SERVER=THIS_MACHINE:PORT)")
    parser.add_argument("--token-file", type=Path, default=None,
                        help="the token's file (default ~/.ros/ipyros/machines/NAME.token, made at the first start)")
    return parser


def main(argv: Optional[list[str]] = None) -> int:
    args = _parser().parse_args(argv)
    from ..core.errors import IpyrosError
    from ..core.names import check_package_name
    from ..processes.keeper import check_machine_name

    try:
        check_machine_name(args.name)
        for package in args.allow:
            check_package_name(package)
    except IpyrosError as error:
        print(f"ipyros machine: {error}", file=sys.stderr)
        return 2
    wanted = os.environ.get("IPYROS_ROS") or os.environ.get("ROS_VERSION") or ""
    if not wanted:
        wanted = "1" if importlib.util.find_spec("rospy") is not None else "2"
    port = args.discovery_server
    if port is not None and not 0 < port < 65536:
        print(f"ipyros machine: --discovery-server {port}: give a UDP port (1 to 65535; 11811 is Fast DDS's)",
              file=sys.stderr)
        return 2
    if wanted == "1":
        if port is not None:
            print("ipyros machine: --discovery-server is ROS 2's; ROS 1 finds nodes through its master: leave it out",
                  file=sys.stderr)
            return 2
        from ..ros1.machine import main as run1
        return run1(args.name, args.token_file, frozenset(args.allow))
    from ..ros2.machine import main as run2
    return run2(args.name, args.token_file, frozenset(args.allow), port)
