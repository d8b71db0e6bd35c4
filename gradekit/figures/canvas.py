"""A display list in paper points with a collision-avoiding label placer, rendered to one Figure.

Everything is laid out in points (1/72 in, y up) before matplotlib is touched: the extent of the
drawing, labels included, is then known exactly, so the figure is sized to it with the axes filling
it (data unit = 1 pt, equal aspect, exact limits) — no tight bbox, no constrained layout, and a
true-scale drawing prints at its stated scale. Text sizes come from the font's advance widths
(FreeType, no renderer), so placing labels costs microseconds.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from functools import cache, lru_cache
from itertools import repeat

import numpy as np

FONT = "DejaVu Sans"
SIZE = 8.0
LINE_H = 1.17  # text box height per font size (ascent + descent of DejaVu Sans)

# Okabe–Ito, the colour-blind-safe palette
BLACK = "#000000"
ORANGE = "#E69F00"
SKY = "#56B4E9"
GREEN = "#009E73"
YELLOW = "#F0E442"
BLUE = "#0072B2"
VERMILION = "#D55E00"
PURPLE = "#CC79A7"
GREY = "#777777"
LIGHT = "#D9D9D9"


@lru_cache(maxsize=1)
def _font():
    from matplotlib import font_manager
    from matplotlib.ft2font import FT2Font

    return FT2Font(font_manager.findfont(FONT))


@cache
def _advance(c: str, size: float) -> float:
    """Advance width of character *c* at *size* pt (unhinted, in points)."""
    from matplotlib.ft2font import LoadFlags

    f = _font()
    f.set_size(size, 72)
    return f.load_char(ord(c), LoadFlags.NO_HINTING).linearHoriAdvance / 65536.0


@cache
def _kern(a: str, b: str, size: float) -> float:
    """Kerning between characters *a* and *b* at *size* pt (points; the font's kern table)."""
    from matplotlib.ft2font import Kerning

    f = _font()
    f.set_size(size, 72)
    return f.get_kerning(f.get_char_index(ord(a)), f.get_char_index(ord(b)), Kerning.UNFITTED) / 64.0


@lru_cache(maxsize=4096)
def text_size(text: str, size: float = SIZE) -> tuple[float, float]:
    """Width and height in points of *text* (lines split at newlines) as it is typeset: advance
    widths and kerning summed per character, cached per character, so a new label costs
    microseconds (FreeType's own layout of the string costs ~25 µs a character)."""
    lines = text.split("\n")
    w = 0.0
    for line in lines:
        lw = sum(map(_advance, line, repeat(size)))
        lw += sum(map(_kern, line, line[1:], repeat(size)))  # each pair of neighbours
        w = max(w, lw)
    return w + 1.0, size * LINE_H * len(lines)


STEPS = (0.0, 3.0, 6.0, 10.0, 15.0, 21.0, 28.0, 36.0, 46.0, 58.0, 72.0, 90.0)  # stand-offs tried, pt
LEADER_GAP = 16.0  # a label standing off further than this (pt) gets a leader line to its anchor
REPAIRS = 3  # earlier labels tried in a stuck label's place (see `Canvas.place`)
REACH = 20.0  # how far (pt) beyond its own size from an anchor a label counts as in another's way
_DIRECTIONS = np.c_[np.cos(np.arange(16) * (math.pi / 8)), np.sin(np.arange(16) * (math.pi / 8))]
_DIRECTIONS[np.abs(_DIRECTIONS) < 1e-12] = 0.0  # the 16 directions a label is tried in, exact on the axes
_DIRECTIONS.flags.writeable = False
_T = np.linspace(0, 2 * math.pi, 25)
_CIRCLE = np.column_stack([np.cos(_T), np.sin(_T)])  # a circle's 25 points, radius 1 (np.c_ costs ~15 µs a call)
_CIRCLE.flags.writeable = False
del _T


@lru_cache(maxsize=4096)
def _stand_off(w: float, h: float) -> np.ndarray:
    """Per direction of `_DIRECTIONS`: how far beyond a circle the centre of a *w*×*h* box stands
    when the box touches the circle in that direction (read-only)."""
    D = _DIRECTIONS
    with np.errstate(divide="ignore"):
        k = np.minimum(np.where(D[:, 0] != 0, w / 2 / np.abs(D[:, 0]), np.inf),
                       np.where(D[:, 1] != 0, h / 2 / np.abs(D[:, 1]), np.inf))
    k.flags.writeable = False
    return k


@lru_cache(maxsize=64)
def _slots(na: int, nd: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Anchor and direction rank of each of *na* × *nd* candidates, and the order `Canvas.put`
    breaks ties in within a stand-off (the earlier anchor, then the direction nearer *prefer*)."""
    anchor = np.repeat(np.arange(na), nd)
    rank = np.tile(np.arange(nd), na)
    order = 1.5 * anchor + 0.2 * rank
    for a in (anchor, rank, order):
        a.flags.writeable = False
    return anchor, rank, order


@lru_cache(maxsize=16)
def _groups(steps: tuple) -> tuple[np.ndarray, ...]:
    """*steps* (stand-offs) in the groups `Canvas.put` scores at a time: without, with leaders."""
    steps = np.asarray(steps, float)
    groups = tuple(g for g in (steps[steps <= LEADER_GAP], steps[steps > LEADER_GAP]) if len(g))
    for g in groups:
        g.flags.writeable = False
    return groups


def _cost(placed: list) -> float:
    """What labels cost: their penalties and stand-offs, as `Canvas.put` scores them."""
    return sum(pen + 0.25 * gap for _t, _a, _b, pen, gap in placed)


@dataclass
class Item:
    """One primitive: kind and its arguments, all coordinates in points."""

    kind: str
    xy: np.ndarray
    style: dict = field(default_factory=dict)


class _Segments:
    """Segments (rows as `Canvas._segment_array` gives them) with what `meets` and `lines_hit` need
    of them alone (extents, directions, which rows continue the line of the row before) worked out
    once, so a canvas pays for it once per change of its segment list, not once per label.

    Tables are segment × candidate (N×K): numpy runs along the last axis, and there are ~10 times
    more candidates than segments; the arithmetic is `segment_box_hits`'s, value for value.
    """

    def __init__(self, S: np.ndarray) -> None:
        self.S = S
        px, py, qx, qy, hw = (S[:, i, None] for i in range(5))  # N×1 columns
        self.px, self.py, self.hw = px, py, hw
        self.dx, self.dy = qx - px, qy - py
        self.adx, self.ady = np.abs(self.dx), np.abs(self.dy)
        self.xlo, self.xhi = np.minimum(px, qx), np.maximum(px, qx)
        self.ylo, self.yhi = np.minimum(py, qy), np.maximum(py, qy)
        # row n + 1 goes on from row n: one polyline (same line number), consecutive rows
        self.joined = ((S[1:, 5] == S[:-1, 5]) & (S[1:, 6] - S[:-1, 6] == 1.0))[:, None] if S.shape[1] > 6 else None
        self.any_joined = self.joined is not None and bool(self.joined.any())

    def meets(self, boxes: np.ndarray) -> np.ndarray:
        """N×K: whether segment n meets box k (K×4: x0, y0, x1, y1), grown by the half width.

        Separating axes: the segment's bounding box must overlap the box, and the box's corners must
        not all lie strictly on one side of the segment's line (the extremes of the cross product
        over a box are its value at the centre ± the half sizes weighted by |dx|, |dy|). Touching
        counts.
        """
        hw = self.hw
        bx0, by0, bx1, by1 = boxes.T
        overlap = ((self.xlo <= bx1 + hw) & (self.xhi >= bx0 - hw)
                   & (self.ylo <= by1 + hw) & (self.yhi >= by0 - hw))
        cx, cy = (bx0 + bx1) / 2, (by0 + by1) / 2
        hx, hy = (bx1 - bx0) / 2 + hw, (by1 - by0) / 2 + hw
        side = self.dx * (cy - self.py) - self.dy * (cx - self.px)
        return overlap & (np.abs(side) <= self.adx * hy + self.ady * hx)

    def lines_hit(self, H: np.ndarray) -> np.ndarray:
        """Per column of *H* (N×K: whether segment n meets candidate k, as `meets` gives it), how
        many lines the candidate meets: a run of consecutive segments of one polyline (an arc's
        chords, a leader meeting two chords at their common vertex) is one line."""
        n = H.sum(axis=0)
        if self.any_joined:
            n = n - (H[1:] & H[:-1] & self.joined).sum(axis=0)
        return n


def segment_box_hits(S: np.ndarray, boxes: np.ndarray) -> np.ndarray:
    """K×N: whether segment n of *S* (x0, y0, x1, y1, half width) meets box k (`_Segments.meets`)."""
    return _Segments(S).meets(boxes).T


def _leader_hits(S: np.ndarray, P: np.ndarray, Q: np.ndarray, pad: float = 0.5) -> np.ndarray:
    """K×N: whether leader P[k]–Q[k] comes within segment n's half width (+ *pad*) of segment n of
    *S* (x0, y0, x1, y1, half width): crosses or touches it.

    Points are (x, y) pairs of arrays, K×1 for the leaders and N for the segments, so every table
    is K×N (no trailing axis of two to sum over or move: those cost more than the arithmetic).
    """
    a, b, hw = (S[:, 0], S[:, 1]), (S[:, 2], S[:, 3]), S[:, 4]
    p, q = (P[:, 0, None], P[:, 1, None]), (Q[:, 0, None], Q[:, 1, None])

    def cross(o, u, v):
        return (u[0] - o[0]) * (v[1] - o[1]) - (u[1] - o[1]) * (v[0] - o[0])

    def point_seg(x, u, v):
        dx, dy = v[0] - u[0], v[1] - u[1]
        ex, ey = x[0] - u[0], x[1] - u[1]
        t = np.clip((ex * dx + ey * dy) / np.maximum(dx * dx + dy * dy, 1e-12), 0.0, 1.0)
        return np.hypot(ex - dx * t, ey - dy * t)

    crossing = (cross(a, b, p) * cross(a, b, q) < 0) & (cross(p, q, a) * cross(p, q, b) < 0)
    dist = np.minimum(np.minimum(point_seg(p, a, b), point_seg(q, a, b)),
                      np.minimum(point_seg(a, p, q), point_seg(b, p, q)))
    return crossing | (dist < hw + pad)


def _lines_hit(H: np.ndarray, S: np.ndarray) -> np.ndarray:
    """Per row of *H* (K×N: whether candidate k meets segment n of *S*, rows as `_segment_array`
    gives them), how many lines it meets (`_Segments.lines_hit`)."""
    return _Segments(S).lines_hit(H.T)


def seg_distance(a, b, c, d) -> float:
    """Shortest distance between segments a–b and c–d."""
    a, b, c, d = (np.asarray(v, float) for v in (a, b, c, d))

    def point_seg(p, q, r):
        v = r - q
        t = float(np.clip(np.dot(p - q, v) / max(float(np.dot(v, v)), 1e-12), 0.0, 1.0))
        return float(np.hypot(*(p - q - v * t)))

    def cross(o, p, q):
        return (p[0] - o[0]) * (q[1] - o[1]) - (p[1] - o[1]) * (q[0] - o[0])

    if (cross(a, b, c) * cross(a, b, d) < 0) and (cross(c, d, a) * cross(c, d, b) < 0):
        return 0.0
    return min(point_seg(a, c, d), point_seg(b, c, d), point_seg(c, a, b), point_seg(d, a, b))


class Canvas:
    """Primitives in points plus the obstacles labels must avoid."""

    def __init__(self) -> None:
        self.items: list[Item] = []
        self.segments: list[tuple[np.ndarray, np.ndarray, float, int]] = []  # p, q, half width, line
        self.lines = 0  # lines (polylines) drawn as obstacles so far: a segment's line is its number
        self.boxes: list[tuple[float, float, float, float]] = []  # placed labels and solid marks
        self.pending: list[tuple[float, int, tuple, dict]] = []  # labels placed once all lines are in
        self.placed: list[tuple[str, np.ndarray, np.ndarray, float, float]] = []  # text, anchors, box, penalty, gap
        self.alt: list[str] = []  # the drawing in words, sentence by sentence, written as it is drawn

    def describe(self, sentence: str) -> None:
        """Add *sentence* to the figure's text alternative (`description`)."""
        if sentence:
            self.alt.append(sentence.strip())

    def description(self) -> str:
        """The figure's text alternative: what was drawn, in the order it was described."""
        return " ".join(s if s.endswith((".", ":")) else s + "." for s in self.alt)

    # -- primitives -------------------------------------------------------------------------
    def line(self, pts, color: str = BLACK, lw: float = 1.0, ls: str = "-", gid: str | None = None,
             obstacle: bool = True, z: float = 2.0, cap: str = "round") -> None:
        xy = np.asarray(pts, float).reshape(-1, 2)
        self.items.append(Item("line", xy, dict(color=color, lw=lw, ls=ls, gid=gid, z=z, cap=cap)))
        if obstacle:
            self.lines += 1
            for a, b in zip(xy[:-1], xy[1:], strict=True):
                self.segments.append((a, b, lw / 2 + 1.0, self.lines))

    def polygon(self, pts, fc: str = "white", ec: str = BLACK, lw: float = 1.0, z: float = 3.0,
                gid: str | None = None, obstacle: bool = True) -> None:
        xy = np.asarray(pts, float).reshape(-1, 2)
        self.items.append(Item("polygon", xy, dict(fc=fc, ec=ec, lw=lw, z=z, gid=gid)))
        if obstacle:
            self.boxes.append((*xy.min(axis=0) - 1.0, *xy.max(axis=0) + 1.0))

    def circle(self, c, r: float, fc: str = "white", ec: str = BLACK, lw: float = 1.0, z: float = 5.0,
               gid: str | None = None, obstacle: bool = True) -> None:
        c = np.asarray(c, float)
        self.polygon(c + r * _CIRCLE, fc, ec, lw, z, gid, obstacle)

    def arrow(self, tail, head, color: str = BLACK, lw: float = 1.3, head_len: float = 7.0,
              gid: str | None = None, z: float = 6.0, ls: str = "-") -> None:
        tail, head = np.asarray(tail, float), np.asarray(head, float)
        d = head - tail
        n = float(np.hypot(*d))
        if n < 1e-9:
            return
        u = d / n
        hl = min(head_len, 0.6 * n)
        base = head - u * hl
        w = np.array([-u[1], u[0]]) * hl * 0.36
        self.line([tail, base + u * 0.5], color, lw, ls, gid, z=z, cap="butt")
        self.polygon([head, base + w, base - w], color, color, 0.5, z, None)

    def arc(self, c, r: float, a0: float, a1: float, color: str = BLACK, lw: float = 1.0,
            head: bool = True, gid: str | None = None, z: float = 6.0, ls: str = "-") -> None:
        """A circular arc from angle *a0* to *a1* (radians, CCW if a1 > a0) with an arrowhead at a1."""
        c = np.asarray(c, float)
        n = max(8, int(abs(a1 - a0) / 0.08))
        hl = 6.0
        trim = min(abs(a1 - a0) * 0.45, hl / r) if head else 0.0
        sgn = 1.0 if a1 >= a0 else -1.0
        t = np.linspace(a0, a1 - sgn * trim, n)
        self.line(c + r * np.column_stack([np.cos(t), np.sin(t)]), color, lw, ls, gid, z=z, cap="butt", obstacle=False)
        t = np.linspace(a0, a1, max(3, int(abs(a1 - a0) / 0.3) + 1))  # coarse copy for the label placer
        xy = c + r * np.column_stack([np.cos(t), np.sin(t)])
        self.lines += 1
        self.segments += [(p, q, lw / 2 + 1.0, self.lines) for p, q in zip(xy[:-1], xy[1:], strict=True)]
        if head:
            tip = c + r * np.array([math.cos(a1), math.sin(a1)])
            back = c + r * np.array([math.cos(a1 - sgn * trim), math.sin(a1 - sgn * trim)])
            self.arrow(back - (tip - back) * 0.01, tip, color, lw, head_len=hl, z=z)

    def text(self, xy, s: str, color: str = BLACK, size: float = SIZE, ha: str = "center",
             gid: str | None = None, weight: str = "normal", obstacle: bool = True) -> None:
        """Text centred (vertically) at *xy*, no placement; *ha* as in matplotlib."""
        xy = np.asarray(xy, float)
        w, h = text_size(s, size)
        x0 = xy[0] - {"center": w / 2, "left": 0.0, "right": w}[ha]
        self.items.append(Item("text", xy, dict(s=s, color=color, size=size, ha=ha, gid=gid, weight=weight)))
        if obstacle:
            self.boxes.append((x0, xy[1] - h / 2, x0 + w, xy[1] + h / 2))

    # -- labels -----------------------------------------------------------------------------
    def penalties(self, boxes: np.ndarray, pad: float = 1.5, free_only: bool = False) -> np.ndarray:
        """Penalty of each candidate label box (K×4: x0, y0, x1, y1): 0 when it touches nothing.

        Overlap with a placed label or mark costs 10 + its area; crossing a line costs 25 (an arc
        once, however many of its chords the box meets). With *free_only*, lines are counted only
        for the boxes on no mark: enough to tell which boxes are free (penalty 0), and cheaper; the
        penalty of a box on a mark then leaves out its lines.
        """
        pen = np.zeros(len(boxes))
        if self.boxes:
            corners = np.ascontiguousarray(boxes.T)  # rows x0, y0, x1, y1: quicker to reduce along
            lo0, lo1 = corners[:2].min(axis=1) - 8.0
            hi0, hi1 = corners[2:].max(axis=1) + 8.0
            B = self._box_array()
            # only the marks near the candidates: which marks are summed fixes the last bit of a
            # sum of three or more (numpy sums over 8 terms pairwise), so this filter stays
            near = (B[:, 2] > lo0) & (B[:, 0] < hi0) & (B[:, 3] > lo1) & (B[:, 1] < hi1)
            B = B[near]
            if len(B):
                ox = np.minimum(boxes[:, None, 2], B[None, :, 2]) - np.maximum(boxes[:, None, 0], B[None, :, 0]) + pad
                oy = np.minimum(boxes[:, None, 3], B[None, :, 3]) - np.maximum(boxes[:, None, 1], B[None, :, 1]) + pad
                hit = (ox > 0) & (oy > 0)
                pen += np.where(hit, 10.0 + ox * oy, 0.0).sum(axis=1)
        if self.segments:
            # Every segment, no proximity filter: one too far from the boxes to meet any of them
            # adds nothing to a count, and a run of a line's chords that meet a box is consecutive
            # rows either way. At a few dozen segments the filter costs more than it saves.
            segs = self._segments()
            if free_only:
                clear = np.flatnonzero(pen == 0.0)
                pen[clear] += 25.0 * segs.lines_hit(segs.meets(boxes[clear]))
            else:
                pen += 25.0 * segs.lines_hit(segs.meets(boxes))
        return pen

    def _segment_array(self) -> np.ndarray:
        """`segments` as an N×7 array (x0, y0, x1, y1, half width, line, row)."""
        return self._segments().S

    def _segments(self) -> _Segments:
        """`segments` as `_Segments`, rebuilt only when the list changed (appended or replaced)."""
        key = (id(self.segments), len(self.segments))
        if getattr(self, "_seg_cache", (None, None))[1] != key:
            arr = np.array([(p[0], p[1], q[0], q[1], hw, ln, i) for i, (p, q, hw, ln) in enumerate(self.segments)],
                           float).reshape(-1, 7)
            self._seg_cache = (_Segments(arr), key)
        return self._seg_cache[0]

    def _box_array(self) -> np.ndarray:
        """`boxes` as an N×4 array, rebuilt only when the list changed (appended or replaced)."""
        key = (id(self.boxes), len(self.boxes))
        if getattr(self, "_box_cache", (None, None))[1] != key:
            self._box_cache = (np.array(self.boxes, float).reshape(-1, 4), key)
        return self._box_cache[0]

    def label(self, s: str, anchors, color: str = BLACK, size: float = SIZE, clear: float = 4.0,
              prefer=None, gid: str | None = None, priority: float = 0.0) -> None:
        """Queue label *s* for `place`: labels go in after every line, lowest *priority* first."""
        self.pending.append((priority, len(self.pending), (s, anchors),
                             dict(color=color, size=size, clear=clear, prefer=prefer, gid=gid)))

    def place(self) -> None:
        """Place the queued labels (see `put`), then repair what the order got wrong.

        Labels go in one by one, so an early label may take the only free spot of a later one
        that has fewer (a short dimension beside a crowded pivot, a force's label at its tail).
        When a label ends up on a line or another label, each earlier label within its reach is
        tried in turn, nearest first: both are taken off, the stuck label is put first, then the
        other; the swap is kept if neither is then on anything and the two cost less than before
        (`put`'s scores), else undone.
        """
        pending, self.pending = self.pending, []
        queue = [(args, kw) for _p, _n, args, kw in sorted(pending, key=lambda t: (t[0], t[1]))]
        added = []  # per label: what its put added (text, leader, box, placed entry)
        for args, kw in queue:
            added.append(self._put_recorded(args, kw))
        for b in range(len(queue)):
            if added[b][3][0][3] < 25.0:
                continue
            for j in self._in_the_way([a[3][0] for a in added], b)[:REPAIRS]:
                before = added[b][3][0], added[j][3][0]
                self._take_off(added[b], added[j])
                got = [self._put_recorded(*queue[k]) for k in (b, j)]
                after = got[0][3][0], got[1][3][0]
                if max(after[0][3], after[1][3]) < 25.0 and _cost(after) < _cost(before):
                    added[b], added[j] = got
                    break
                self._take_off(*got)
                self._put_back(added[b], added[j])

    def _put_recorded(self, args: tuple, kw: dict) -> tuple:
        """`put` one label; return what it added: (items, segments, boxes, placed entries)."""
        ni, ns, nb, npl = len(self.items), len(self.segments), len(self.boxes), len(self.placed)
        self.put(*args, **kw)
        return self.items[ni:], self.segments[ns:], self.boxes[nb:], self.placed[npl:]

    def _take_off(self, *labels: tuple) -> None:
        """Remove what `put` added for *labels* (as `_put_recorded` returns it) from the drawing."""
        for attr, i in (("items", 0), ("segments", 1), ("boxes", 2), ("placed", 3)):
            gone = {id(x) for lab in labels for x in lab[i]}
            setattr(self, attr, [x for x in getattr(self, attr) if id(x) not in gone])
        self._seg_cache = self._box_cache = (None, None)

    def _put_back(self, *labels: tuple) -> None:
        for lab in labels:
            self.items += lab[0]
            self.segments += lab[1]
            self.boxes += lab[2]
            self.placed += lab[3]
        self._seg_cache = self._box_cache = (None, None)

    @staticmethod
    def _in_the_way(placed: list, bad: int) -> list[int]:
        """The labels placed before *placed*[bad] whose boxes lie within its reach (a leader's
        length beyond its own size from one of its anchors), nearest first."""
        _t, A, box, _pen, _gap = placed[bad]
        reach = (box[2] - box[0]) / 2 + (box[3] - box[1]) / 2 + REACH
        near = []
        for j in range(bad):
            b = placed[j][2]
            dx = np.maximum(np.maximum(b[0] - A[:, 0], A[:, 0] - b[2]), 0.0)
            dy = np.maximum(np.maximum(b[1] - A[:, 1], A[:, 1] - b[3]), 0.0)
            d = float(np.min(np.hypot(dx, dy)))
            if d < reach:
                near.append((d, j))
        return [j for _d, j in sorted(near)]

    def put(self, s: str, anchors, color: str = BLACK, size: float = SIZE, clear: float = 4.0,
            prefer=None, gid: str | None = None, steps=STEPS) -> np.ndarray:
        """Place *s* next to one of its anchors; return the text centre.

        Candidates are boxes touching a circle of radius *clear* (+ step) around each anchor in
        16 directions. The candidate that touches nothing and lies nearest wins (ties: the earlier
        anchor, then the direction nearest *prefer*); when none is free, the one with the least
        overlap (a leader across a line costs less than a label on one). A label that has to stand
        off further than `LEADER_GAP` gets a thin leader line to its anchor, so it is never read as
        naming something else; a leader through a label or mark, or across a line (once a line,
        not the line its anchor lies on, which it leaves from underneath), is an overlap.
        """
        w, h = text_size(s, size)
        A = np.asarray(anchors, float).reshape(-1, 2)
        D, k = _DIRECTIONS, _stand_off(w, h)
        if prefer is not None:
            pv = np.asarray(prefer, float)
            pn = float(np.hypot(*pv))
            if pn > 0:
                nearest = np.argsort(-(D @ (pv / pn)), kind="stable")
                D, k = D[nearest], k[nearest]
        na = len(A)
        anchor, rank, order = _slots(na, len(D))  # order: ties within a stand-off, the earlier anchor, then *prefer*
        best = None  # (score, centre, box, pen, gap, leader or None)
        # Stand-offs are scored a group at a time (one call for the near ones, one for those with
        # leaders): most labels find a free spot within 6 pt, and one call over a few hundred
        # candidates costs less than two over fewer. Then nearest first, as if one by one.
        for group in _groups(steps if isinstance(steps, tuple) else tuple(np.asarray(steps, float).tolist())):
            r = clear + group  # (G,)
            C = (A[None, :, None, :] + D[None, None, :, :] * (r[:, None] + k[None, :])[:, None, :, None])
            C = C.reshape(len(group), -1, 2)
            half = np.array([w / 2, h / 2])
            boxes = np.concatenate([C - half, C + half], axis=2)
            leader = group[0] > LEADER_GAP
            # lines first counted only where they decide whether a candidate is free (see below)
            pen = self.penalties(boxes.reshape(-1, 4), free_only=not leader).reshape(len(group), -1)
            if leader:  # a leader from the anchor's clear circle to the box must cross nothing either
                start = np.broadcast_to(A[anchor] + D[rank] * clear, C.shape).reshape(-1, 2)
                end = (A[anchor][None] + D[rank][None] * r[:, None, None]).reshape(-1, 2)
                # ... but what the anchor lies on (the bar a dimension names, the arrow of a load) it
                # leaves, drawn under it: checked from where it comes out of that line's width
                out = np.full(na, clear)
                if self.segments:
                    S = self._segment_array()
                    lo, hi = np.minimum(start, end).min(axis=0) - 4.0, np.maximum(start, end).max(axis=0) + 4.0
                    S = S[np.all(np.maximum(S[:, :2], S[:, 2:4]) > lo, axis=1)
                          & np.all(np.minimum(S[:, :2], S[:, 2:4]) < hi, axis=1)]
                    if len(S):
                        own = _leader_hits(S, A, A, pad=1.0 - S[:, 4])  # anchor within 1 pt of the centre line
                        out = np.maximum(clear, np.where(own, S[None, :, 4] + 0.6, 0.0).max(axis=1))
                check = np.broadcast_to(A[anchor] + D[rank] * out[anchor, None], C.shape).reshape(-1, 2)
                if self.segments and len(S):
                    pen += 8.0 * _lines_hit(_leader_hits(S, check, end), S).reshape(pen.shape)
                if self.boxes:
                    seg = np.column_stack([check, end, np.full(len(start), 0.5)])
                    pen += 25.0 * segment_box_hits(seg, self._box_array()).sum(axis=0).reshape(pen.shape)
                start, end = start.reshape(C.shape), end.reshape(C.shape)
            # the nearest stand-off with a free candidate wins with its free one of least order ...
            free = pen == 0.0
            with_free = np.flatnonzero(free.any(axis=1))
            if len(with_free):
                g = int(with_free[0])
                i = int(np.argmin(np.where(free[g], order, np.inf)))
                line = (start[g, i], end[g, i]) if leader else None
                best = (None, C[g, i], boxes[g, i], float(pen[g, i]), float(group[g]), line)
                break
            # ... else the least score so far (the nearer stand-off on ties) is kept
            if not leader:  # every candidate's full penalty is needed now
                pen = self.penalties(boxes.reshape(-1, 4)).reshape(len(group), -1)
            for g, step in enumerate(group):
                score = pen[g] + 0.25 * step + 0.02 * (step + order)
                i = int(np.argmin(score))
                if best is None or score[i] < best[0]:
                    line = (start[g, i], end[g, i]) if leader else None
                    best = (score[i], C[g, i], boxes[g, i], float(pen[g, i]), float(step), line)
        assert best is not None
        _, centre, box, pen_i, gap_i, line = best
        if line is not None:
            self.line(list(line), color, 0.5, z=1.8)
        self.text(centre, s, color, size, gid=gid)
        self.placed.append((s, A, np.asarray(box), pen_i, float(gap_i)))
        return np.asarray(centre)

    def scale_bar(self, length: float, text: str, gap: float = 12.0, gid: str | None = None) -> float:
        """A bar of *length* points with end ticks and *text*, under the drawing; returns its y."""
        x0, y0, _, _ = self.extent()
        y = y0 - gap
        self.line([(x0, y), (x0 + length, y)], BLACK, 1.2, gid=gid, cap="butt")
        for xx in (x0, x0 + length):
            self.line([(xx, y - 3), (xx, y + 3)], BLACK, 0.8, cap="butt")
        self.text((x0 + length + 4, y), text, ha="left")
        return y

    # -- composition ------------------------------------------------------------------------
    def extent(self) -> tuple[float, float, float, float]:
        self.place()
        pts = [it.xy.reshape(-1, 2) for it in self.items if it.kind != "text"]
        pts = np.concatenate(pts) if pts else np.zeros((1, 2))
        lo, hi = pts.min(axis=0), pts.max(axis=0)
        x0, y0, x1, y1 = float(lo[0]), float(lo[1]), float(hi[0]), float(hi[1])
        for it in self.items:
            if it.kind == "text":
                w, h = text_size(it.style["s"], it.style["size"])
                left = it.xy[0] - {"center": w / 2, "left": 0.0, "right": w}[it.style["ha"]]
                x0, x1 = min(x0, left), max(x1, left + w)
                y0, y1 = min(y0, it.xy[1] - h / 2), max(y1, it.xy[1] + h / 2)
        return x0, y0, x1, y1

    def shift(self, d) -> None:
        self.place()
        d = np.asarray(d, float)
        for it in self.items:
            it.xy = it.xy + d
        self.segments = [(p + d, q + d, hw, ln) for p, q, hw, ln in self.segments]
        self.boxes = [(b[0] + d[0], b[1] + d[1], b[2] + d[0], b[3] + d[1]) for b in self.boxes]
        d4 = np.concatenate([d, d])
        self.placed = [(t, a + d, b + d4, pen, gap) for t, a, b, pen, gap in self.placed]
        self._seg_cache = self._box_cache = (None, None)  # new lists, same lengths: rebuild

    def absorb(self, other: Canvas) -> None:
        other.place()
        self.items += other.items
        self.segments += [(p, q, hw, ln + self.lines) for p, q, hw, ln in other.segments]
        self.lines += other.lines
        self.boxes += other.boxes
        self.placed += other.placed
        self.alt += other.alt


def row(panels: list[Canvas], gap: float = 28.0) -> Canvas:
    """Panels side by side, bottoms aligned, in one canvas."""
    out = Canvas()
    x = 0.0
    for p in panels:
        x0, y0, x1, _ = p.extent()
        p.shift((x - x0, -y0))
        out.absorb(p)
        x += x1 - x0 + gap
    return out


def render(cv: Canvas, margin: float = 6.0, extent: tuple[float, float, float, float] | None = None):
    """The matplotlib Figure of *cv*: sized to its extent plus *margin* points, axes filling it."""
    # No backend is chosen: a bare Figure saves to SVG/PNG without one, and a notebook's or
    # pyplot user's backend stays theirs.
    from matplotlib.collections import LineCollection
    from matplotlib.figure import Figure
    from matplotlib.lines import Line2D
    from matplotlib.patches import Polygon
    from matplotlib.text import Text
    from matplotlib.transforms import Affine2D

    x0, y0, x1, y1 = extent or cv.extent()
    x0, y0, x1, y1 = x0 - margin, y0 - margin, x1 + margin, y1 + margin
    W, H = x1 - x0, y1 - y0
    fig = Figure(figsize=(W / 72.0, H / 72.0), dpi=72)
    # No Axes: every item is a figure artist placed in paper points (1 unit = 1 pt from the
    # lower-left corner). An Axes costs ~7 ms to build (ticks, spines, autoscaling) for nothing.
    T = Affine2D().translate(-x0, -y0).scale(1.0 / 72.0) + fig.dpi_scale_trans
    add = fig.add_artist
    plain: dict[tuple, list[np.ndarray]] = {}
    for it in cv.items:
        st = it.style
        if it.kind == "line":
            if st["gid"] is None:
                plain.setdefault((st["color"], st["lw"], st["ls"], st["z"], st["cap"]), []).append(it.xy)
                continue
            ln = Line2D(it.xy[:, 0], it.xy[:, 1], color=st["color"], lw=st["lw"], ls=st["ls"],
                        zorder=st["z"], solid_capstyle=st["cap"], dash_capstyle="butt", transform=T)
            ln.set_gid(st["gid"])
            add(ln)
        elif it.kind == "polygon":
            poly = Polygon(it.xy, closed=True, fc=st["fc"], ec=st["ec"], lw=st["lw"], zorder=st["z"], transform=T)
            if st["gid"]:
                poly.set_gid(st["gid"])
            add(poly)
        elif it.kind == "text":
            # parse_math off: a label from a problem file is text, never mathtext ("$x^$" would not parse)
            t = Text(it.xy[0], it.xy[1], st["s"], color=st["color"], fontsize=st["size"], ha=st["ha"],
                     va="center", family=FONT, zorder=8, weight=st["weight"], transform=T, parse_math=False)
            t.set_gid(st["gid"])
            add(t)
    for (color, lw, ls, z, cap), segs in plain.items():
        add(LineCollection(segs, colors=color, linewidths=lw, linestyles=ls, zorder=z, capstyle=cap, transform=T))
    fig._gradekit_origin = (x0, y0)  # paper position of the figure's lower-left corner, in points
    return fig


# matplotlib's dash patterns (in units of the line width), so both renderers draw alike
_DASHES = {"--": (3.7, 1.6), "-.": (6.4, 1.6, 1.0, 1.6), ":": (1.0, 1.65)}
_ANCHOR = {"center": "middle", "left": "start", "right": "end"}


def svg(cv: Canvas, margin: float = 6.0, extent: tuple[float, float, float, float] | None = None) -> bytes:
    """SVG of *cv* written straight from the display list: the same drawing as `render` + savefig
    (sizes in points, z-order, dash patterns, text as text in DejaVu Sans), without matplotlib.

    Documents use it: building and saving a matplotlib Figure costs ~25 ms a figure, this ~1 ms.
    The output is deterministic (no ids but the items' gids, no dates).
    """
    from xml.sax.saxutils import escape, quoteattr

    x0, y0, x1, y1 = extent or cv.extent()
    x0, y0, x1, y1 = x0 - margin, y0 - margin, x1 + margin, y1 + margin
    W, H = x1 - x0, y1 - y0

    def pts(xy: np.ndarray) -> str:
        return " ".join(f"{x - x0:.2f},{y1 - y:.2f}" for x, y in xy.tolist())

    def gid(st: dict) -> str:
        return f" id={quoteattr(st['gid'])}" if st.get("gid") else ""

    z_text = 8.0
    order = sorted(range(len(cv.items)), key=lambda i: (cv.items[i].style.get("z", z_text), i))
    out = [
        '<?xml version="1.0" encoding="utf-8" standalone="no"?>',
        f'<svg xmlns="http://www.w3.org/2000/svg" width="{W:.2f}pt" height="{H:.2f}pt" '
        f'viewBox="0 0 {W:.2f} {H:.2f}" version="1.1">',
    ]
    for i in order:
        it = cv.items[i]
        st = it.style
        if it.kind == "line":
            dash = _DASHES.get(st["ls"])
            lw = st["lw"]
            dashes = (' stroke-dasharray="' + ",".join(f"{d * lw:.2f}" for d in dash) + '"') if dash else ""
            out.append(
                f'<polyline{gid(st)} points="{pts(it.xy)}" fill="none" stroke="{st["color"]}" '
                f'stroke-width="{st["lw"]:.2f}" stroke-linecap="{"butt" if dash else st["cap"]}" '
                f'stroke-linejoin="round"{dashes}/>'
            )
        elif it.kind == "polygon":
            fill = "none" if st["fc"] in ("none", None) else st["fc"]
            out.append(
                f'<polygon{gid(st)} points="{pts(it.xy)}" fill="{fill}" stroke="{st["ec"]}" '
                f'stroke-width="{st["lw"]:.2f}" stroke-linejoin="miter"/>'
            )
        elif it.kind == "text":
            lines = st["s"].split("\n")
            size = st["size"]
            x, y = it.xy[0] - x0, y1 - it.xy[1]
            top = y - (len(lines) - 1) * size * LINE_H / 2  # the block is centred on y, like va="center"
            weight = ' font-weight="bold"' if st["weight"] == "bold" else ""
            spans = "".join(
                f'<tspan x="{x:.2f}" y="{top + k * size * LINE_H:.2f}">{escape(line)}</tspan>'
                for k, line in enumerate(lines)
            )
            out.append(
                f'<text{gid(st)} font-family="{FONT}" font-size="{size:g}" fill="{st["color"]}"{weight} '
                f'text-anchor="{_ANCHOR[st["ha"]]}" dominant-baseline="central">{spans}</text>'
            )
    out.append("</svg>")
    return ("\n".join(out) + "\n").encode("utf-8")
