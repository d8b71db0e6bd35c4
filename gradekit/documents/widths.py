"""Fixed column widths and row heights for the documents' tables, measured through Typst and kept for the process.

Why: with ``auto`` columns and rows Typst lays each table cell out three times (to size its column,
to size its row, then for good), and a worked key is mostly tables: giving every table the widths
and heights it would get anyway takes about a fifth of a key's compile off and a quarter of a
sheet's, in instructions (benchmarks/RESULTS.md, "Typst: where a worked key's compile goes").
Python cannot measure the text itself (Libertinus Serif is embedded in Typst, no font file), so
each cell is measured by Typst, in a small document that starts with the documents' own set rules
(templates/_style.typ.j2), and remembered; a document's tables are measured together, when the
template first prints one of them (one query for all their new cells, usually none or a few).

What is measured is a cell's *shape*: its markup with each digit of its text written 0. The body
font's figures are tabular (every digit the same advance), and a digit kerns with its neighbours as
0 does; both are checked through Typst, once a process for each style and neighbour that occurs, and
a cell where they do not hold is measured as it is. So the shapes repeat from student to student: a
class needs a few hundred measurements, nearly all for its first student.

The widths: a column is as wide as Typst would make it (its widest cell plus the insets), and the
safety margin, `MARGIN` (0.01 pt), is taken from the inset on the side its cells are not aligned to:
each cell has that much more room than it needs, yet sits exactly where an ``auto`` column puts it,
and the ``1fr`` description columns, which get what the others leave, keep their width and their
line breaks. The margin only absorbs rounding, as the measurement is Typst's own.
The heights: a row is fixed only when each of its cells is provably one line: all its columns are
fixed and each ``1fr`` cell fits its column with `FR_SLACK` to spare; its height is its tallest
cell plus the insets, as Typst's own ``auto`` row.

The fallback: a table with a cell that cannot be measured (Typst refuses it), or whose columns would
not fit the text width (Typst shrinks ``auto`` columns then, so that cells wrap), keeps ``auto``
columns and rows, as before. All the tables are in the body at its full width, which is what they
are checked against; their header row is bold (templates/_style.typ.j2), and measured so.
"""

from __future__ import annotations

import json
import logging
import os
import re
import shutil
import tempfile
from collections.abc import Sequence
from functools import lru_cache
from multiprocessing.util import Finalize

from gradekit.documents.typeset import Typ, available_fonts, render, string, text

log = logging.getLogger("gradekit")

MARGIN = 0.01  # pt of room each cell has beyond its measured width (taken from an inset)
FR_SLACK = 0.5  # pt a 1fr cell must leave free in its column to count as one line
INSET = (4.0, 3.0)  # pt, x and y: the documents' table inset (printed with each table)
DIGITS = "0123456789"
_ZEROS = str.maketrans(DIGITS, "0" * 10)


class Table:
    """One table as the templates print it: ``#text({size})[#table(columns: {columns}, rows: {rows},
    inset: {inset}, align: {align}, ...)]`` with the cells of ``body``, the header row first.

    Its widths and heights are worked out when first read, together with those of every table made
    before it and not read yet (a document's tables: one Typst query for all their new shapes)."""

    def __init__(self, cells: Sequence[Sequence[Typ]], columns: Sequence[str], align: Sequence[str],
                 size: float, inset: tuple[float, float]) -> None:
        self.cells = [list(row) for row in cells]
        self.spec = list(columns)
        self.alignments = list(align)
        self.inset_pt = inset
        self.size = Typ(f"{size:g}pt")
        self.align = Typ(f"({', '.join(align)},)")
        self.body = Typ("\n".join("  " + "".join(f"[{c}], " for c in row) for row in cells))
        head, rest = _style(size, "bold"), _style(size, "regular")  # the header row is bold
        self.styled = [(head if r == 0 else rest, c) for r, row in enumerate(self.cells) for c in row]
        self._sized: tuple[Typ, Typ, Typ] | None = None
        _PENDING.append(self)
        del _PENDING[:-_BATCH]  # tables made and never printed are not kept for ever

    @property
    def columns(self) -> Typ:
        return self._fixed()[0]

    @property
    def rows(self) -> Typ:
        return self._fixed()[1]

    @property
    def inset(self) -> Typ:
        return self._fixed()[2]

    def _fixed(self) -> tuple[Typ, Typ, Typ]:
        if self._sized is None:  # measure the shapes of all the tables waiting, at once
            batch = list(_PENDING) if self in _PENDING else [self]
            _PENDING.clear()
            sizes = _measurer().sizes([c for t in batch for c in t.styled])
            at = 0
            for t in batch:
                t._sized = _fix(t, sizes[at:at + len(t.styled)])
                at += len(t.styled)
        return self._sized  # type: ignore[return-value]


