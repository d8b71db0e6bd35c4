"""docs/kinds.md shows each mechanism kind's default labels in a figure generated from its starter."""

from __future__ import annotations

from pathlib import Path

import pytest

from gradekit.figures import kind_figure_svg
from gradekit.mechanics.mechanisms import KINDS

DOCS = Path(__file__).resolve().parents[1] / "docs"


@pytest.mark.parametrize("kind", sorted(KINDS))
def test_each_kinds_figure_is_the_starters_scene(kind):
    svg = kind_figure_svg(kind)
    assert (DOCS / "kinds" / f"{kind}.svg").read_bytes() == svg  # regenerate: see gradekit.figures.kind_figure_svg
    assert f"(kinds/{kind}.svg)" in (DOCS / "kinds.md").read_text(encoding="utf-8")
    for point in KINDS[kind].points:  # every point the kind declares is labelled by its default name
        assert f">{point}<" in svg.decode("utf-8")
