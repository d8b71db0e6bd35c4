"""Flag submissions that match another student's key better than their own."""

from __future__ import annotations

import bisect
from collections import Counter
from collections.abc import Sequence
from dataclasses import dataclass

from gradekit.grading.compare import StudentGrade
from gradekit.keys import KeyEntry


@dataclass(frozen=True)
class IntegrityFlag:
    """Evidence that *student_id*'s answers fit *other_id*'s key better than their own."""

    student_id: str
    other_id: str
    path: str
    own_matches: int
    other_matches: int
    keys: tuple[str, ...]

    def describe(self) -> str:
        """One line for the report."""
        return (
            f"{self.path}: {self.student_id} matches {self.other_id}'s key on "
            f"{self.other_matches} answers ({', '.join(self.keys)}) but their own on "
            f"{self.own_matches}"
        )


def find_copies(grades: Sequence[StudentGrade], keys: Sequence[KeyEntry]) -> list[IntegrityFlag]:
    """Flag each graded submission whose answers fit another student's key better.

    A submission is flagged when the number of its answers within tolerance of another
    student's key exceeds the number within tolerance of its own key, and is at least 2. Each
    answer is looked up among the other students' values for that key by bisection, so a class
    of n students costs O(n·k·log n), not O(n²·k).

    Args:
        grades: the graded students (those without a submission are skipped).
        keys: every student's key entries.

    Returns:
        One flag per flagged submission, naming the best-fitting other student (ties: the
        first by id).
    """
    by_key: dict[str, list[tuple[float, str, KeyEntry]]] = {}
    for entry in keys:
        by_key.setdefault(entry.key, []).append((entry.value, entry.student_id, entry))
    index = {}
    for key, items in by_key.items():
        items.sort(key=lambda item: item[0])
        index[key] = ([item[0] for item in items], items)
    flags = []
    for grade in grades:
        if grade.submission is None:
            continue
        sid = grade.student.student_id
        own = sum(1 for r in grade.results if r.correct)
        hits: Counter[str] = Counter()
        evidence: dict[str, list[str]] = {}
        for result in grade.results:
            if result.value is None or result.entry.key not in index:
                continue
            x = result.value
            values, items = index[result.entry.key]
            # A superset window: bands around nearby key values differ from the band around x
            # by at most a decade (significant-figure mode), so 20 bands around x cover them.
            width = 20 * result.entry.tolerance.band(x) + result.entry.tolerance.abs
            lo = bisect.bisect_left(values, x - width)
            hi = bisect.bisect_right(values, x + width)
            for value, other, entry in items[lo:hi]:
                if other != sid and entry.tolerance.accepts(x, value):
                    hits[other] += 1
                    evidence.setdefault(other, []).append(entry.key)
        if not hits:
            continue
        best = max(hits.values())
        if best >= 2 and best > own:
            other = min(o for o, n in hits.items() if n == best)
            flags.append(IntegrityFlag(sid, other, grade.submission.path, own, best, tuple(evidence[other])))
    return flags
