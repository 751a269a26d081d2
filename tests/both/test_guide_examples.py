"""The guide's examples that can run here, run: every ```python block of the README and docs/ that follows the
mark below, in a shell with ipyros loaded (the message classes they name imported first), so they cannot rot."""

from __future__ import annotations

import re
from pathlib import Path

import pytest
from shell import ok

ROOT = Path(__file__).resolve().parents[2]
MARK = "<!-- the guide's tests run the block below: tests/both/test_guide_examples.py -->"
IMPORTS = "from geometry_msgs.msg import Pose, PoseStamped, Twist\n"


def examples() -> list[tuple[str, str]]:
    found = []
    for path in [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]:
        text = path.read_text(encoding="utf-8")
        for number, block in enumerate(re.findall(re.escape(MARK) + r"\n```python\n(.*?)```", text, re.S), 1):
            found.append((f"{path.relative_to(ROOT)}#{number}", block))
    return found


def test_the_guide_has_examples_that_run():
    assert {where.split("#")[0] for where, _ in examples()} >= {"README.md", "docs/guard.md", "docs/dsl.md",
                                                                "docs/wrapping.md"}


@pytest.mark.parametrize("where, code", examples(), ids=[where for where, _ in examples()])
def test_a_guide_example_runs(ip, where, code):
    ok(ip, IMPORTS + code)
