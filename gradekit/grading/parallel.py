"""A second process for a share of a large class: it reads, grades and writes the feedback of the
students it is given while the first process does the rest, then hands back their grades.

The helper is forked, so it starts in milliseconds with the keys and roster the parent has already
read, and its grades come back as a few strings and byte strings per student: the submission it read
and what the parent reads of the grade (`pack`, `PackedGrade`; the parent grades the submission again
only if the results themselves are asked for). Pickling the records themselves would send every
student's keys along and cost more than grading.
Where fork is not available (Windows, macOS's default), in a program with other threads, on one
core, or while the other cores are busy, everything stays in one process.
"""

from __future__ import annotations

import os
import pickle
import signal
import threading
import time
import traceback
import warnings
from array import array
from collections.abc import Callable, Iterator, Sequence
from functools import cached_property
from itertools import chain, compress
from operator import attrgetter

from gradekit.grading.compare import AnswerResult, ProblemScore, ResultColumns, StudentGrade, grade_student
from gradekit.grading.reader import Answer, Issue, Submission
from gradekit.keys import KeyEntry
from gradekit.roster import Student

FROM = 200
"""Students a helper takes at the least: below that, starting it costs more than it saves."""

SHARE = 0.6
"""The most of the students it could take that a helper grades. How many it does is settled while both
work (`Claims`): it takes them from the back, and the parent, once done with its own students and
copy detection's keys, takes the rest from the front, so both end together whatever each costs (the
helper spends more on each: it copies the parent's memory as it writes, and packs its grades) and
whatever else runs on the machine. At 3,000 students a fixed half had left one of the two idle for
0.05–0.6 s before the join."""


def cores() -> int:
    """The processor cores this process may run on."""
    try:
        return len(os.sched_getaffinity(0))
    except (AttributeError, OSError):
        return os.cpu_count() or 1


def available() -> bool:
    """A helper process can be forked safely here: POSIX fork, no other Python thread, two cores or more."""
    return hasattr(os, "fork") and threading.active_count() == 1 and cores() >= 2


def _counters() -> tuple[int, int] | None:
    """The kernel's counters of all cores' idle (and iowait) time and of all time, in ticks, from
    ``/proc/stat``; None where there are none (not Linux)."""
    try:
        with open("/proc/stat", encoding="ascii") as f:
            fields = [int(x) for x in f.readline().split()[1:]]
        return fields[3] + fields[4], sum(fields)
    except (OSError, ValueError, IndexError):
        return None


class Look:
    """The start of a look at how busy the cores are: the kernel's counters, this process's CPU time
    and the clock. Made as a caller begins the work that leads up to the choice of a helper, it lets
    `spare_core` look over that work instead of sleeping (at 3,000 students, reading the folder and
    matching its files to the roster take about as long as the look needs)."""

    def __init__(self) -> None:
        self.counters = _counters()
        self.cpu = time.process_time()
        self.at = time.monotonic()


def _idle_cores(seconds: float = 0.1, since: Look | None = None) -> float | None:
    """How many cores sat idle over at least *seconds*, not counting what this process used: the time
    since *since* (this process at work meanwhile), else the next *seconds* (asleep); sleeps only for
    what is left of *seconds*. None where the kernel has no counters (not Linux)."""
    start = since if since is not None else Look()
    left = seconds - (time.monotonic() - start.at)
    if left > 0:
        time.sleep(left)
    end = Look()
    if start.counters is None or end.counters is None:
        return None
    (idle0, total0), (idle1, total1) = start.counters, end.counters
    if total1 <= total0 or end.at <= start.at:
        return None
    mine = (end.cpu - start.cpu) / (end.at - start.at)  # the cores this process kept busy meanwhile
    return min(cores() * (idle1 - idle0) / (total1 - total0) + mine, float(cores()))


