"""The README is a short front door: at most 300 lines, and every link in it leads somewhere that exists."""

from __future__ import annotations

import re
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
README = ROOT / "README.md"
#: [text](target): a Markdown link, inline (the README uses no reference-style links).
LINK = re.compile(r"\[[^\]]*\]\(([^)\s]+)\)")


def anchors(markdown: Path) -> set[str]:
    """The anchors of a Markdown file's headings, as GitHub and MyST (``myst_heading_anchors``) make them."""
    found = set()
    for line in markdown.read_text(encoding="utf-8").splitlines():
        heading = re.match(r"#{1,6}\s+(.*)", line)
        if heading:
            text = re.sub(r"[^\w\- ]", "", heading.group(1).strip().lower())
            found.add(text.replace(" ", "-"))
    return found


def test_the_readme_is_at_most_300_lines():
    assert len(README.read_text(encoding="utf-8").splitlines()) <= 300


def test_every_link_of_the_readme_resolves():
    targets = LINK.findall(README.read_text(encoding="utf-8"))
    assert targets, "the README links into the guide"
    for target in targets:
        assert not target.startswith(("http:", "https:")), f"{target}: the README links only into this repository"
        path, _, anchor = target.partition("#")
        file = (ROOT / path) if path else README
        assert file.is_file(), f"README.md links to {target}, which is not a file of the repository"
        if anchor:
            assert anchor in anchors(file), f"README.md links to {target}: {path or 'README.md'} has no such heading"
