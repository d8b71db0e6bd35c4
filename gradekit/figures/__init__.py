"""Figures of one student's variant: the assignment scene and the instructor's key figures.

Figure functions return a `matplotlib.figure.Figure` and never save or show it; `to_svg`,
`to_png` and `write_figures` are the only places that serialise. matplotlib is imported here (and
only here, never by the solver) with the Agg backend chosen lazily.
"""

from __future__ import annotations

import io
import re
from pathlib import Path

import matplotlib

from gradekit.solving.pipeline import Result

SVG_RC = {"svg.fonttype": "none", "svg.hashsalt": "gradekit", "svg.image_inline": True}


def scene(result: Result, case: str | None = None, *, true_scale: bool = False):
    """The assignment figure: the student's mechanism with the given values, no solved answer.

    Args:
        result: the solved variant (`gradekit.solving.sampling.variant(...).result`).
        case: the case (position) to draw; the first when None.
        true_scale: draw at ``problem.figure.true_scale`` (paper length per mechanism length) so
            the SVG placed at its natural size measures true, with a scale bar and the printed scale.
    """
    from gradekit.figures.canvas import render
    from gradekit.figures.sheet import build_scene

    return render(build_scene(result, case, true_scale))


def key_figures(result: Result) -> list[tuple[str, str, object]]:
    """The answer-key figures of a variant as (slug, caption, figure), in document order."""
    from gradekit.figures.key import key_figure_specs

    return [(slug, caption, make()) for slug, caption, make in key_figure_specs(result)]


def scene_svg(result: Result, case: str | None = None, *, true_scale: bool = False) -> bytes:
    """`scene` as SVG bytes, written straight from the display list (no matplotlib; documents use it)."""
    from gradekit.figures.canvas import svg
    from gradekit.figures.sheet import build_scene

    return svg(build_scene(result, case, true_scale))


def scene_described(result: Result, case: str | None = None, *, true_scale: bool = False) -> tuple[bytes, str]:
    """`scene_svg` and the scene's text alternative, written from the model as it is drawn: the
    mechanism, its links with their printed lengths, the crank angle, the points, each load with its
    magnitude and direction, the scale. Only what the sheet prints: never a solved answer."""
    from gradekit.figures.canvas import svg
    from gradekit.figures.sheet import build_scene

    cv = build_scene(result, case, true_scale)
    return svg(cv), cv.description()


def key_figure_svgs(result: Result) -> list[tuple[str, str, bytes]]:
    """`key_figures` as (slug, caption, SVG bytes); drawings written straight from their display
    lists, plotted curves through matplotlib."""
    return [(slug, caption, data) for slug, caption, data, _alt in key_figures_described(result)]


def key_figures_described(result: Result) -> list[tuple[str, str, bytes, str]]:
    """`key_figure_svgs` with each figure's text alternative: (slug, caption, SVG bytes, alt). A
    free-body diagram names each force (magnitude, point, direction); a force polygon says the order
    of its arrows and how it closes; a velocity or acceleration polygon each point's image."""
    from gradekit.figures.canvas import Canvas, svg
    from gradekit.figures.key import Plot, key_drawings

    out = []
    for slug, caption, make in key_drawings(result):
        drawn = make()
        if isinstance(drawn, Canvas):
            out.append((slug, caption, svg(drawn), drawn.description()))
        elif isinstance(drawn, Plot):
            out.append((slug, caption, to_svg(drawn.figure), drawn.alt))
        else:
            out.append((slug, caption, to_svg(drawn), caption))
    return out


def kind_figure_svg(kind: str) -> bytes:
    """The scene of `gradekit bank new KIND`'s starter problem: the kind's default point and link
    labels (docs/kinds/<kind>.svg, which docs/kinds.md shows)."""
    import tempfile

    from gradekit.bank.schema import load_problem
    from gradekit.bank.starter import starter
    from gradekit.solving.sampling import variant

    with tempfile.TemporaryDirectory() as tmp:
        f = Path(tmp) / f"{kind}.yaml"
        f.write_text(starter(kind), encoding="utf-8")
        return scene_svg(variant(load_problem(f)).result)


def to_svg(fig) -> bytes:
    """SVG bytes of *fig* (text kept as text), identical for identical figures; closes *fig*."""
    buf = io.BytesIO()
    with matplotlib.rc_context(SVG_RC):
        fig.savefig(buf, format="svg", metadata={"Date": None})
    _close(fig)
    return buf.getvalue()


def to_png(fig, dpi: int = 110) -> bytes:
    """PNG bytes of *fig* at *dpi* (previews); closes *fig*."""
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=dpi, metadata={"Software": None})
    _close(fig)
    return buf.getvalue()


def write_figures(result: Result, out_dir: Path, fmt: str = "svg") -> list[Path]:
    """Write the scene (and, for a true-scale problem, its true-scale drawing) and every key figure.

    Files are ``<problem id>-<slug>.<fmt>``; returns their paths in order.
    """
    if fmt not in ("svg", "png"):
        raise ValueError(f"expected svg or png, got {fmt!r}")
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    write = to_svg if fmt == "svg" else to_png
    pid = result.problem.id
    figs = [("scene", scene(result))]
    if result.problem.figure.true_scale:
        figs.append(("scene-true-scale", scene(result, true_scale=True)))
    if len(result.cases) > 1:
        figs += [(f"scene-{re.sub(r'[^a-z0-9]+', '-', str(c.name).lower())}", scene(result, c.name))
                 for c in result.cases[1:]]
    paths = []
    for slug, fig in figs:
        p = out_dir / f"{pid}-{slug}.{fmt}"
        p.write_bytes(write(fig))
        paths.append(p)
    for slug, _caption, fig in key_figures(result):
        p = out_dir / f"{pid}-{slug}.{fmt}"
        p.write_bytes(write(fig))
        paths.append(p)
    return paths


def _close(fig) -> None:
    # Figures made here are not registered with pyplot; a pyplot figure is closed there too.
    import sys

    plt = sys.modules.get("matplotlib.pyplot")
    if plt is not None and plt.fignum_exists(getattr(fig, "number", -1)):
        plt.close(fig)


__all__ = ["scene", "scene_described", "key_figures", "key_figures_described", "to_svg", "to_png",
           "write_figures"]
