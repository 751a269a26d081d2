"""ipyros: interactive, incremental programming of ROS 1 nodes from IPython.

``from ipyros import rosNode`` gives the DSL of Adam & Schultz; ``%load_ext ipyros``
adds the magics and live tab completion on top of it.
"""

from __future__ import annotations

__version__ = "0.1.0"
