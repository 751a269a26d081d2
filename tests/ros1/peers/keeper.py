"""Peer: the keeper of a machine, as ``python -m ipyros.machine`` runs it (Ctrl-C ends it).

    python keeper.py --name NAME [--token-file FILE]
"""
import sys

from ipyros.machine import main

sys.exit(main())