def spare_core(since: Look | None = None) -> bool:
    """A core is free for a helper: over a short look (0.1 s: the kernel counts in 10 ms ticks, so a
    shorter look is coarse) at least one and a half cores sat idle or busy with this process, so
    another one besides this process's. The look is the time since *since* when given (this process
    working meanwhile), else a sleep. When other work keeps the cores
    busy a helper only competes with it, and the extra work of handing grades back makes the run
    slower (``make -l`` likewise). Without the kernel's counters, the load average of the last
    minute (which lags: it still counts what this process did while loading) must leave half a core."""
    idle = _idle_cores(since=since)
    if idle is not None:
        return idle >= 1.5
    try:
        return os.getloadavg()[0] < cores() - 0.5
    except (AttributeError, OSError):
        return True


def helper_share(candidates: Sequence[str], since: Look | None = None) -> list[str]:
    """The students a helper may grade, of those it could (*candidates*, in roster order): the last
    `SHARE` of them, or none when they are too few or no helper can be forked or run beside this one
    (`spare_core`, looking since *since* when given). They are shared out between the helper and the
    parent as both work (`Claims`)."""
    take = int(len(candidates) * SHARE)
    if take < FROM or not available() or not spare_core(since):
        return []
    return list(candidates[len(candidates) - take :])


class Claims:
    """*n* items shared out between a process and its forked helper while both work: the parent takes
    them from the front (`front`), the helper from the back (`back`), *chunk* at a time, so each is
    taken exactly once and both run out together.

    The two counters live in memory both processes share; a POSIX record lock on a temporary file
    guards them (a lock that dies with its holder: a helper killed while holding it cannot stop the
    parent). Made before the fork.
    """

    def __init__(self, n: int, chunk: int = 4) -> None:
        import mmap
        import tempfile

        self.chunk = chunk
        self._lock = tempfile.TemporaryFile()
        self._counts = mmap.mmap(-1, 16)
        self._counts[:] = array("q", [0, n]).tobytes()

    def _take(self, front: bool) -> range:
        import fcntl

        fcntl.lockf(self._lock, fcntl.LOCK_EX)
        try:
            lo, hi = array("q", self._counts[:]).tolist()
            if front:
                taken = range(lo, min(lo + self.chunk, hi))
                lo = taken.stop
            else:
                taken = range(max(hi - self.chunk, lo), hi)
                hi = taken.start
            self._counts[:] = array("q", [lo, hi]).tobytes()
        finally:
            fcntl.lockf(self._lock, fcntl.LOCK_UN)
        return taken

    def front(self) -> Iterator[range]:
        """The parent's takes, from the front, until none is left."""
        while taken := self._take(True):
            yield taken

    def back(self) -> Iterator[range]:
        """The helper's takes, from the back, until none is left."""
        while taken := self._take(False):
            yield taken

    def close(self) -> None:
        self._lock.close()
        self._counts.close()


class Forked:
    """Run *work* in a forked child process while the parent goes on; `result` waits for its return value.

    The child ignores Ctrl-C (the parent handles it: leaving the ``with`` block stops the child
    before anything is cleaned up) and ends with ``os._exit``, so nothing of the parent's (output
    buffers, exit handlers, open ``with`` blocks) runs twice. An exception in the child is raised
    again by `result`, with the child's traceback as a note. When fork fails, `result` runs *work*
    in the parent.
    """

    def __init__(self, work: Callable[[], object]) -> None:
        self.work = work
        self.pid: int | None = None
        self.pipe: int | None = None
        read, write = os.pipe()
        try:
            with warnings.catch_warnings():
                # Python 3.12+ warns of fork in a process with threads: numpy's BLAS keeps idle
                # workers, which hold nothing the child needs (it does no linear algebra).
                warnings.simplefilter("ignore", DeprecationWarning)
                pid = os.fork()
        except OSError:
            os.close(read)
            os.close(write)
            return
        if pid == 0:  # the child
            status = 1
            try:
                os.close(read)
                signal.signal(signal.SIGINT, signal.SIG_IGN)
                payload = _outcome(work)
                with os.fdopen(write, "wb") as pipe:
                    pipe.write(payload)
                status = 0
            finally:
                os._exit(status)
        os.close(write)
        self.pid, self.pipe = pid, read

    def __enter__(self) -> Forked:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def result(self) -> object:
        """What *work* returned (waiting for the child), or its exception raised again."""
        if self.pid is None:
            return self.work()
        with os.fdopen(self.pipe, "rb") as pipe:
            self.pipe = None
            payload = pipe.read()
        _, status = os.waitpid(self.pid, 0)
        self.pid = None
        if not payload:
            raise RuntimeError(f"the helper process ended without its result (wait status {status})")
        ok, value, trace = pickle.loads(payload)
        if ok:
            return value
        value.add_note(f"in the helper process:\n{trace}")
        raise value

    def close(self) -> None:
        """Stop the child if its result was not collected (an error or Ctrl-C in the parent)."""
        if self.pid is not None:
            try:
                os.kill(self.pid, signal.SIGKILL)
            except ProcessLookupError:
                pass
            os.waitpid(self.pid, 0)
            self.pid = None
        if self.pipe is not None:
            os.close(self.pipe)
            self.pipe = None


