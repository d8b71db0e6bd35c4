"""With a helper process and a histogram to draw, copy detection and the report are made in a process
forked for them while the histogram is drawn: the same flags, the same files as one process."""

from __future__ import annotations

import random
from pathlib import Path

import pytest

from gradekit.grading import batch, parallel
from gradekit.grading.batch import grade_batch
from gradekit.grading.integrity import KEY_MATCH
from gradekit.keys import KeyEntry, Tolerance
from gradekit.roster import Student

N = 200
TOL = Tolerance("relative", rel=0.02)
IDS = [f"{30000 + i}" for i in range(N)]


@pytest.fixture(scope="module")
def klass(tmp_path_factory):
    """Keys of 5 answers from 3 drawn inputs, a file a student; students 0-9 hand in 100-109's answers."""
    rng = random.Random(5)
    keys = []
    for sid in IDS:
        a, b, c = (rng.uniform(1, 3) for _ in range(3))
        for k, v in enumerate((a * b, a / c, 10 * b * c, a * a * c, b / a)):
            keys.append(KeyEntry(sid, "p1", f"p1.a{k}", v, "N", TOL))
    value = {(e.student_id, e.key): e.value for e in keys}
    subs = tmp_path_factory.mktemp("copies") / "subs"
    subs.mkdir()
    for i, sid in enumerate(IDS):
        source = IDS[100 + i] if i < 10 else sid
        rows = [f"{sid},p1.a{k},{value[(source, f'p1.a{k}')]:.4g},N" for k in range(5)]
        (subs / f"{sid}.csv").write_text("student_id,key,value,unit\n" + "\n".join(rows) + "\n", encoding="utf-8")
    return keys, subs


def _run(keys, subs: Path, out: Path):
    students = [Student(sid, f"Student {sid}") for sid in IDS]
    result = grade_batch(keys, students, subs, out, assignment_title="HW", histogram=True)
    return result, {p.relative_to(out).as_posix(): p.read_bytes() for p in sorted(out.rglob("*")) if p.is_file()}


@pytest.mark.skipif(not parallel.available(), reason="needs fork and two cores")
def test_copy_detection_forked_finds_what_one_process_finds(klass, tmp_path, monkeypatch):
    keys, subs = klass
    monkeypatch.setattr(parallel, "spare_core", lambda since=None: False)
    alone, alone_files = _run(keys, subs, tmp_path / "alone")
    forks: list[str] = []

    class Recorded(parallel.Forked):
        def __init__(self, work):
            forks.append(work.__name__)
            super().__init__(work)

    monkeypatch.setattr(batch, "Forked", Recorded)
    monkeypatch.setattr(parallel, "FROM", 1)
    monkeypatch.setattr(parallel, "spare_core", lambda since=None: True)
    both, both_files = _run(keys, subs, tmp_path / "both")
    assert forks == ["helper", "checked"]  # the helper, then copy detection and the report
    copied = {(f.student_id, f.other_id) for f in alone.flags if f.reason == KEY_MATCH}
    assert {(IDS[i], IDS[100 + i]) for i in range(10)} <= copied
    assert both.flags == alone.flags
    assert both_files.keys() == alone_files.keys()
    assert [name for name in alone_files if both_files[name] != alone_files[name]] == []


@pytest.mark.skipif(not parallel.available(), reason="needs fork and two cores")
def test_an_error_in_forked_copy_detection_reaches_the_caller(klass, tmp_path, monkeypatch):
    keys, subs = klass
    monkeypatch.setattr(parallel, "FROM", 1)
    monkeypatch.setattr(parallel, "spare_core", lambda since=None: True)

    def failing(*args, **kwargs):
        raise ValueError("copy detection failed")

    monkeypatch.setattr(batch, "find_copies", failing)
    with pytest.raises(ValueError, match="copy detection failed"):
        _run(keys, subs, tmp_path / "out")
    assert not (tmp_path / "out").exists()  # nothing moved in: the staging folder is gone