_PENDING: list[Table] = []
_BATCH = 200  # tables measured together at most (a document has a few dozen)
_KEYS_KEPT = 100_000  # cells whose shape is remembered (a student brings a few hundred new ones)


def cell(*parts: Typ | str | int) -> Typ:
    """One cell's markup from *parts*, as a template prints them: markup as it is, text escaped."""
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
          size: float = 10.0, inset: tuple[float, float] = INSET) -> Table:
    """*cells* (rows of cell markup, the header first, set bold by the documents' style) in a table
    whose ``auto`` *columns* (``"auto"`` or ``"1fr"``, one per column; *align* ``"left"`` or
    ``"right"`` each) get their measured widths, and whose rows, where each cell is one line, their
    measured heights."""
    return Table(cells, columns, align, size, inset)


def _fix(t: Table, sizes: list[tuple[float, float] | None]) -> tuple[Typ, Typ, Typ]:
    """Columns, rows and insets of *t* from the *sizes* of its cells: measured, or ``auto`` as before
    (see the module's docstring). The margin is taken from the inset on the side a column's cells
    are not aligned to, so that every cell sits where an ``auto`` column would put it."""
    ix, iy = t.inset_pt
    keep = (Typ(f"({', '.join(t.spec)},)"), Typ("auto"), Typ(f"(x: {ix:g}pt, y: {iy:g}pt)"))
    if None in sizes:
        return keep
    n = len(t.spec)
    grid = [sizes[r * n:(r + 1) * n] for r in range(len(t.cells))]
    widths = [max(row[c][0] for row in grid) + 2 * ix if spec == "auto" else None for c, spec in enumerate(t.spec)]
    fr = [c for c, spec in enumerate(t.spec) if spec != "auto"]
    room = _measurer().text_width - sum(w for w in widths if w is not None)
    if room < 0 or (fr and room < 2 * ix * len(fr)):
        return keep  # Typst would shrink the auto columns to fit: as before
    fr_width = room / len(fr) if fr else 0.0
    rows = [f"{max(h for _, h in row) + 2 * iy!r}pt"
            if all(row[c][0] + 2 * ix <= fr_width - FR_SLACK for c in fr) else "auto" for row in grid]
    insets = []
    for w, a in zip(widths, t.alignments, strict=True):
        if w is None:
            insets.append(f"(x: {ix:g}pt, y: {iy:g}pt)")
        else:
            free = "right" if a == "left" else "left"
            insets.append(f"({a}: {ix:g}pt, {free}: {ix - MARGIN:g}pt, y: {iy:g}pt)")
    return (Typ("(" + ", ".join(f"{w!r}pt" if w is not None else t.spec[c] for c, w in enumerate(widths)) + ",)"),
            Typ("(" + ", ".join(rows) + ",)") if any(r != "auto" for r in rows) else Typ("auto"),
            Typ("(" + ", ".join(insets) + ",)"))


def _style(size: float, weight: str) -> str:
    return f'text({size:g}pt, weight: "{weight}")'


# --------------------------------------------------------------------------------------------- shapes

