"""``RosMagics``: the extension's settings, as traitlets configuration.

Every setting can live in ``ipython_config.py``::

    c.RosMagics.master_uri = "http://robot:11311/"
    c.RosMagics.start_master = False

or be read and changed at the prompt with ``%config``::

    %config RosMagics                      # lists them with their help
    %config RosMagics.hz_window = 2.0

IPython only offers ``%config`` for configurables with ``config=True`` traits, and every
``Magics`` instance registers itself as one, so the settings live on a ``Magics`` class
of their own; the magics that use them (``%topics``, ``%handler``, ...) are in the
modules next to this one and read them from here at each call. Settings that act on
something already running (the graph refresh period, the log level, the master before
it is attached) are applied when they change by :mod:`ipyros.ipython.extension`.
"""

from __future__ import annotations

import urllib.parse

from IPython.core.magic import Magics, magics_class
from traitlets import Bool, CaselessStrEnum, Float, Int, TraitError, Unicode, validate

from ...core.errors import IpyrosError
from ...core.names import check_namespace, check_node_name


@magics_class
class RosMagics(Magics):
    """Settings of the ipyros extension (``%load_ext ipyros``)."""

    ros = Int(
        0,
        help="Which ROS this session runs on: 1 (rospy) or 2 (rclpy); 0: IPYROS_ROS, else ROS_VERSION, else "
             "what is importable. Read when the session starts (at %load_ext, or the first rosNode).",
    ).tag(config=True)

    master_uri = Unicode(
        "",
        help="URI of the ROS master to use, e.g. http://localhost:11311/. Empty: ROS_MASTER_URI, "
             "else http://localhost:11311/. Fixed once the first node is created.",
    ).tag(config=True)

    start_master = Bool(
        True,
        help="Start a ROS master (rosmaster --core and rosout) on this machine when none answers at "
             "master_uri; it stops when the IPython session exits.",
    ).tag(config=True)

    process_node_name = Unicode(
        "",
        help="Name of this session's ROS node, which hosts every rosNode of the session (rospy allows one "
             "node per process). Empty: the first rosNode created names it.",
    ).tag(config=True)

    graph_period = Float(
        1.0,
        help="Seconds between background refreshes of the cached ROS graph that tab completion reads. "
             "%topics always reads the master afresh.",
    ).tag(config=True)

    log_level = CaselessStrEnum(
        ["DEBUG", "INFO", "WARNING", "ERROR"],
        default_value="WARNING",
        help="Level of ipyros's own log messages (logger 'ipyros'), printed on stderr.",
    ).tag(config=True)

    handler_tracebacks = Bool(
        True,
        help="When a handler raises, print its full traceback; False prints one line per failure.",
    ).tag(config=True)

    echo_count = Int(
        0,
        help="How many messages %echo shows when -n is not given; 0 means until Ctrl-C.",
    ).tag(config=True)

    hz_window = Float(
        1.0,
        help="Seconds %topics --hz listens to measure message rates.",
    ).tag(config=True)

    try_history = Int(
        20,
        help="How many of the last messages each subscription of a node keeps, for %try.",
    ).tag(config=True)

    restart_basenodes = Bool(
        False,
        help="When the ROS master restarts, restart the basenodes that do not register with it again "
             "(rospy and roscpp nodes do not); False only reports them, with the line that restarts them.",
    ).tag(config=True)

    freeze_gc = Bool(
        True,
        help="Once the session has loaded, take what it loaded out of Python's full garbage collections "
             "(gc.freeze): each walked every object for 70-105 ms and stalled a TAB; undone at unload. "
             "Set before %load_ext ipyros; False keeps Python's default.",
    ).tag(config=True)

    rich_output = Bool(
        True,
        help="Render tables and messages with rich: colour in a terminal, HTML in Jupyter. "
             "False prints plain text. Either way there is no colour when output is not a terminal.",
    ).tag(config=True)

    # Bounds: a value out of them is refused where it is set, not ignored later. The upper
    # ones keep a typo from freezing the prompt (%topics --hz waiting an hour) or filling memory.
    _seconds = {"graph_period": (0.05, 3600.0), "hz_window": (0.05, 600.0)}
    _counts = {"echo_count": 1_000_000, "try_history": 10_000}

    @validate("graph_period", "hz_window")
    def _seconds_in_range(self, proposal):
        low, high = self._seconds[proposal.trait.name]
        if not low <= proposal.value <= high:  # NaN fails this too
            raise TraitError(f"{proposal.trait.name} must be from {low:g} to {high:g} seconds, not {proposal.value}")
        return proposal.value

    @validate("echo_count", "try_history")
    def _count_in_range(self, proposal):
        high = self._counts[proposal.trait.name]
        if not 0 <= proposal.value <= high:
            raise TraitError(f"{proposal.trait.name} must be from 0 to {high:,}, not {proposal.value}")
        return proposal.value

    @validate("ros")
    def _ros(self, proposal):
        if proposal.value not in (0, 1, 2):
            raise TraitError(f"ros must be 1 (ROS 1), 2 (ROS 2) or 0 (found by itself), not {proposal.value}")
        return proposal.value

    @validate("master_uri")
    def _master_uri(self, proposal):
        uri = proposal.value.strip()
        if uri:
            parts = urllib.parse.urlsplit(uri)
            try:
                port = parts.port
            except ValueError:
                port = None
            if parts.scheme not in ("http", "https") or not parts.hostname or port is None:
                raise TraitError(f"master_uri {uri!r} is not a ROS master URI; write it like "
                                 "'http://localhost:11311/' (or '' for ROS_MASTER_URI)")
        return uri

    @validate("process_node_name")
    def _process_node_name(self, proposal):
        name = proposal.value.strip()
        if name:
            namespace, _, base = ("/" + name.strip("/")).rpartition("/")
            try:
                check_namespace(namespace or "/")
                check_node_name(base)
            except IpyrosError as error:
                raise TraitError(f"process_node_name {name!r}: {error}") from None
        return name
