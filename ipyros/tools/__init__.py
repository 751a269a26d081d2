"""Tools: what the prompt does with nodes and the graph, returning data that the IPython face shows.

- :mod:`.graph`: a cached view of the live graph, refreshed in the background;
- :mod:`.probe`: echo, rates, and the prompt's publisher; :mod:`.record`: topics to a bag;
  :mod:`.plot`: topic fields drawn live;
- :mod:`.tryout`: a candidate handler run beside the live one; :mod:`.editing`: a handler's
  source to edit, and the edit put live;
- :mod:`.wrap`: a node wrapped in one call; :mod:`.robot`: the demo robot;
- :mod:`.paramwatch`: parameters watched as they change;
- :mod:`.collector`: Python's garbage collector kept from stalling the prompt.

May import: core, processes, node, dsl (never the IPython face).
"""

__all__ = ["collector", "editing", "graph", "paramwatch", "plot", "probe", "record", "robot", "tryout", "wrap"]
