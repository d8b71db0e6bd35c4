"""The HTML version of a student's sheet (``sheet.html`` beside ``assignment.pdf``): the same
statement, each figure as inline SVG with its text alternative, the answer table.

Rendered from the sheet's own template context (`build_context` with ``key=False``: no answer value)
through ``templates/sheet.html.j2`` with HTML autoescaping, so every string from an assignment,
problem or roster file reaches the page as text. The page is polyglot markup (well-formed XML as
well as HTML5), and its CSS lets it reflow: at 200 % zoom nothing needs horizontal scrolling.
"""

from __future__ import annotations

import re
from functools import lru_cache

import jinja2
from markupsafe import Markup

from gradekit.documents.typeset import TEMPLATES

_PROLOGUE = re.compile(r"^\s*<\?xml[^>]*\?>\s*")
_SVG_OPEN = re.compile(r"<svg\b")


@lru_cache(maxsize=1)
def _environment() -> jinja2.Environment:
    return jinja2.Environment(loader=jinja2.FileSystemLoader(str(TEMPLATES)), undefined=jinja2.StrictUndefined,
                              autoescape=True, trim_blocks=True, lstrip_blocks=True)


def inline_svg(svg: bytes, described_by: str) -> Markup:
    """gradekit's own SVG (`figures.canvas.svg`: its text escaped when drawn) for inlining: no XML
    prologue, ``role="img"`` and named by the element *described_by* (the figure's description); its
    element ids prefixed by *described_by*, as two figures of a page draw the same parts."""
    body = _PROLOGUE.sub("", svg.decode("utf-8")).replace(' id="', f' id="{Markup.escape(described_by)}-')
    attrs = f'<svg role="img" aria-labelledby="{Markup.escape(described_by)}" focusable="false"'
    return Markup(_SVG_OPEN.sub(attrs, body, count=1))


def sheet(context: dict) -> str:
    """``sheet.html`` of the sheet whose template context is *context*."""
    return _environment().get_template("sheet.html.j2").render(**context, inline_svg=inline_svg)


__all__ = ["sheet", "inline_svg"]
