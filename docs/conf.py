"""Sphinx configuration of the ipyros guide: ``sphinx-build -W docs OUT`` (``bash run.sh docs``)."""

from __future__ import annotations

import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path[:0] = [str(HERE / "_ext"), str(HERE.parent)]

project = "ipyros"
author = "the ipyros developers"
copyright = "2026, the ipyros developers"

extensions = ["myst_parser", "sphinx.ext.autodoc", "ipyros_docs"]
source_suffix = {".md": "markdown", ".rst": "restructuredtext"}
root_doc = "index"
exclude_patterns = ["_build", "_ext"]
myst_heading_anchors = 3
myst_enable_extensions = ["colon_fence"]
html_theme = "furo"
html_title = "ipyros"
autodoc_member_order = "bysource"
autodoc_typehints = "none"  # the DSL's signatures say enough; its docstrings say the rest
nitpicky = False
