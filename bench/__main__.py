"""Run every benchmark in one go: ``python -m bench [--quick]``.

Each benchmark starts its own rosmaster on a free port, prints a table, saves it under
bench/results/, and stops everything it started. The exit code is non-zero if a
target was missed.
"""

from __future__ import annotations

import sys


def main(argv: list[str] | None = None) -> int:
    argv = sys.argv[1:] if argv is None else argv
    from bench import completion, relay, scale

    status = 0
    for bench in (relay, completion, scale):
        print(f"\n=== {bench.__name__} ===", flush=True)
        status |= bench.main(argv) or 0
    return status


if __name__ == "__main__":
    sys.exit(main())
