"""The label placer: no label on a line in scenes where the placement order or the leader rule
once put one there (a force's label crossed by a bar, a short dimension on an angle's arc)."""

from __future__ import annotations

import numpy as np
import pytest

import gradekit
from gradekit.bank.registry import load_bank
from gradekit.figures.canvas import Canvas, segment_box_hits, text_size
from gradekit.figures.sheet import build_scene

BANK = load_bank()


def _lines_on_labels(cv: Canvas) -> list[tuple[str, int]]:
    """(label, how many drawn segments cross its box) for every label some line's ink crosses; a
    label's own leader, which ends on its box, is not counted."""
    out = []
    S = np.array([(p[0], p[1], q[0], q[1], hw - 1.0) for p, q, hw, *_ in cv.segments])  # ink: lw / 2
    for it in cv.items:
        if it.kind != "text":
            continue
        w, h = text_size(it.style["s"], it.style["size"])
        x0 = it.xy[0] - {"center": w / 2, "left": 0.0, "right": w}[it.style["ha"]]
        box = np.array([[x0, it.xy[1] - h / 2, x0 + w, it.xy[1] + h / 2]])
        hit = segment_box_hits(S, box)[0]
        own = (S[:, 4] == 0.5 / 2) & np.array(
            [min(np.hypot(*(np.clip(e, box[0, :2], box[0, 2:]) - e)) for e in (s[:2], s[2:4])) < 1.0 for s in S])
        n = int((hit & ~own).sum())
        if n:
            out.append((it.style["s"], n))
    return out


@pytest.mark.parametrize("pid, seed", [
    ("s003-fourbar-quick-return", 3),  # f2's label lay on the coupler, across its own arrow's line
    ("s003-fourbar-quick-return", 6),
    ("s003-slotted-lever", 1),  # d1 on the angle's arc beside the crank's pivot
    ("s003-slotted-lever", 9),  # O2A on the lever
    ("s003-fourbar", 10),  # d1 on the coupler
])
def test_no_label_sits_on_a_line(pid, seed):
    r = gradekit.sample_many(BANK[pid], seeds=range(seed + 1)).variant(seed).result
    cv = build_scene(r, None, False)
    cv.place()
    assert _lines_on_labels(cv) == []
    assert all(pen < 25.0 for _t, _a, _b, pen, _g in cv.placed)
