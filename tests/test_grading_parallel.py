"""A helper process grades a share of a large class: the outputs are byte for byte what one process
writes, whatever the files look like, and its failures reach the caller without leaving a half run."""

from __future__ import annotations

import os
from pathlib import Path

import pytest

from gradekit.grading import batch, parallel
from gradekit.grading.batch import grade_batch
from gradekit.grading.compare import grade_student
from gradekit.grading.parallel import pack, unpack
from gradekit.grading.reader import IdIndex, KeyIndex, read_file
from gradekit.keys import KeyEntry, Mistake, Tolerance
from gradekit.roster import Student

N = 40
IDS = [f"{2000 + i}" for i in range(N)]
STUDENTS = [Student(sid, f"Student {sid}", f"s{sid}@example.edu") for sid in IDS]


def _keys() -> list[KeyEntry]:
    keys = []
    for i, sid in enumerate(IDS):
        v = 100.0 + 7 * i
        keys += [
            KeyEntry(sid, "p1", "p1.F", v, "N", Tolerance(rel=0.01), 2.0,
                     mistakes=(Mistake("static-answer", "a static answer", v * 0.8),)),
            KeyEntry(sid, "p1", "p1.T", -v / 10, "N*m", Tolerance(rel=0.02), 3.0),
            KeyEntry(sid, "p2", "p2.a", 30.0 + i, "deg", Tolerance(rel=0.0, abs=0.5, period=360.0), 1.5),
            KeyEntry(sid, "p2", "p2.z", 0.0, "m", Tolerance(abs=0.01, mode="sigfigs"), 1.0),
        ]
    return keys


KEYS = _keys()
VALUES = {(e.student_id, e.key): e for e in KEYS}


def _long(sid: str, rows: list[tuple[str, str, str]], id_cell: str | None = None) -> str:
    return "student_id,key,value,unit\n" + "".join(f"{id_cell or sid},{k},{v},{u}\n" for k, v, u in rows)


def _answers(sid: str, i: int) -> list[tuple[str, str, str]]:
    f, t, a = (VALUES[(sid, k)].value for k in ("p1.F", "p1.T", "p2.a"))
    kinds = [
        [("p1.F", f"{f:.4g}", "N"), ("p1.T", f"{t:.4g}", "N*m"), ("p2.a", f"{a + 359.8:.5g}", "deg"),
         ("p2.z", "0", "m")],
        [("p1.F", f"{f * 0.8:.4g}", "N"), ("p1.T", f"{t * 1000:.5g}", "N*mm"), ("p2.a", "", "deg")],
        [("p1.F", "abc", "N"), ("p1.T", f"{-t:.4g}", "N*m"), ("p2.a", f"{a:.3g}", "rad"), ("p2.z", "1e-9", "km")],
        [("p1.F", f"{f:.4g} kN", ""), ("p1.T", "1,5", "N*m"), ("p2.a", f"{a}", "deg"), ("p3.x", "1", "m")],
    ]
    return kinds[i % len(kinds)]


@pytest.fixture(scope="module")
def subs(tmp_path_factory: pytest.TempPathFactory) -> Path:
    folder = tmp_path_factory.mktemp("parallel") / "subs"
    folder.mkdir()
    for i, sid in enumerate(IDS[:-1]):  # the last student hands in nothing
        (folder / f"{sid}.csv").write_text(_long(sid, _answers(sid, i)), encoding="utf-8")
    a, b, c, d = IDS[3], IDS[4], IDS[30], IDS[31]
    (folder / f"{a}_v2.csv").write_text(_long(a, _answers(a, 0)), encoding="utf-8")  # a second file
    os.utime(folder / f"{a}_v2.csv", (1e9, 1e9))
    (folder / f"{c}.csv").write_text(_long(c, _answers(c, 1), id_cell=d), encoding="utf-8")  # d's rows in c's file
    (folder / f"{b}.csv").write_bytes(b"PK\x03\x04 a workbook")  # unreadable
    (folder / f"{IDS[5]}.csv").write_text(  # wide layout
        f"student_id,p1.F,p1.T\n{IDS[5]},{VALUES[(IDS[5], 'p1.F')].value},oops\n", encoding="utf-8"
    )
    (folder / "all.csv").write_text(  # class-wide: one student with a file of their own, one without
        "student_id,key,value,unit\n"
        f"{IDS[20]},p1.F,1,N\n{IDS[-1]},p1.F,{VALUES[(IDS[-1], 'p1.F')].value},N\n{IDS[-1]},p2.z,0,m\n",
        encoding="utf-8",
    )
    (folder / "zzz.csv").write_text(_long("99999", [("p1.F", "1", "N")]), encoding="utf-8")  # not on the roster
    (folder / ".hidden.csv").write_text("x", encoding="utf-8")
    (folder / "late").mkdir()
    (folder / "late" / f"{IDS[35]}.csv").write_text(_long(IDS[35], _answers(IDS[35], 2)), encoding="utf-8")
    return folder


