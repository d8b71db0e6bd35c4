"""Typst markup from jinja2 templates: escaping, the number filter, fonts and one compiler per process."""

from __future__ import annotations

import logging
import math
import re
from collections.abc import Sequence
from functools import lru_cache
from pathlib import Path

import jinja2

from gradekit import units
from gradekit.errors import GradekitError
from gradekit.numbers import fmt
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


_LONG_RUN = re.compile(r"(\S{24})(?=\S)")


def breakable(value: str) -> Typ:
    """*value* as text (`text`) that may break inside a long run without spaces: a zero-width space
    after every 24 such characters, so that a 3,000-character name wraps inside its field instead
    of running off the page."""
    return text(_LONG_RUN.sub("\\1\u200b", str(value)))


def brief(value: str, limit: int = 60) -> Typ:
    """*value* as text, cut to *limit* characters with an ellipsis (a running page header's name)."""
    value = str(value)
    return text(value if len(value) <= limit else value[:limit - 1].rstrip() + "…")


def paragraph_texts(value: str) -> list[str]:
    """Multi-line *value* as plain paragraphs: blank lines separate paragraphs, newlines are spaces."""
    return [p for p in (" ".join(p.split()) for p in re.split(r"\n\s*\n", str(value).strip())) if p]


def paragraphs(value: str) -> Typ:
    """Multi-line *value* as markup paragraphs (`paragraph_texts`)."""
    return Typ("\n\n".join(text(p) for p in paragraph_texts(value)))


def num(value: float, sig: int = 5) -> Typ:
    """A number through `numbers.fmt` (the one formatter), with a true minus sign for markup."""
    return Typ(fmt(float(value), sig).replace("-", "−"))


def unit(u: str) -> Typ:
    """A unit for markup: ``N*mm`` -> ``N·mm``, escaped."""
    return text(units.pretty(u)) if u else Typ("")


def cell(*parts: Typ | str | int) -> Typ:
    """One table cell's markup from *parts*: markup as it is, text escaped, integers as written."""
    out = []
    for p in parts:
        if isinstance(p, Typ):
            out.append(p)
        elif isinstance(p, str):
            out.append(text(p))
        elif isinstance(p, int) and not isinstance(p, bool):
            out.append(str(p))
        else:
            raise TypeError(f"a table cell printed {p!r}: print text, markup or a formatted number")
    return Typ("".join(out))


def table(cells: Sequence[Sequence[Typ]], columns: Sequence[str], align: Sequence[str], *,
          size: float = 10.0, inset: tuple[float, float] = (4.0, 3.0)) -> Typ:
    """A whole table as markup: *cells* are rows of cell markup, the first row the header.

    The header is a ``table.header``: Typst repeats it on every page the table runs onto and tags
    its cells as header cells (TH) in the PDF. Columns (``"auto"`` or ``"1fr"``) and rows are laid
    out by Typst itself.
    """
    head, *body = [list(r) for r in cells]
    inner = (f"#table(columns: ({', '.join(columns)},), inset: (x: {inset[0]:g}pt, y: {inset[1]:g}pt), "
             f"align: ({', '.join(align)},),\n"
             f"  table.header({''.join(f'[{c}], ' for c in head)}),\n"
             + "\n".join("  " + "".join(f"[{c}], " for c in row) for row in body) + "\n)")
    return Typ(inner if size == 10.0 else f"#text({size:g}pt)[{inner}]")


def formula(src: str) -> Typ:
    """Inline math *src* (Typst math, as gradekit writes it) with its spoken form as the equation's
    alt text (`speak`): PDF/UA-1 asks a text alternative of every formula.

    The equation is made with its alt text as an argument rather than by a ``set`` rule in a content
    block around it: the same element and tags, with less for Typst to style and realize."""
    return Typ(f"#math.equation(alt: {string(speak(src))}, block: false, ${src}$.body);")


_UNIT_WORDS = {"N": "newton", "kN": "kilonewton", "mN": "millinewton", "m": "metre", "mm": "millimetre",
               "cm": "centimetre", "km": "kilometre", "in": "inch", "ft": "foot", "lb": "pound",
               "lbf": "pound-force", "kip": "kip", "kg": "kilogram", "g": "gram", "s": "second",
               "min": "minute", "rad": "radian", "rev": "revolution", "rpm": "revolutions per minute",
               "slug": "slug", "deg": "degree", "°": "degree"}
_PLURAL = {"inch": "inches", "foot": "feet", "revolutions per minute": "revolutions per minute"}
_POWERS = {"²": " squared", "³": " cubed"}
_MATH_WORDS = {"=": "equals", "+": "plus", "-": "minus", "−": "minus", "times": "times", "dot": "dot",
               "angle": "at angle", "degree": "degrees", "arrow.double.r": "hence", "sum": "sum of",
               "/": "over", ",": ",", ";": ";", "'": "prime"}
