"""The label placer's fast penalties: the same values as a plain pair-by-pair reading of their rule,
and, to the last bit, as the vectorised formulation they replaced (whose floats the figures carry)."""

from __future__ import annotations

import numpy as np
import pytest

from gradekit.figures.canvas import Canvas, _hits, _leader_hits, _lines_hit, _seg_hits_box, seg_distance

GRID = 0.25  # coordinates on a binary grid: every sum and product below is exact, touching is exact


def _grid(rng, lo: float, hi: float, size=None):
    return np.round(rng.uniform(lo, hi, size) / GRID) * GRID


def _random_canvas(rng, n_lines: int, n_marks: int, arcs: int = 0) -> Canvas:
    """Polylines (some with zero-length pieces) and marks on the grid, plus *arcs* (off the grid)."""
    cv = Canvas()
    for _ in range(n_lines):
        pts = _grid(rng, 0.0, 60.0, (int(rng.integers(2, 5)), 2))
        if rng.random() < 0.3:
            pts[1] = pts[0]  # a zero-length segment
        if rng.random() < 0.3:
            pts[:, int(rng.integers(2))] = pts[0, 0]  # axis-parallel: lies along box edges
        cv.line(pts, lw=float(rng.choice([0.5, 1.0, 1.5])))
    for _ in range(arcs):
        a0 = rng.uniform(0, 6)
        cv.arc(rng.uniform(10, 50, 2), rng.uniform(4, 20), a0, a0 + rng.uniform(0.5, 5), head=False)
    for _ in range(n_marks):
        x, y = _grid(rng, 0.0, 60.0, 2)
        cv.boxes.append((x, y, x + _grid(rng, 0.5, 12.0), y + _grid(rng, 0.5, 6.0)))
    return cv


def _candidates(rng, cv: Canvas, k: int) -> np.ndarray:
    """Label-sized boxes, a third of them with an edge on a segment's end (grown by its half width)
    or a mark's edge. Only ends on the grid: touching an arc's chord is exact for neither method."""
    w, h = _grid(rng, 2.0, 20.0), _grid(rng, 2.0, 10.0)
    x0, y0 = _grid(rng, -10.0, 65.0, k), _grid(rng, -10.0, 65.0, k)
    ends = [e for p, q, hw, _ln in cv.segments for e in (p - hw, q + hw)] + [np.array(b[2:]) for b in cv.boxes]
    ends = [e for e in ends if not np.any(np.fmod(e, GRID))]
    for i in np.flatnonzero(rng.random(k) < 0.33):
        if ends:
            e = ends[int(rng.integers(len(ends)))]
            x0[i] = e[0] if rng.random() < 0.5 else e[0] - w
            y0[i] = e[1] if rng.random() < 0.5 else e[1] - h
    return np.column_stack([x0, y0, x0 + w, y0 + h])


def _reference(cv: Canvas, boxes: np.ndarray, pad: float = 1.5) -> tuple[list[float], list[int]]:
    """Per box: what its overlaps with marks cost (10 + area each) and how many lines it meets (a
    run of consecutive segments of one line, each met, is one), one pair at a time."""
    marks, lines = [], []
    for x0, y0, x1, y1 in boxes:
        cost = 0.0
        for b in cv.boxes:
            ox = min(x1, b[2]) - max(x0, b[0]) + pad
            oy = min(y1, b[3]) - max(y0, b[1]) + pad
            if ox > 0 and oy > 0:
                cost += 10.0 + ox * oy
        met = [_seg_hits_box(p, q, (x0 - hw, y0 - hw, x1 + hw, y1 + hw)) for p, q, hw, _ln in cv.segments]
        n = 0
        for i, m in enumerate(met):
            same_run = i > 0 and met[i - 1] and cv.segments[i - 1][3] == cv.segments[i][3]
            n += m and not same_run
        marks.append(cost)
        lines.append(n)
    return marks, lines