class Stream:
    """Objects a forked helper sends as it works, for the parent to take whenever it looks: neither
    side ever waits for the other (`send` in the helper, `receive` in the parent). Made before the fork.

    Each object is pickled to a temporary file, which takes any amount without blocking; its length
    then goes through a pipe (a few bytes an object: the pipe never fills), so the parent reads only
    what was written in full (the pipe orders the two).
    """

    def __init__(self) -> None:
        import tempfile

        self._file = tempfile.TemporaryFile()
        self._ready, self._sent = os.pipe()
        os.set_blocking(self._ready, False)
        self._written = 0  # the sender's end of the file
        self._read = 0  # the receiver's
        self._pending = b""  # length bytes received, not yet a whole length

    def send(self, obj: object) -> None:
        """Pickle *obj* for the parent (in the helper)."""
        payload = pickle.dumps(obj, protocol=pickle.HIGHEST_PROTOCOL)
        view = memoryview(payload)
        while view:
            view = view[os.pwrite(self._file.fileno(), view, self._written + len(payload) - len(view)) :]
        self._written += len(payload)
        os.write(self._sent, len(payload).to_bytes(8, "little"))

    def receive(self) -> list:
        """Every object sent in full since the last look, in order (in the parent; never waits)."""
        try:
            self._pending += os.read(self._ready, 1 << 16)
        except BlockingIOError:
            return []
        whole = len(self._pending) // 8 * 8
        sizes = [int.from_bytes(self._pending[i : i + 8], "little") for i in range(0, whole, 8)]
        self._pending = self._pending[whole:]
        data = os.pread(self._file.fileno(), sum(sizes), self._read)
        if len(data) != sum(sizes):
            raise RuntimeError(f"expected {sum(sizes)} bytes from the helper, got {len(data)}")
        self._read += len(data)
        objects, at = [], 0
        for size in sizes:
            objects.append(pickle.loads(data[at : at + size]))
            at += size
        return objects

    def close(self) -> None:
        for fd in (self._ready, self._sent):
            os.close(fd)
        self._file.close()


def _outcome(work: Callable[[], object]) -> bytes:
    """(True, value, "") or (False, exception, traceback) of running *work*, pickled."""
    try:
        return pickle.dumps((True, work(), ""), protocol=pickle.HIGHEST_PROTOCOL)
    except BaseException as exc:  # noqa: BLE001 (everything goes back to the parent)
        trace = traceback.format_exc()
        try:
            payload = pickle.dumps((False, exc, trace), protocol=pickle.HIGHEST_PROTOCOL)
            pickle.loads(payload)  # some exceptions pickle but cannot be rebuilt
            return payload
        except Exception:  # noqa: BLE001 (then as text)
            return pickle.dumps((False, RuntimeError(f"{type(exc).__name__}: {exc}"), trace))


def _floats(values: list[float | None]) -> tuple[bytes, bytes]:
    """Optional floats as (their bytes, which are None), exactly (-0.0 and infinities too)."""
    if None not in values:  # (no float equals None)
        return array("d", values).tobytes(), b""
    none = [v is None for v in values]
    return array("d", [0.0 if v is None else v for v in values]).tobytes(), bytes(none)