# A cell's markup, token by token: a string literal (text, group 1); math or a function call (kept as
# it is, group 2); bare figures, as `num` prints them (group 3); strong emphasis (group 4); anything
# else (group 5) stops the rewriting: the cell is measured as it is.
_TOKEN = re.compile(
    r'#"((?:[^"\\\n]|\\["\\])*)"'
    r'|(\$(?:[^$"\\]|\\.|"(?:[^"\\]|\\.)*")*\$'
    r'|#[a-z][\w-]*(?:\((?:[^()"\[\]]|"(?:[^"\\]|\\.)*")*\))?(?:\[(?:[^\[\]#$"\\]|#"(?:[^"\\]|\\.)*")*\])?)'
    r"|([0-9.,− ]+)"
    r"|(\*)"
    r"|(.)",
    re.S,
)
_BARE_NUMBER = re.compile(r"[0-9.,−]+")


@lru_cache(maxsize=8192)
def shape(markup: str) -> tuple[str, frozenset[tuple[bool, str]]]:
    """*markup* with each digit of its text written 0, and what that takes: the (strong, neighbour)
    pairs whose kerning must not depend on the digit (``""``: digit next to digit). Math, function
    calls and anything this does not read are left as they are (no pairs: *markup* itself)."""
    if _BARE_NUMBER.fullmatch(markup):
        return markup.translate(_ZEROS), _needs([(False, markup)])
    out, runs, run, strong = [], [], [], False
    for m in _TOKEN.finditer(markup):
        lit, opaque, bare, star, other = m.groups()
        if other is not None:
            return markup, frozenset()
        if lit is not None:
            out.append('#"' + lit.translate(_ZEROS) + '"')
            run.append(lit.replace('\\"', '"').replace("\\\\", "\\"))
        elif bare is not None:
            out.append(bare.translate(_ZEROS))
            run.append(bare)
        else:  # a style or an opaque box begins: no kerning across it
            out.append(m.group(0))
            runs.append((strong, "".join(run)))
            run = []
            strong ^= star is not None
    if strong:
        return markup, frozenset()
    runs.append((strong, "".join(run)))
    return "".join(out), _needs(runs)


_NEIGHBOURS = re.compile(r"(?<=[0-9])[^0-9]|[^0-9](?=[0-9])")
_DIGIT_PAIR = re.compile(r"[0-9]{2}")


def _needs(runs: list[tuple[bool, str]]) -> frozenset[tuple[bool, str]]:
    needs = set()
    for strong, s in runs:
        needs.update((strong, c) for c in _NEIGHBOURS.findall(s))
        if _DIGIT_PAIR.search(s):
            needs.add((strong, ""))
    return frozenset(needs)


def _check_strings(strong: bool, neighbour: str) -> list[str]:
    """The pairs that show whether every digit kerns with *neighbour* (or with every digit) as 0 does."""
    if neighbour:
        pairs = [d + neighbour for d in DIGITS] + [neighbour + d for d in DIGITS]
    else:
        pairs = [a + b for a in DIGITS for b in DIGITS]
    lit = [f"#{string(p)}" for p in pairs]
    return [f"*{p}*" if strong else p for p in lit]


# ------------------------------------------------------------------------------------------ measuring


