"""The IPython face: the extension, the magics, tab completion and how results are shown.

- :mod:`.extension`: ``%load_ext ipyros``: what loading adds, and unloading takes away again;
- :mod:`.magics`: one ``Magics`` class per concern, thin over the DSL and the tools;
- :mod:`.completion`: live topic names, types and more on TAB, from the magics' own parsers;
- :mod:`.display`: records as rich tables in a terminal and HTML in Jupyter.

May import: every layer below (core, processes, node, dsl, tools); nothing imports it
but ``ipyros.load_ipython_extension``.
"""

__all__ = ["completion", "display", "extension", "magics"]