def _previous_penalties(cv: Canvas, boxes: np.ndarray, pad: float = 1.5) -> np.ndarray:
    """`Canvas.penalties` as it was written before the fast path (near filters, K×N tables): the
    floating-point result the figures were drawn with, kept here as its specification."""
    pen = np.zeros(len(boxes))
    lo, hi = boxes[:, :2].min(axis=0) - 8.0, boxes[:, 2:].max(axis=0) + 8.0
    if cv.boxes:
        B = np.array(cv.boxes, float).reshape(-1, 4)
        B = B[(B[:, 2] > lo[0]) & (B[:, 0] < hi[0]) & (B[:, 3] > lo[1]) & (B[:, 1] < hi[1])]
        if len(B):
            ox = np.minimum(boxes[:, None, 2], B[None, :, 2]) - np.maximum(boxes[:, None, 0], B[None, :, 0]) + pad
            oy = np.minimum(boxes[:, None, 3], B[None, :, 3]) - np.maximum(boxes[:, None, 1], B[None, :, 1]) + pad
            hit = (ox > 0) & (oy > 0)
            pen += np.where(hit, 10.0 + ox * oy, 0.0).sum(axis=1)
    if cv.segments:
        S = np.array([(p[0], p[1], q[0], q[1], hw, ln, i) for i, (p, q, hw, ln) in enumerate(cv.segments)], float)
        smin = np.minimum(S[:, :2], S[:, 2:4]) - S[:, 4:5]
        smax = np.maximum(S[:, :2], S[:, 2:4]) + S[:, 4:5]
        S = S[np.all(smax > lo, axis=1) & np.all(smin < hi, axis=1)]
        if len(S):
            px, py, qx, qy, hw = S[:, 0], S[:, 1], S[:, 2], S[:, 3], S[:, 4]
            dx, dy = qx - px, qy - py
            bx0, by0, bx1, by1 = (boxes[:, i, None] for i in range(4))
            overlap = ((np.minimum(px, qx) <= bx1 + hw) & (np.maximum(px, qx) >= bx0 - hw)
                       & (np.minimum(py, qy) <= by1 + hw) & (np.maximum(py, qy) >= by0 - hw))
            cx, cy = (bx0 + bx1) / 2, (by0 + by1) / 2
            hx, hy = (bx1 - bx0) / 2 + hw, (by1 - by0) / 2 + hw
            H = overlap & (np.abs(dx * (cy - py) - dy * (cx - px)) <= np.abs(dx) * hy + np.abs(dy) * hx)
            n = H.sum(axis=1)
            if len(S) > 1:
                same = (S[1:, 5] == S[:-1, 5]) & (S[1:, 6] - S[:-1, 6] == 1.0)
                n = n - (H[:, 1:] & H[:, :-1] & same).sum(axis=1)
            pen += 25.0 * n
    return pen


@pytest.mark.parametrize("seed", range(40))
def test_lines_met_are_counted_as_pair_by_pair(seed):
    rng = np.random.default_rng(seed)
    cv = _random_canvas(rng, n_lines=int(rng.integers(1, 12)), n_marks=0)
    boxes = _candidates(rng, cv, 120)
    _marks, lines = _reference(cv, boxes)
    assert list(cv.penalties(boxes)) == [25.0 * n for n in lines]


@pytest.mark.parametrize("seed", range(40))
def test_marks_cost_their_overlap_as_pair_by_pair(seed):
    rng = np.random.default_rng(seed)
    cv = _random_canvas(rng, n_lines=0, n_marks=int(rng.integers(1, 25)))
    boxes = _candidates(rng, cv, 120)
    marks, _lines = _reference(cv, boxes)
    assert cv.penalties(boxes) == pytest.approx(marks, rel=1e-12, abs=0.0)


@pytest.mark.parametrize("seed", range(60))
def test_penalties_are_those_of_the_previous_formulation_to_the_bit(seed):
    """Lines, arcs (runs of chords), zero-length pieces, up to 30 marks (numpy sums more than 8
    terms pairwise, so which marks are summed, and in what order, shows in the last bit)."""
    rng = np.random.default_rng(1000 + seed)
    cv = _random_canvas(rng, int(rng.integers(0, 10)), int(rng.integers(0, 30)), arcs=int(rng.integers(0, 4)))
    boxes = _candidates(rng, cv, int(rng.integers(1, 300)))
    got = cv.penalties(boxes)
    assert got.dtype == np.float64 and got.shape == (len(boxes),)
    assert got.tobytes() == _previous_penalties(cv, boxes).tobytes()
    marks, lines = _reference(cv, boxes)
    assert got == pytest.approx([m + 25.0 * n for m, n in zip(marks, lines, strict=True)], rel=1e-12, abs=0.0)


def test_a_leader_added_after_the_first_label_counts_from_then_on():
    """Segments added during placement (a leader) change what the next call sees."""
    cv = Canvas()
    cv.line([(0.0, 0.0), (10.0, 0.0)])
    box = np.array([[20.0, -2.0, 24.0, 2.0]])
    assert cv.penalties(box)[0] == 0.0
    cv.line([(15.0, 0.0), (30.0, 0.0)], lw=0.5)
    assert cv.penalties(box)[0] == 25.0


def test_hits_and_lines_hit_keep_their_layout():
    """`_hits` is K×N (box × segment) and `_lines_hit` reads it so, for the callers outside the
    canvas (the label tests, the leader check)."""
    S = np.array([[0.0, 0.0, 10.0, 0.0, 1.0, 1.0, 0.0], [10.0, 0.0, 10.0, 10.0, 1.0, 1.0, 1.0],
                  [30.0, 30.0, 30.0, 30.0, 1.0, 2.0, 2.0]])
    boxes = np.array([[9.0, -1.0, 11.0, 1.0], [29.0, 29.0, 29.0, 29.0], [50.0, 50.0, 51.0, 51.0]])
    H = _hits(S, boxes)
    assert H.tolist() == [[True, True, False], [False, False, True], [False, False, False]]
    assert _lines_hit(H, S).tolist() == [1, 1, 0]


