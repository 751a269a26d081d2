"""Sphinx directive ``.. ipyros-magics::``: the magics reference, drawn from :mod:`ipyros.ipython.reference`.

The text is never parsed as markup: a magic's help is plain text (``%%``, ``*``, backticks and all),
so the reference cannot fail the build with a warning and says exactly what ``%magic?`` says.
"""

from __future__ import annotations

from docutils import nodes
from sphinx.util.docutils import SphinxDirective


class MagicsReference(SphinxDirective):
    """Every magic the extension registers: a section each, with usage, description and arguments."""

    has_content = False

    def run(self) -> list[nodes.Node]:
        from ipyros.ipython.reference import entries

        out: list[nodes.Node] = []
        for entry in entries():
            section = nodes.section(ids=[nodes.make_id(f"magic-{entry.name}")], names=[f"%{entry.name}"])
            section += nodes.title(text=entry.title)
            section += nodes.literal_block(text=entry.usage, language="text")
            for kind, text in entry.blocks():
                section += nodes.literal_block(text=text, language="text") if kind == "code" else \
                    nodes.paragraph(text=text)
            if entry.options:
                rows = nodes.bullet_list()
                for option in entry.options:
                    item = nodes.list_item()
                    para = nodes.paragraph()
                    para += nodes.literal(text=option.spelling)
                    para += nodes.Text(f": {option.help}" if option.help else "")
                    item += para
                    rows += item
                section += rows
            section += nodes.paragraph(text=f"Declared by {entry.owner}.")
            out.append(section)
        return out


def setup(app):  # noqa: ANN001, ANN201 - Sphinx's extension entry point
    app.add_directive("ipyros-magics", MagicsReference)
    return {"parallel_read_safe": True, "parallel_write_safe": True}
