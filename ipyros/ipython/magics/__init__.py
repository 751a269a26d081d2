"""The IPython face of ipyros: one ``Magics`` class per concern.

* :class:`RosMagics` (``config.py``): the settings, ``%config RosMagics``;
* :class:`TopicMagics` (``graph.py``): ``%topics``, ``%echo``, ``%pub``;
* :class:`RateMagics` (``rates.py``): ``%hz``, ``%bw``, ``%delay``, measured until Ctrl-C;
* :class:`IntrospectMagics` (``introspect.py``): ``%services``, ``%call``, ``%params``, ``%param``,
  ``%nodes``, ``%node``;
* :class:`ActionMagics` (``actions.py``): ``%actions``, ``%action`` (a goal with live feedback, or --watch);
* :class:`NodeMagics` (``nodes.py``): ``%handler``, ``%%handler``, ``%try``, ``%status``, ``%export``;
* :class:`WrapMagics` (``wrap.py``): ``%wrap``;
* :class:`DemoMagics` (``demo.py``): ``%demo``, the demo robot;
* :class:`PlotMagics` (``plot.py``): ``%plot``, topic fields drawn live;
* :class:`RecordMagics` (``record.py``): ``%record``, topics written to a bag;
* :class:`SafetyMagics` (``safety.py``): ``%estop``, the session's guards held at their stop message;
* :class:`MachineMagics` (``machines.py``): ``%machines``, the robots' keepers the session sees;
* :class:`AgentMagics` (``agent.py``): ``%mcp``, an AI agent's server, its requests approved or denied here;
* :class:`DrawingMagics` (``drawing.py``): ``%graph``, the live graph drawn as the paper draws wrapping.

:mod:`ipyros.ipython.extension` creates and registers them; ``%magic?`` shows each one's help.
"""

from .actions import ActionMagics
from .agent import AgentMagics
from .config import RosMagics
from .demo import DemoMagics
from .drawing import DrawingMagics
from .graph import TopicMagics
from .machines import MachineMagics
from .introspect import IntrospectMagics
from .nodes import NodeMagics
from .plot import PlotMagics
from .rates import RateMagics
from .record import RecordMagics
from .safety import SafetyMagics
from .wrap import WrapMagics

__all__ = ["RosMagics", "TopicMagics", "NodeMagics", "WrapMagics", "DemoMagics", "PlotMagics", "RecordMagics",
           "RateMagics", "IntrospectMagics", "ActionMagics", "SafetyMagics", "MachineMagics",
           "AgentMagics", "DrawingMagics"]
