"""The README's first lines, as both suites' terminal tests type them and check what they do (no ROS here)."""

from __future__ import annotations

import re
from pathlib import Path

import pytest
from terminal import Terminal, run

ROOT = Path(__file__).resolve().parents[2]
#: The comment above the README's five lines; the ```python block after it holds them.
MARKER = "<!-- the five lines"


def readme_lines() -> list[str]:
    """The five lines the README tells a new user to type, as they stand in it."""
    text = (ROOT / "README.md").read_text(encoding="utf-8")
    block = re.search(r"```python\n(.*?)```", text[text.index(MARKER):], re.S)
    assert block, f"no ```python block after {MARKER!r} in README.md"
    return block.group(1).rstrip("\n").split("\n")


def watch_the_turtle_go_round(term: Terminal, poses: int = 2, timeout: float = 30.0) -> list[tuple[float, float]]:
    """``poses[-1].position``, typed again and again, until it has shown ``poses`` places away from the
    origin; each must lie on the circle of radius v/ω = 2.0/1.8 around (0, v/ω) the five lines drive."""
    seen: list[tuple[float, float]] = []

    def moved(rows):
        term.press("C-l")
        run(term, 'print("AT", poses[-1].position.x, poses[-1].position.y)')
        found = re.findall(r"^AT (\S+) (\S+)$", "\n".join(term.screen()), re.M)
        if found:
            seen.append((float(found[-1][0]), float(found[-1][1])))
        return len({p for p in seen if p != (0.0, 0.0)}) >= poses

    term.wait_for(moved, timeout=timeout, what=f"the turtle to move ({poses} different poses)", interval=0.3)
    assert all(x * x + (y - 1.111) ** 2 == pytest.approx(1.111 ** 2, rel=0.1) for x, y in seen if (x, y) != (0, 0)), \
        f"the poses {seen} are not on the circle of radius v/ω around (0, v/ω)"
    return seen
