"""Files: how a node's work is written down and read back, as formats of plain data and code.

- :mod:`.savefile`: nodes as runnable Python (the DSL as a person would type it);
- :mod:`.modelfile`: a node as YAML or JSON (its model and its handlers' sources), and
  what such a file may run only with trust;
- :mod:`.export`: a node as a script or ROS package that needs no ipyros;
- :mod:`.atomic`: files written whole or not at all; :mod:`.kept`: what these need of a node.

May import: core. The DSL (:mod:`ipyros.dsl.keeping`) hands these the nodes and the ROS.
"""

__all__ = ["atomic", "export", "kept", "modelfile", "savefile"]
