"""What the ipyros magics share: their link to the extension, and finding what a line names."""

from __future__ import annotations

from typing import Any

from IPython.core.magic import Magics

from ..api import Host


class ExtensionMagics(Magics):
    """A ``Magics`` class of ipyros: reaches the settings, the graph and the printer via ``ext``."""

    def __init__(self, shell: Any, ext: Host) -> None:
        super().__init__(shell=shell)
        self.ext = ext


