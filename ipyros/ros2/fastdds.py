"""Fast DDS as an ipyros session runs it: a profile of ipyros's own, unless the user has one.

Two defaults of Fast DDS (the only middleware of the PyPI wheels) hurt a session:

* its shared-memory segment is 512 KiB, so a camera image or a point cloud leaves shared
  memory and goes fragmented over UDP: 13 ms for 1 MiB between two processes on one
  machine, where a 64 MiB segment takes 2.3 ms (measured with the wheels' Fast DDS 3.2; a
  best-effort 1 MiB topic delivered nothing at all with the default);
* with ``ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST`` its participants still receive on every
  interface (``0.0.0.0``): discovery is kept to the machine, the sockets are not.

So a session writes a profile of its own and points ``FASTDDS_DEFAULT_PROFILES_FILE`` at
it before rclpy starts: a shared-memory transport with :data:`SEGMENT` bytes, and UDPv4
(for peers on other machines, and as Fast DDS's fallback), restricted to the loopback
interface when the session is local. The processes ipyros starts (basenodes, bag players,
the demo robot) inherit the environment, and so the profile. A user who configured Fast DDS
(a profile file, builtin transports, another middleware) is left alone, and the load line
says which applies.

Discovery kept to this machine is the profile's too. rmw_fastrtps's own ``LOCALHOST`` range adds
two transports of its own to whatever the profile gives (its ``create_participant``: a shared memory
of Fast DDS's default size and a UDPv4 transport with no interface list), and that UDPv4 transport
opens its sending sockets on ``0.0.0.0`` and on every interface's address (the machine's LAN
address among them), where anyone on the network can send to them. So a local session's profile
says what ``LOCALHOST`` means itself (discovery on loopback: a unicast locator on ``127.0.0.1``,
``127.0.0.1`` as the initial peer, 32 participants to try there, no multicast) and the session and
what it starts run with ``ROS_AUTOMATIC_DISCOVERY_RANGE=SYSTEM_DEFAULT``, under which rmw adds
nothing: every socket is then on loopback (tested), and the nodes still find, and are found by,
the other ``LOCALHOST`` nodes of the machine. What the user asked for is kept in
``IPYROS_DISCOVERY_RANGE`` (the load line says it; :func:`local` reads it).

Fast DDS frees its shared memory when a participant is deleted; a process that is killed
(SIGKILL, a crash) leaves its files in ``/dev/shm``, a port's lock still taken. A new
participant given that port is then never seen by the others (its node does not show up
in the graph). So a session removes, before it starts, the Fast DDS files that no living
process uses (:func:`remove_stale_files`).
"""

from __future__ import annotations

import hashlib
import os
from pathlib import Path
from typing import Optional

__all__ = ["DEFAULT_SEGMENT", "HELD_RANGE", "SEGMENT", "USER_SETTINGS", "discovery_range", "environment", "local",
           "prepare", "profile_xml", "remove_stale_files", "size_note", "write_profile"]

#: The shared-memory segment of each participant: room for a few 16 MiB point clouds in flight.
SEGMENT = 64 * 1024 * 1024

#: Fast DDS's own shared-memory segment (a process with its defaults): larger messages leave shared memory.
DEFAULT_SEGMENT = 512 * 1024

#: What a user sets to configure Fast DDS themselves; any of them means "leave it alone".
USER_SETTINGS = ("FASTDDS_DEFAULT_PROFILES_FILE", "FASTRTPS_DEFAULT_PROFILES_FILE", "FASTDDS_BUILTIN_TRANSPORTS",
                 "RMW_FASTRTPS_USE_QOS_FROM_XML", "ROS_DISCOVERY_SERVER")

_MARK = "ipyros-profile"  # in the file's name: a profile of ipyros's, not the user's


#: Where a session keeps the discovery range the user asked for, when its profile does what the range said.
HELD_RANGE = "IPYROS_DISCOVERY_RANGE"


def discovery_range() -> str:
    """The discovery range the user asked for: ``LOCALHOST``, ``SUBNET``, ``OFF`` or ``SYSTEM_DEFAULT``."""
    return (os.environ.get(HELD_RANGE) or os.environ.get("ROS_AUTOMATIC_DISCOVERY_RANGE", "").upper()
            or ("LOCALHOST" if os.environ.get("ROS_LOCALHOST_ONLY") == "1" else "SUBNET"))


