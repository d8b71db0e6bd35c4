"""Documents draw their figures straight to SVG from the display list: the same picture as the
matplotlib rendering (size in points, every label, every id), for every bank problem."""

from __future__ import annotations

import re
from collections import Counter

import pytest

from gradekit.bank.registry import load_bank
from gradekit.figures import key_figure_svgs, key_figures, scene, scene_svg, to_svg
from gradekit.solving.sampling import variant

BANK = load_bank()
_SIZE = re.compile(rb'<svg[^>]*width="([\d.]+)pt" height="([\d.]+)pt"')


def _texts(svg: bytes) -> Counter:
    body = svg.decode("utf-8")
    return Counter(t.strip() for t in re.findall(r"<(?:text|tspan)[^>]*>([^<]+)", body) if t.strip())


def _ids(svg: bytes) -> set[str]:
    return {i for i in re.findall(r'id="([^"]+)"', svg.decode("utf-8")) if not re.match(r"[a-zA-Z]+_\d+$", i)}


def _same(direct: bytes, mpl: bytes) -> None:
    w1, h1 = map(float, _SIZE.search(direct).groups())
    w2, h2 = map(float, _SIZE.search(mpl).groups())
    assert w1 == pytest.approx(w2, abs=0.01) and h1 == pytest.approx(h2, abs=0.01)
    assert _texts(direct) == _texts(mpl)
    assert _ids(direct) <= _ids(mpl) | {"figure_1"}


@pytest.mark.parametrize("pid", sorted(BANK))
def test_direct_svg_draws_what_matplotlib_draws(pid):
    r = variant(BANK[pid], course="MEG373", salt="svg", student="7").result
    true_scale = BANK[pid].method == "graphical" and BANK[pid].figure.true_scale is not None
    _same(scene_svg(r, true_scale=true_scale), to_svg(scene(r, true_scale=true_scale)))
    direct = key_figure_svgs(r)
    mpl = [(slug, cap, to_svg(fig)) for slug, cap, fig in key_figures(r)]
    assert [(s, c) for s, c, _ in direct] == [(s, c) for s, c, _ in mpl]
    for (_s, _c, a), (_s2, _c2, b) in zip(direct, mpl, strict=True):
        if b"<polyline" in a or b"<polygon" in a:  # a drawing (a plotted curve goes through matplotlib)
            _same(a, b)