_MATH_TOKEN = re.compile(r'"(?:[^"\\]|\\.)*"|#h\([^)]*\)|[A-Za-z]+(?:\.[a-z]+)*|[0-9]+(?:\.[0-9]+)?|\S')


def spoken_unit(u: str) -> str | None:
    """``N·m`` -> 'newton metres', ``m/s²`` -> 'metres per second squared'; None when *u* is not a unit."""
    num, _, den = u.partition("/")

    def words(part: str) -> list[str] | None:
        out = []
        for piece in filter(None, part.split("·")):
            power = _POWERS.get(piece[-1], "")
            base = piece[:-1] if power else piece
            if base not in _UNIT_WORDS:
                return None
            out.append(_UNIT_WORDS[base] + power)
        return out or None

    top, bottom = words(num), (words(den) if den else [])
    if top is None or bottom is None:
        return None
    last = top[-1]
    stem, power = (last.split(" ", 1) + [""])[:2] if " " in last and last.split(" ", 1)[1] in ("squared", "cubed") \
        else (last, "")
    top[-1] = (_PLURAL.get(stem, stem + "s") + (" " + power if power else ""))
    return " ".join(top) + (" per " + " ".join(bottom) if bottom else "")


def speak(src: str) -> str:
    """The spoken form of a formula gradekit writes in Typst math: ``T = −1.176 "N·m"`` -> 'T equals
    minus 1.176 newton metres'; ``arrow(r)_("AB")`` -> 'vector r sub AB'; ``abs(x)`` -> 'magnitude of
    x'; ``(a) / (b)`` -> 'a over b'. Quoted text is read as written (a unit in words)."""
    tokens = _MATH_TOKEN.findall(src)
    out: list[str] = []
    wrappers = {"arrow": "vector", "hat": "unit vector", "abs": "magnitude of", "dot": "rate of",
                "dot.double": "second rate of"}
    depth_words: list[str] = []
    for i, t in enumerate(tokens):
        nxt = tokens[i + 1] if i + 1 < len(tokens) else ""
        if t.startswith("#h("):
            out.append(",")
        elif t.startswith('"'):
            inner = t[1:-1].replace('\\"', '"').replace("\\\\", "\\")
            out.append(spoken_unit(inner) or inner)
        elif t in wrappers and nxt == "(":
            out.append(wrappers[t])
        elif t == "(":
            bare = not (i and (tokens[i - 1] in wrappers or tokens[i - 1] in ("_", "^")))
            depth_words.append("(" if bare else "")
            out.append("(" if bare else "")
        elif t == ")":
            out.append(depth_words.pop() and ")" if depth_words else "")
        elif t == "_":
            out.append("sub")
        elif t == "^":
            out.append("squared" if nxt == "2" else "to the power")
            if nxt == "2":
                tokens[i + 1] = ""
        elif t in _MATH_WORDS:
            out.append(_MATH_WORDS[t])
        elif t:
            out.append(t)
    text_ = re.sub(r"\(\s+", "(", " ".join(w for w in out if w))
    text_ = re.sub(r"\s+([,;)])", r"\1", text_)
    return re.sub(r"([,;])(\s*[,;])+", r"\1", text_).strip()


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
                       markup=Typ, formula=formula, breakable=breakable, brief=brief)
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


class TypstFailure(Exception):
    """Typst refused a document: its message on one line, the text it quotes, and whether that text
    is a glyph no font draws (which PDF/UA-1 refuses)."""

    def __init__(self, message: str) -> None:
        self.message = " ".join(message.split())
        m = re.search(r'the text `"(.*?)"`', self.message) or re.search(r'"([^"]+)"', self.message)
        self.quoted = m.group(1) if m else ""
        self.missing_glyph = "could not be displayed" in self.message
        super().__init__(self.message)


class Compiler:
    """One `typst.Compiler` per process, rooted at the build folder (figures live under it)."""

    def __init__(self, root: Path) -> None:
        import typst

        self.root = Path(root)
        self._typst = typst
        self._compiler = typst.Compiler(root=str(self.root))

    def pdf(self, source: str, *, accessible: bool = True) -> bytes:
        """Compile Typst *source* (paths in it relative to the root) to PDF bytes: PDF/UA-1 when
        *accessible*, else a tagged PDF.

        PDF/UA-1 (ISO 14289-1): Typst refuses to export a document that misses one of its
        requirements (a heading level skipped, a figure or formula without alt text, no title), so
        every document that is written is tagged, titled and described. It also refuses text that
        no font draws, hence *accessible* off for a name whose script has no installed font."""
        try:
            return self._compiler.compile(input=source.encode("utf-8"), format="pdf",
                                          pdf_standards=["ua-1"] if accessible else [])
        except self._typst.TypstError as exc:
            raise TypstFailure(str(getattr(exc, "message", "") or exc)) from None


def is_finite(x: float) -> bool:
    return isinstance(x, (int, float)) and math.isfinite(x)