def _unfloats(data: bytes, none: bytes) -> list[float | None]:
    values = array("d")
    values.frombytes(data)
    values = values.tolist()
    if none and len(none) != len(values):
        raise ValueError(f"expected {len(values)} flags of None, got {len(none)}")
    for i in compress(range(len(values)), none):  # only the None's places visited
        values[i] = None
    return values


_SEP = "\x00"  # joins a student's texts: no cell, unit or key holds a NUL (the reader refuses them)
_TEXTS = attrgetter("key", "raw", "raw_unit", "unit", "field", "issue")  # an answer's, in `Answer`'s order
_NUMBER, _LINE, _CORRECT, _VALUE = map(attrgetter, ("number", "line", "correct", "value"))
_DIAGNOSIS, _CARRIED, _ENTRY_KEY = attrgetter("diagnosis"), attrgetter("carried"), attrgetter("entry.key")
_HEAD = ("path", "student_id", "claimed", "readable", "mtime", "class_wide", "named", "conflicts")  # a submission's
_HEAD_OF, _SUBMISSION = attrgetter(*_HEAD), attrgetter(*Submission.__dataclass_fields__)  # (the first in `pack`)


def pack(grade: StudentGrade) -> tuple:
    """A graded submission as a few strings, byte strings and short lists, cheap to pickle: the
    submission as read, and of the grade what the parent reads of it (`PackedGrade`): its problem
    scores, messages and `StudentGrade.columns`. The results themselves stay behind: grading the
    same submission against the same key entries makes them again (`PackedGrade.results`).
    """
    sub = grade.submission
    if sub is None:
        raise ValueError("expected a graded submission, got none")
    answers, results = sub.answers, grade.results
    texts = list(chain.from_iterable(map(_TEXTS, answers)))
    keys = list(map(_ENTRY_KEY, results))
    joined, joined_keys = _SEP.join(texts), _SEP.join(keys)
    if (texts and joined.count(_SEP) != len(texts) - 1) or (keys and joined_keys.count(_SEP) != len(keys) - 1):
        raise ValueError("expected texts without NUL characters")
    return (
        _HEAD_OF(sub),
        tuple(_issue(i) for i in sub.issues),
        tuple(_issue(i) for i in grade.issues),
        tuple((p.problem, p.points, p.max_points) for p in grade.problems),
        len(answers),
        joined,
        _floats(list(map(_NUMBER, answers))),
        array("q", map(_LINE, answers)).tobytes(),
        joined_keys,
        bytes(map(_CORRECT, results)),
        _floats(list(map(_VALUE, results))),
        [(i, d.name) for i, d in enumerate(map(_DIAGNOSIS, results)) if d is not None],
        [i for i, c in enumerate(map(_CARRIED, results)) if c is not None],
    )


def unpack(data: tuple, student: Student, entries: Sequence[KeyEntry]) -> StudentGrade:
    """The grade `pack` made of *student*'s submission graded against *entries* (their key entries, in
    order), graded again (`PackedGrade`; without carried credit: a grade that had some is refused)."""
    return PackedGrade(data, student, lambda sub: grade_student(student, entries, sub)).built()


def _answers(data: tuple) -> tuple[Answer, ...]:
    """The answers of the submission of a grade `pack` made."""
    n, texts, numbers, lines = data[4], data[5], data[6], data[7]
    texts = texts.split(_SEP) if n else []
    line_numbers = array("q")
    line_numbers.frombytes(lines)
    return tuple(map(
        Answer, texts[0::6], texts[1::6], texts[2::6], _unfloats(*numbers), texts[3::6], line_numbers.tolist(),
        texts[4::6], texts[5::6],
    ))


