"""``python -m ipyros.mcp``: a bridge for MCP clients that start a command (Claude Desktop, ...) to the server a
running ipyros session started with ``%mcp start``.

It reads the server's address and token from the file ``%mcp start`` wrote (``~/.ipyros/mcp.json``, or
``$IPYROS_MCP_FILE``), then passes each JSON-RPC message from its standard input to the server over HTTP, with the
token, and each answer back to its standard output, one line each. It holds nothing of its own: no tool, no token
on its command line; with no session running it says so in one line on standard error and ends.

    {"mcpServers": {"ipyros": {"command": "python3", "args": ["-m", "ipyros.mcp"]}}}
"""

from __future__ import annotations

import json
import sys
import urllib.error
import urllib.request
from typing import Optional

from .address import token_file


def main() -> int:
    path = token_file()
    try:
        kept = json.loads(path.read_text())
        url, token = kept["url"], kept["token"]
    except (OSError, ValueError, KeyError):
        print(f"ipyros.mcp: no running session's server ({path} unreadable); start one at the ipyros prompt with "
              "%mcp start", file=sys.stderr)
        return 1
    session: Optional[str] = None
    version: Optional[str] = None
    for line in sys.stdin:
        if not line.strip():
            continue
        headers = {"Content-Type": "application/json", "Accept": "application/json, text/event-stream",
                   "Authorization": f"Bearer {token}"}
        if session:
            headers["Mcp-Session-Id"] = session
        if version:
            headers["Mcp-Protocol-Version"] = version
        request = urllib.request.Request(url, data=line.encode(), headers=headers, method="POST")
        try:
            with urllib.request.urlopen(request, timeout=600) as answer:
                session = answer.headers.get("mcp-session-id") or session
                body = answer.read().decode()
        except urllib.error.HTTPError as error:
            body = _error_for(line, f"the session's server answered {error.code}: {error.read().decode()[:200]}")
        except OSError as error:
            print(f"ipyros.mcp: the session's server at {url} does not answer ({error}); is the session still "
                  "running?", file=sys.stderr)
            return 1
        if not body.strip():
            continue  # a notification: nothing comes back
        try:
            message = json.loads(body)
        except ValueError:
            message = json.loads(_error_for(line, "the session's server answered something not JSON"))
        result = message.get("result") if isinstance(message, dict) else None
        if isinstance(result, dict) and "protocolVersion" in result:
            version = result["protocolVersion"]
        sys.stdout.write(json.dumps(message) + "\n")
        sys.stdout.flush()
    return 0


def _error_for(line: str, text: str) -> str:
    """A JSON-RPC error answering the request ``line`` (none for a notification, which has no id)."""
    try:
        ident = json.loads(line).get("id")
    except (ValueError, AttributeError):
        ident = None
    if ident is None:
        return ""
    return json.dumps({"jsonrpc": "2.0", "id": ident, "error": {"code": -32603, "message": text}})


if __name__ == "__main__":
    sys.exit(main())
