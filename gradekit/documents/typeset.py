"""Typst markup from jinja2 templates: escaping, the number filter, fonts and one compiler per process."""

from __future__ import annotations

import logging
import math
import re
from functools import lru_cache
from pathlib import Path

import jinja2

from gradekit import units
from gradekit.errors import GradekitError
from gradekit.report import fmt
from gradekit.resources import resource_dir

log = logging.getLogger("gradekit")

TEMPLATES = resource_dir("templates")

# Body text first; then fonts for the scripts of names on a roster, used by Typst's fallback
# when installed (Debian: fonts-noto-core for Ethiopic, fonts-noto-cjk for CJK).
FONTS = ("Libertinus Serif", "DejaVu Sans", "Noto Serif", "Noto Sans", "Noto Sans Ethiopic",
         "Noto Serif Ethiopic", "Abyssinica SIL", "Noto Sans CJK SC", "Noto Serif CJK SC",
         "Noto Sans SC", "WenQuanYi Zen Hei", "Droid Sans Fallback")


class Typ(str):
    """Text that already is Typst markup: templates output it as it is."""


def string(text: str) -> Typ:
    """*text* as a Typst string literal (``"..."``), for code contexts such as function arguments."""
    out = text.replace("\\", "\\\\").replace('"', '\\"').replace("\r\n", "\n")
    out = out.replace("\n", "\\n").replace("\r", "\\n").replace("\t", "\\t")
    return Typ(f'"{out}"')


def text(value: str) -> Typ:
    """*value* as literal markup text: a string expression, so ``# $ * _ @ < [ \\`` stay characters."""
    return Typ("#" + string(str(value)))


def paragraphs(value: str) -> Typ:
    """Multi-line *value* as markup paragraphs: blank lines separate paragraphs, newlines are spaces."""
    paras = [" ".join(p.split()) for p in re.split(r"\n\s*\n", str(value).strip())]
    return Typ("\n\n".join(text(p) for p in paras if p))


def num(value: float, sig: int = 5) -> Typ:
    """A number through `report.fmt` (the one formatter), with a true minus sign for markup."""
    return Typ(fmt(float(value), sig).replace("-", "−"))


def unit(u: str) -> Typ:
    """A unit for markup: ``N*mm`` -> ``N·mm``, escaped."""
    return text(units.pretty(u)) if u else Typ("")


def _finalize(value: object) -> object:
    """Every ``{{ }}`` output: markup passes, text is escaped, floats must go through ``num``."""
    if isinstance(value, Typ):
        return value
    if isinstance(value, bool) or value is None:
        raise TypeError(f"template printed {value!r}: print text or a formatted number")
    if isinstance(value, int):
        return str(value)
    if isinstance(value, float):
        raise TypeError(f"template printed the float {value!r} unformatted: use |num")
    return text(str(value))


@lru_cache(maxsize=1)
def environment() -> jinja2.Environment:
    """The jinja2 environment for Typst templates (StrictUndefined, escaping by default)."""
    env = jinja2.Environment(
        loader=jinja2.FileSystemLoader(str(TEMPLATES)),
        undefined=jinja2.StrictUndefined,
        autoescape=False,
        finalize=_finalize,
        keep_trailing_newline=True,
        trim_blocks=True,
        lstrip_blocks=True,
        comment_start_string="{##",
        comment_end_string="##}",
    )
    env.filters.update(num=num, unit=unit, string=string, text=text, paragraphs=paragraphs,
                       markup=Typ)
    return env


def render(template: str, context: dict) -> str:
    """Render one template of ``templates/`` with *context*."""
    try:
        return environment().get_template(template).render(**context)
    except jinja2.TemplateNotFound as exc:
        raise GradekitError(f"expected the template {exc.name} in {TEMPLATES}, got no such file") from None


@lru_cache(maxsize=1)
def available_fonts() -> tuple[str, ...]:
    """The families of `FONTS` that Typst finds (bundled or installed), in order."""
    import typst

    have = set(typst.Fonts().families())
    return tuple(f for f in FONTS if f in have)


@lru_cache(maxsize=1)
def _covered() -> frozenset[int]:
    """Code points drawn by some font Typst will use (read from the installed font files)."""
    import typst

    cps: set[int] = set(range(0x20, 0x530)) | set(range(0x1E00, 0x2070))  # bundled Libertinus
    wanted = set(available_fonts())
    for info in typst.Fonts().fonts():
        if info.family not in wanted or not info.path:
            continue
        try:
            from fontTools.ttLib import TTFont

            with TTFont(info.path, fontNumber=info.index, lazy=True) as font:
                cps.update(font.getBestCmap() or {})
        except Exception as exc:  # an unreadable font only costs coverage
            log.debug("cannot read %s: %s", info.path, exc)
    return frozenset(cps)


def missing_glyphs(value: str) -> str:
    """The characters of *value* that no available font draws (empty when all are covered)."""
    covered = _covered()
    seen = dict.fromkeys(c for c in value if ord(c) not in covered and not c.isspace()
                         and not _combining_or_control(c))
    return "".join(seen)


def _combining_or_control(c: str) -> bool:
    import unicodedata

    return unicodedata.category(c) in ("Mn", "Me", "Cc", "Cf")


def font_hint(chars: str) -> str:
    """Which Debian package would draw *chars*."""
    import unicodedata

    names = " ".join(unicodedata.name(c, "") for c in chars)
    if re.search(r"CJK|HIRAGANA|KATAKANA|HANGUL", names):
        return "fonts-noto-cjk"
    return "fonts-noto-core"


class Compiler:
    """One `typst.Compiler` per process, rooted at the build folder (figures live under it)."""

    def __init__(self, root: Path) -> None:
        import typst

        self.root = Path(root)
        self._typst = typst
        self._compiler = typst.Compiler(root=str(self.root))

    def pdf(self, source: str) -> bytes:
        """Compile Typst *source* (paths in it relative to the root) to PDF bytes."""
        try:
            return self._compiler.compile(input=source.encode("utf-8"), format="pdf")
        except self._typst.TypstError as exc:  # a template bug, not a data error: show it whole
            raise RuntimeError(f"typst failed: {exc}") from exc


def is_finite(x: float) -> bool:
    return isinstance(x, (int, float)) and math.isfinite(x)