def _run(subs: Path, out: Path, reveal: bool = False):
    result = grade_batch(KEYS, STUDENTS, subs, out, assignment_title="HW <9>", reveal=reveal,
                         problem_titles={"p1": "Statics", "p2": "Angles"}, histogram=False)
    written = {p.relative_to(out).as_posix(): p.read_bytes() for p in sorted(out.rglob("*")) if p.is_file()}
    return result, written


def _helper(monkeypatch: pytest.MonkeyPatch, share: float) -> None:
    """A helper for the small test class whatever the machine is doing."""
    monkeypatch.setattr(parallel, "FROM", 1)
    monkeypatch.setattr(parallel, "SHARE", share)
    monkeypatch.setattr(parallel, "spare_core", lambda since=None: True)


@pytest.mark.skipif(not parallel.available(), reason="needs fork and two cores")
@pytest.mark.parametrize("share", [0.6, 1.0])
@pytest.mark.parametrize("reveal", [False, True])
def test_a_helper_process_writes_what_one_process_writes(
    subs: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch, share: float, reveal: bool
) -> None:
    alone, alone_files = _run(subs, tmp_path / "alone", reveal)
    forks = []
    real_fork = parallel.Forked

    def counted(work):
        forks.append(work)
        return real_fork(work)

    monkeypatch.setattr(batch, "Forked", counted)
    _helper(monkeypatch, share)
    helped, helped_files = _run(subs, tmp_path / "helped", reveal)
    assert len(forks) == 1
    assert helped_files.keys() == alone_files.keys()
    assert [name for name in alone_files if helped_files[name] != alone_files[name]] == []
    assert helped.grades == alone.grades
    assert helped.files == alone.files
    assert helped.flags == alone.flags
    assert [g.student.student_id for g in helped.grades] == IDS
    statuses = {f.path.rsplit("/", 1)[-1]: f.status for f in helped.files}
    assert statuses[f"{IDS[4]}.csv"] == "unreadable" and statuses["zzz.csv"] == "unknown student"
    assert statuses["all.csv"] == "graded" and statuses[f"{IDS[3]}_v2.csv"] == "duplicate"


def _raise_in(monkeypatch: pytest.MonkeyPatch, name: str, helper: bool, exc: BaseException) -> None:
    """Make ``batch.<name>`` raise *exc* in the helper process (*helper*) or in the parent."""
    parent, real = os.getpid(), getattr(batch, name)

    def failing(*args, **kwargs):
        if (os.getpid() != parent) == helper:
            raise exc
        return real(*args, **kwargs)

    monkeypatch.setattr(batch, name, failing)