def local() -> bool:
    """Whether discovery is kept to this machine (``ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST``, or the older
    ``ROS_LOCALHOST_ONLY=1``)."""
    return discovery_range() == "LOCALHOST"


def environment(loopback_only: bool, folder: Optional[Path] = None) -> dict[str, str]:
    """The variables a process needs to run with ipyros's profile (empty if it cannot be written): the profile's
    file and, for a local one, the discovery range that lets the profile alone decide (see the module's docstring)."""
    path = write_profile(loopback_only, folder)
    if path is None:
        return {}
    if not loopback_only:
        return {"FASTDDS_DEFAULT_PROFILES_FILE": str(path)}
    return {"FASTDDS_DEFAULT_PROFILES_FILE": str(path), "ROS_AUTOMATIC_DISCOVERY_RANGE": "SYSTEM_DEFAULT",
            HELD_RANGE: "LOCALHOST"}


def profile_xml(loopback_only: bool) -> str:
    """The Fast DDS XML profile: shared memory of :data:`SEGMENT` bytes, and UDPv4 (on ``lo`` alone, and discovery
    on loopback, if asked)."""
    interfaces = ("\n        <interfaces><allowlist><interface name=\"lo\"/></allowlist></interfaces>"
                  "\n        <maxInitialPeersRange>32</maxInitialPeersRange>" if loopback_only else "")
    loopback = "<locator><udpv4><address>127.0.0.1</address></udpv4></locator>"
    discovery = (f"""
        <builtin>
          <metatrafficUnicastLocatorList>{loopback}</metatrafficUnicastLocatorList>
          <initialPeersList>{loopback}</initialPeersList>
        </builtin>""" if loopback_only else "")
    return f"""<?xml version="1.0" encoding="UTF-8"?>
<!-- Written by ipyros for its session and the processes it starts (see ipyros/ros2/fastdds.py).
     Set FASTDDS_DEFAULT_PROFILES_FILE to a profile of your own to use that instead. -->
<dds xmlns="http://www.eprosima.com">
  <profiles>
    <transport_descriptors>
      <transport_descriptor>
        <transport_id>ipyros_shm</transport_id>
        <type>SHM</type>
        <segment_size>{SEGMENT}</segment_size>
      </transport_descriptor>
      <transport_descriptor>
        <transport_id>ipyros_udp</transport_id>
        <type>UDPv4</type>{interfaces}
      </transport_descriptor>
    </transport_descriptors>
    <participant profile_name="ipyros" is_default_profile="true">
      <rtps>{discovery}
        <userTransports>
          <transport_id>ipyros_shm</transport_id>
          <transport_id>ipyros_udp</transport_id>
        </userTransports>
        <useBuiltinTransports>false</useBuiltinTransports>
      </rtps>
    </participant>
  </profiles>
</dds>
"""


def prepare() -> str:
    """Point Fast DDS at ipyros's profile, unless the user configured it; say which applies, in words.

    Called before rclpy starts in this process; the environment it sets is inherited by every
    process ipyros starts after it.
    """
    rmw = os.environ.get("RMW_IMPLEMENTATION", "rmw_fastrtps_cpp")
    if rmw != "rmw_fastrtps_cpp":
        return f"{rmw} as configured"
    mine = os.environ.get("FASTDDS_DEFAULT_PROFILES_FILE", "")
    if _MARK in Path(mine).name:  # set by this session (or the one that started this process): keep it
        return _describe(mine)
    given = next((f"{name}={os.environ[name]}" for name in USER_SETTINGS if os.environ.get(name)), None)
    if given is not None:
        if os.environ.get("ROS_DISCOVERY_SERVER") and not os.environ.get("ROS_SUPER_CLIENT"):
            os.environ["ROS_SUPER_CLIENT"] = "TRUE"  # a plain client sees only what it subscribes to: no graph
        return f"Fast DDS as you configured it ({given}; {discovery_words()})"
    # Static peers are added by rmw for its own ranges only: with them, its LOCALHOST stays as it is.
    variables = environment(loopback_only=local() and not os.environ.get("ROS_STATIC_PEERS"))
    if not variables:
        return "Fast DDS's defaults (ipyros could not write its profile)"
    if HELD_RANGE in variables:
        os.environ.pop("ROS_LOCALHOST_ONLY", None)  # said by IPYROS_DISCOVERY_RANGE now
    os.environ.update(variables)
    return _describe(variables["FASTDDS_DEFAULT_PROFILES_FILE"])