class _Measurer:
    """Typst's width and height of cells, by (style, shape), for the life of the process."""

    def __init__(self) -> None:
        self.sizes_of: dict[tuple[str, str], tuple[float, float] | None] = {}
        self.checked: dict[tuple[str, bool, str], bool] = {}  # digits kern as 0 with this neighbour
        self.ok: dict[tuple[str, frozenset], bool] = {}  # ... with all these
        self.key_of: dict[tuple[str, str], tuple[str, str]] = {}  # (style, markup) -> (style, shape)
        self.text_width = 0.0
        self._compiler = None
        self._folder = ""
        self._style = ""

    def sizes(self, cells: list[tuple[str, str]]) -> list[tuple[float, float] | None]:
        """(width, height) in pt of each (style, markup) of *cells*; None for one not measured."""
        fresh = {c for c in cells if c not in self.key_of}
        if fresh:
            if len(self.key_of) > _KEYS_KEPT:
                self.key_of.clear()
            shaped = {c: shape(c[1]) for c in fresh}
            new = {(style, needs) for (style, _), (_, needs) in shaped.items()
                   if needs and (style, needs) not in self.ok}
            checks = {(style, *need) for style, needs in new for need in needs} - self.checked.keys()
            if checks:
                self._measure([], sorted(checks))
            for style, needs in new:
                self.ok[(style, needs)] = all(self.checked[(style, *need)] for need in needs)
            for (style, markup), (s, needs) in shaped.items():
                ok = not needs or self.ok[(style, needs)]  # else a digit kerns unlike 0: as it is
                self.key_of[(style, markup)] = (style, s if ok else markup)
            todo = {self.key_of[c] for c in fresh} - self.sizes_of.keys()
            if todo:
                self._measure(sorted(todo), [])
        return [self.sizes_of[self.key_of[c]] for c in cells]

    def _measure(self, cells: list[tuple[str, str]], checks: list[tuple[str, bool, str]]) -> None:
        items = [f"{style}[{s}]" for style, s in cells]
        for style, strong, c in checks:
            items += [f"{style}[{p}]" for p in _check_strings(strong, c)]
        got = self._sizes(items)
        self.sizes_of.update(zip(cells, got[:len(cells)], strict=True))
        at = len(cells)
        for k in checks:
            n = 20 if k[2] else 100
            ws = [wh[0] if wh else None for wh in got[at:at + n]]
            at += n
            # a neighbour: d+c as 0+c and c+d as c+0; digits together: every pair as 00
            refs = [ws[0]] * 10 + [ws[10]] * 10 if k[2] else [ws[0]] * n
            self.checked[k] = None not in ws and all(abs(w - r) < 1e-9 for w, r in zip(ws, refs, strict=True))
            if not self.checked[k]:
                log.debug("digits kern differently with %r in %s: such cells are measured as they are", k[2], k[0])

    def _sizes(self, items: list[str]) -> list[tuple[float, float] | None]:
        """(width, height) of each Typst expression of *items*; None for one that Typst refuses (found
        by halving, so that it costs its neighbours nothing)."""
        import typst

        try:
            width, got = self._query(items)
        except (typst.TypstError, RuntimeError, ValueError) as exc:
            if len(items) == 1:
                log.debug("table cell not measured (%s): %s", exc, items[0])
                return [None]
            half = len(items) // 2
            return self._sizes(items[:half]) + self._sizes(items[half:])
        self.text_width = width
        return [(float(w), float(h)) for w, h in got]

    def _query(self, items: list[str]) -> tuple[float, list[list[float]]]:
        """One Typst query: the body's text width and [width, height] of each of *items*."""
        import typst

        if not self._folder:  # removed when the process ends, a pool's worker too
            self._folder = tempfile.mkdtemp(prefix="gradekit-widths-")
            Finalize(self, shutil.rmtree, args=(self._folder, True), exitpriority=0)
        path = os.path.join(self._folder, "measure.typ")
        with open(path, "w", encoding="utf-8") as f:
            f.write(self._preamble())
            f.write("#layout(size => context [#metadata((size.width / 1pt, (\n")
            f.write(",\n".join(items))
            f.write(",).map(c => { let m = measure(c); (m.width / 1pt, m.height / 1pt) }))) <gradekit-widths>])\n")
        if self._compiler is None:  # it reads the file again at each query; its fonts stay loaded
            self._compiler = typst.Compiler(input=path, root=self._folder)
        width, got = json.loads(self._compiler.query("<gradekit-widths>", field="value", one=True))
        return float(width), got

    def _preamble(self) -> str:
        """The documents' own set rules (fonts, size, language, page): cells measure as they print."""
        if not self._style:
            self._style = render("_style.typ.j2", {"course": "", "title": "", "key": False,
                                                   "fonts": available_fonts(), "student": {"name": "", "id": ""}})
        return self._style


_MEASURERS: dict[int, _Measurer] = {}


def _measurer() -> _Measurer:
    """This process's measurer (a forked child makes its own: Typst's threads do not survive a fork)."""
    pid = os.getpid()
    if pid not in _MEASURERS:
        _MEASURERS.clear()
        _MEASURERS[pid] = _Measurer()
    return _MEASURERS[pid]
