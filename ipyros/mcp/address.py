"""Where a running session's agent server is written down: its address and token, for the bridge to find."""

from __future__ import annotations

import os
from pathlib import Path

__all__ = ["token_file"]


def token_file() -> Path:
    """``$IPYROS_MCP_FILE``, else ``~/.ipyros/mcp.json``: the server's url and token, readable by its owner alone."""
    base = os.environ.get("IPYROS_MCP_FILE")
    return Path(base).expanduser() if base else Path.home() / ".ipyros" / "mcp.json"