def size_note(size: float) -> Optional[str]:
    """One line for a topic whose messages are ``size`` bytes, if that is more than Fast DDS's defaults carry in
    shared memory: where it goes instead, what that costs, and how to give the publisher ipyros's profile."""
    if size <= DEFAULT_SEGMENT:
        return None
    mine = os.environ.get("FASTDDS_DEFAULT_PROFILES_FILE", "")
    fix = (f"start the publisher with FASTDDS_DEFAULT_PROFILES_FILE={mine} (ipyros's profile, which the processes "
           "ipyros starts have)" if _MARK in Path(mine).name else
           f"give the publisher a Fast DDS profile whose shared-memory segment holds a few messages (ipyros's has "
           f"{SEGMENT >> 20} MiB: ipyros/ros2/fastdds.py)")
    return (f"messages over {DEFAULT_SEGMENT >> 10} KiB leave Fast DDS's default shared memory: from a publisher "
            f"with the defaults they go fragmented over UDP (about 5x slower; best-effort ones can be lost); {fix}")


def _describe(path: str) -> str:
    where = "UDP on loopback only" if "loopback" in Path(path).name else "UDP on every interface"
    return (f"Fast DDS with ipyros's profile (shared memory up to {SEGMENT >> 20} MiB, {where}, {discovery_words()}; "
            f"{path})")


def discovery_words() -> str:
    """How this session finds its peers, in words for the load line: a robot on another machine is found only if
    discovery reaches it."""
    server = os.environ.get("ROS_DISCOVERY_SERVER")
    if server:
        return f"discovery through the server at {server} (as a super client: the whole graph)"
    peers = os.environ.get("ROS_STATIC_PEERS")
    if local():
        return "discovery on this machine only" + (f", and the static peers {peers}" if peers else "") + \
            " (ROS_AUTOMATIC_DISCOVERY_RANGE=SUBNET reaches other machines)"
    if discovery_range() == "OFF":
        return "discovery off" + (f" but for the static peers {peers}" if peers else "")
    return "discovery on the subnet (multicast)" + (f" and the static peers {peers}" if peers else "")


def write_profile(loopback_only: bool, folder: Optional[Path] = None) -> Optional[Path]:
    """ipyros's profile in a file (``$ROS_HOME/ipyros`` unless ``folder`` is given), named by its content
    so that sessions share one and never race; None if it cannot be written."""
    text = profile_xml(loopback_only)
    folder = folder or Path(os.environ.get("ROS_HOME") or Path.home() / ".ros").expanduser() / "ipyros"
    path = folder / f"{_MARK}-{'loopback' if loopback_only else 'any'}-{hashlib.sha1(text.encode()).hexdigest()[:10]}.xml"
    try:
        if not path.exists():
            folder.mkdir(parents=True, exist_ok=True)
            partial = path.with_suffix(f".{os.getpid()}.tmp")
            partial.write_text(text, encoding="utf-8")
            os.replace(partial, path)
    except OSError:
        return None
    return path


SHM = Path("/dev/shm")


def _in_use() -> set[str]:
    """The names of the files of /dev/shm that a living process has mapped or open (those this user may see)."""
    used: set[str] = set()
    for proc in Path("/proc").iterdir():
        if not proc.name.isdigit():
            continue
        try:
            used.update(line.split()[-1].rsplit("/", 1)[-1] for line in (proc / "maps").read_text().splitlines()
                        if "/dev/shm/" in line)
            fds = list((proc / "fd").iterdir())
        except OSError:  # gone meanwhile, or another user's (whose files this user cannot remove either)
            continue
        for fd in fds:
            try:
                target = os.readlink(fd)
            except OSError:  # closed meanwhile (the listing's own descriptor, for one)
                continue
            if target.startswith("/dev/shm/"):
                used.add(target.rsplit("/", 1)[-1])
    return used


def remove_stale_files(names: "Optional[set[str]]" = None, shm: Path = SHM) -> list[str]:
    """Remove the Fast DDS files of ``shm`` (or those of ``names``) that no living process uses; return their names."""
    if not shm.is_dir():
        return []
    candidates = {p.name for p in shm.iterdir() if "fastdds" in p.name} if names is None else set(names)
    removed = []
    for name in sorted(candidates - _in_use()):
        try:
            (shm / name).unlink()
            removed.append(name)
        except OSError:  # another user's, or removed meanwhile
            continue
    return removed