@pytest.mark.parametrize("seed", range(10))
def test_crowded_marks_are_summed_as_before_to_the_bit(seed):
    """A dozen overlapping marks round the candidates, far ones listed in between: a candidate on
    several marks sums their costs in the order, and grouping, it always did."""
    rng = np.random.default_rng(2000 + seed)
    cv = Canvas()
    for i in range(24):
        x, y = (rng.uniform(0, 20, 2) if i % 2 == 0 else rng.uniform(300, 400, 2))
        cv.boxes.append((x, y, x + rng.uniform(3, 15), y + rng.uniform(2, 8)))
    x0, y0 = rng.uniform(-5, 25, 200), rng.uniform(-5, 25, 200)
    boxes = np.column_stack([x0, y0, x0 + 9.3, y0 + 4.7])
    got = cv.penalties(boxes)
    assert got.tobytes() == _previous_penalties(cv, boxes).tobytes()
    marks, _lines = _reference(cv, boxes)
    assert got == pytest.approx(marks, rel=1e-12, abs=0.0)


def _previous_leader_hits(S, P, Q, pad=0.5):
    """`_leader_hits` as it was written before (points with a trailing axis of two)."""
    a, b, hw = S[None, :, 0:2], S[None, :, 2:4], S[None, :, 4]
    p, q = P[:, None, :], Q[:, None, :]

    def cross(o, u, v):
        return (u[..., 0] - o[..., 0]) * (v[..., 1] - o[..., 1]) - (u[..., 1] - o[..., 1]) * (v[..., 0] - o[..., 0])

    def point_seg(x, u, v):
        d = v - u
        t = np.clip(((x - u) * d).sum(-1) / np.maximum((d * d).sum(-1), 1e-12), 0.0, 1.0)
        return np.hypot(*np.moveaxis(x - u - d * t[..., None], -1, 0))

    crossing = (cross(a, b, p) * cross(a, b, q) < 0) & (cross(p, q, a) * cross(p, q, b) < 0)
    dist = np.minimum(np.minimum(point_seg(p, a, b), point_seg(q, a, b)),
                      np.minimum(point_seg(a, p, q), point_seg(b, p, q)))
    return crossing | (dist < hw + pad)


@pytest.mark.parametrize("seed", range(30))
def test_leader_hits_as_before_and_as_the_distance_between_segments(seed):
    """Leaders against segments: zero-length ones on both sides (an anchor checked against what it
    lies on), shared ends and collinear touching on the grid; then off the grid, against the
    distance of each pair (`seg_distance`) compared with the half width and pad."""
    rng = np.random.default_rng(3000 + seed)
    n, k = int(rng.integers(1, 25)), int(rng.integers(1, 60))
    S = np.column_stack([_grid(rng, 0, 20, (n, 4)), rng.choice([0.75, 1.0, 1.25], n)])
    zero = rng.random(n) < 0.25
    S[zero, 2:4] = S[zero, 0:2]
    P, Q = _grid(rng, 0, 20, (k, 2)), _grid(rng, 0, 20, (k, 2))
    dot = rng.random(k) < 0.2
    Q[dot] = P[dot]  # zero-length leaders
    shared = rng.random(k) < 0.3
    P[shared] = S[rng.integers(n, size=int(shared.sum())), 2:4]  # a leader starting on a segment's end
    pads = [0.5, 1.0 - S[:, 4]]
    for pad in pads:
        assert np.array_equal(_leader_hits(S, P, Q, pad), _previous_leader_hits(S, P, Q, pad))
        assert np.array_equal(_leader_hits(S, P, P, pad), _previous_leader_hits(S, P, P, pad))
    S[:, :4] += rng.uniform(-0.1, 0.1, (n, 4))
    P, Q = P + rng.uniform(-0.1, 0.1, (k, 2)), Q + rng.uniform(-0.1, 0.1, (k, 2))
    expected = [[seg_distance(P[i], Q[i], S[j, :2], S[j, 2:4]) < S[j, 4] + 0.5 for j in range(n)] for i in range(k)]
    assert _leader_hits(S, P, Q).tolist() == expected


@pytest.mark.parametrize("seed", range(20))
def test_free_only_tells_the_free_boxes_and_leaves_out_lines_only_on_marks(seed):
    rng = np.random.default_rng(4000 + seed)
    cv = _random_canvas(rng, int(rng.integers(1, 10)), int(rng.integers(1, 15)), arcs=1)
    boxes = _candidates(rng, cv, 200)
    full, quick = cv.penalties(boxes), cv.penalties(boxes, free_only=True)
    marks, lines = _reference(cv, boxes)
    on_mark = np.array(marks) > 0
    assert np.array_equal(full == 0.0, quick == 0.0)
    assert full[~on_mark].tobytes() == quick[~on_mark].tobytes()
    assert quick[on_mark] == pytest.approx(np.array(marks)[on_mark], rel=1e-12, abs=0.0)
    assert full[on_mark] - quick[on_mark] == pytest.approx(25.0 * np.array(lines)[on_mark], abs=1e-9)
