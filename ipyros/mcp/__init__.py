"""An AI coding agent in the session, behind the guard and the person's approval (``%mcp``).

* :mod:`~ipyros.mcp.allow`: what an agent may do beyond reading, each name in its one spelling;
* :mod:`~ipyros.mcp.approvals`: its requests, waiting for ``%mcp approve N`` at the prompt;
* :mod:`~ipyros.mcp.candidate`: a handler it wrote, made a function without running its code;
* :mod:`~ipyros.mcp.desk`: the session as it may use it, each a thin call of what the magics do;
* :mod:`~ipyros.mcp.server`: those calls as MCP tools, over HTTP on the loopback, behind a token;
* ``python -m ipyros.mcp``: a bridge for clients that start a command (stdio) to the running session's server.

Only :mod:`~ipyros.mcp.server` and the bridge import the MCP SDK (the ``agent`` extra): the rest is plain Python.
"""