@pytest.mark.skipif(not parallel.available(), reason="needs fork and two cores")
def test_a_failure_in_the_helper_reaches_the_caller_and_leaves_no_partial_run(
    subs: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    _helper(monkeypatch, 1.0)
    _raise_in(monkeypatch, "write_staged", True, OSError(28, "No space left on device"))
    with pytest.raises(OSError, match="No space left on device") as raised:
        _run(subs, tmp_path / "out")
    assert any("in the helper process" in note for note in raised.value.__notes__)
    assert sorted(p.name for p in tmp_path.iterdir()) == []  # neither OUT nor a staging folder


@pytest.mark.skipif(not parallel.available(), reason="needs fork and two cores")
def test_ctrl_c_while_the_helper_works_stops_it_and_leaves_no_partial_run(
    subs: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    _helper(monkeypatch, 0.6)
    _raise_in(monkeypatch, "feedback_pages", False, KeyboardInterrupt())
    started: list[int] = []

    class Watched(parallel.Forked):
        def __init__(self, work) -> None:
            super().__init__(work)
            started.append(self.pid)

    monkeypatch.setattr(batch, "Forked", Watched)
    with pytest.raises(KeyboardInterrupt):
        _run(subs, tmp_path / "out")
    assert sorted(p.name for p in tmp_path.iterdir()) == []
    assert len(started) == 1 and started[0] is not None
    with pytest.raises(ChildProcessError):  # the helper was stopped and reaped
        os.waitpid(started[0], os.WNOHANG)


def test_a_packed_grade_unpacks_to_the_same_grade(subs: Path) -> None:
    ids, key_index = IdIndex(STUDENTS), KeyIndex(e.key for e in KEYS)
    by_student: dict[str, list[KeyEntry]] = {}
    for e in KEYS:
        by_student.setdefault(e.student_id, []).append(e)
    seen = 0
    for path in sorted(subs.rglob("*.csv")):
        for sub in read_file(path, str(path), path.name, ids, key_index):
            if sub.student_id is None:
                continue
            student = STUDENTS[IDS.index(sub.student_id)]
            grade = grade_student(student, by_student[sub.student_id], sub)
            assert unpack(pack(grade), student, by_student[sub.student_id]) == grade
            seen += 1
    assert seen == N + 3  # 39 students' files, a second file, a late one, the class-wide file's two


def test_a_helper_needs_a_core_idle_now_not_a_quiet_last_minute(monkeypatch):
    """The free core is judged from what the cores do now: one and a half idle (this process's
    and another); the minute's load average, which still counts this run's own start, only where
    the kernel's counters are missing."""
    idle = parallel._idle_cores(0.05)
    if idle is not None:  # Linux: a fraction of the cores this process may use, measured
        assert 0.0 <= idle <= parallel.cores() + 1e-9
    monkeypatch.setattr(parallel, "_idle_cores", lambda seconds=0.1, since=None: 1.9)
    monkeypatch.setattr(parallel.os, "getloadavg", lambda: (5.0, 5.0, 5.0))  # a busy last minute
    assert parallel.spare_core()
    monkeypatch.setattr(parallel, "_idle_cores", lambda seconds=0.1, since=None: 1.2)
    monkeypatch.setattr(parallel.os, "getloadavg", lambda: (0.0, 0.0, 0.0))
    assert not parallel.spare_core()
    monkeypatch.setattr(parallel, "_idle_cores", lambda seconds=0.1, since=None: None)
    monkeypatch.setattr(parallel, "cores", lambda: 2)
    assert parallel.spare_core()
    monkeypatch.setattr(parallel.os, "getloadavg", lambda: (1.6, 1.0, 1.0))
    assert not parallel.spare_core()


@pytest.mark.skipif(not parallel.available(), reason="needs fork and two cores")
def test_the_parent_grades_none_of_the_helpers_students_again_unless_their_results_are_read(
    subs: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    from gradekit.grading.batch import StudentKeys
    from gradekit.grading.parallel import PackedGrade

    class Entries(dict):  # every student's key entries, noting whose the parent reads
        def get(self, sid, default=None):
            self.read.append(sid)
            return super().get(sid, default)

    entries = Entries()
    entries.read = []
    for e in KEYS:
        entries.setdefault(e.student_id, []).append(e)
    keys = StudentKeys(entries, IDS, {e.key: e.problem for e in KEYS})
    alone, alone_files = _run(subs, tmp_path / "alone")
    _helper(monkeypatch, 1.0)
    helped = grade_batch(keys, STUDENTS, subs, tmp_path / "helped", assignment_title="HW <9>",
                         problem_titles={"p1": "Statics", "p2": "Angles"}, histogram=False)
    sent = [g for g in helped.grades.as_made() if isinstance(g, PackedGrade)]
    assert sent  # the helper graded some of the class
    again = {g.student.student_id for g in sent if "results" in vars(g)}
    assert again == {g.student.student_id for g in sent if g.submission.conflicts}  # (to count their answers)
    named = {other for g in helped.grades.as_made() if g.submission for other in g.submission.conflicts}
    assert named  # (a file holds another's rows: graded against both keys for its flag)
    assert not ({g.student.student_id for g in sent} - again - named) & set(entries.read)  # others' keys never read
    assert helped.graded == alone.graded and helped.missing == alone.missing and helped.clean == alone.clean
    assert helped.grades == alone.grades  # built now
    written = {p.relative_to(tmp_path / "helped").as_posix(): p.read_bytes()
               for p in sorted((tmp_path / "helped").rglob("*")) if p.is_file()}
    assert written == alone_files