def _columns(data: tuple) -> ResultColumns:
    """`StudentGrade.columns` of a grade `pack` made, read from it; checks that its parts agree in length."""
    n_answers, texts, numbers, lines, keys, correct, value, diagnosed, carried = data[4:]
    n = len(correct)
    names = keys.split(_SEP) if n else []
    values = _unfloats(*value)
    if len(names) != n or len(values) != n or correct.translate(None, b"\x00\x01"):
        raise ValueError(f"expected {n} keys, values and verdicts (0 or 1), got {len(names)} keys and "
                         f"{len(values)} values")
    if (texts.count(_SEP) + 1 if n_answers else len(texts)) != 6 * n_answers or not (
        len(numbers[0]) == len(lines) == 8 * n_answers and len(numbers[1]) in (0, n_answers)
    ):
        raise ValueError(f"expected {n_answers} answers, got texts, numbers or lines of another length")
    diagnoses: list[str | None] = [None] * n
    for i, name in diagnosed:
        diagnoses[i] = name
    flags = [False] * n
    for i in carried:
        flags[i] = True
    return ResultColumns(names, values, list(map(bool, correct)), diagnoses, flags)


class PackedSubmission(Submission):
    """The submission of a grade a helper process sent (`pack`): everything but its answers made at once,
    its answers when first read. `built` is the same as a plain `Submission`, and a copy or a pickle is one."""

    def __init__(self, data: tuple) -> None:
        fields = self.__dict__  # (a frozen dataclass: its fields written directly, as its own __init__ does)
        fields.update(zip(_HEAD, data[0], strict=True))
        fields["issues"] = tuple(Issue(*i) for i in data[1])
        fields["_packed"] = data

    @cached_property
    def answers(self) -> tuple[Answer, ...]:  # (kept in the instance, as the field would be)
        return _answers(self.__dict__["_packed"])

    def built(self) -> Submission:
        """The same submission as a `Submission`."""
        return Submission(*_SUBMISSION(self))

    def __reduce__(self) -> tuple:
        return Submission, _SUBMISSION(self)


class PackedGrade(StudentGrade):
    """A grade a helper process sent (`pack`), as the parent keeps it: its student, problem scores and
    messages made at once, its submission a `PackedSubmission` (answers made when read), its results'
    columns (`columns`: all the report, copy detection and the grade table read of them) read from the
    packed data, and its results only when first read: *regrade* grades the submission again (against
    the student's key entries, which the parent otherwise never builds for the helper's students), and
    what it makes must pack to what was sent. `built` is the same grade as a plain `StudentGrade`, and
    a copy or a pickle of it is one.

    Raises:
        ValueError: *data* is not a grade `pack` made (its parts disagree); when the results are first
            read, *regrade* made another grade.
    """

    def __init__(self, data: tuple, student: Student, regrade: Callable[[Submission], StudentGrade]) -> None:
        try:
            columns = _columns(data)
            submission = PackedSubmission(data)
            problems = tuple(ProblemScore(*p) for p in data[3])
            issues = tuple(Issue(*i) for i in data[2])
        except (ValueError, TypeError, IndexError) as exc:
            raise ValueError(f"expected a grade packed for {student.student_id}, got a malformed one ({exc})") from None
        fields = self.__dict__  # (a frozen dataclass: its fields written directly, as its own __init__ does)
        fields["student"] = student
        fields["submission"] = submission
        fields["problems"] = problems
        fields["issues"] = issues
        fields["_packed"] = (data, regrade, columns)

    @cached_property
    def results(self) -> tuple[AnswerResult, ...]:  # (kept in the instance, as the field would be)
        data, regrade, _ = self.__dict__["_packed"]
        again = regrade(self.submission)
        if again.student != self.student or pack(again) != data:
            raise ValueError(f"expected {self.student.student_id}'s submission to grade as the helper process "
                             "graded it, got another grade (other key entries?)")
        return again.results

    def columns(self) -> ResultColumns:
        return self.__dict__["_packed"][2]

    def built(self) -> StudentGrade:
        """The same grade as a `StudentGrade` (its results and its submission's answers built)."""
        results = self.results
        return StudentGrade(self.student, self.submission.built(), results, self.problems, self.issues)

    def __reduce__(self) -> tuple:
        return StudentGrade, (self.student, self.submission.built(), self.results, self.problems, self.issues)


def _issue(i: Issue) -> tuple:
    return (i.path, i.line, i.field, i.message)
