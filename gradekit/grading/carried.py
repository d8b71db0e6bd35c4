"""Error carried forward in grading: credit for later answers that follow from a student's own earlier ones.

`gradekit.solving.carry` does the mechanics (which answers follow from which, each later answer recomputed
from the student's submitted upstream values). This module applies it to graded submissions: for
each problem with a carry credit, an answer that is wrong against the key but right from the
student's own wrong upstream values earns ``credit`` × its points and keeps the `Carried` record,
so feedback can say which of the student's values it is consistent with.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Mapping, Sequence

from gradekit.grading.compare import AnswerResult, StudentGrade, problem_scores
from gradekit.solving.keys import KeyEntry

REL = 1e-9  # a frozen key and the re-solved variant agree to this (else the variant is not the student's)


@dataclasses.dataclass
class CarryForward:
    """What carried credit needs: each student's solved variants and each problem's credit.

    ``variants[student][label]`` is a `gradekit.solving.sampling.Variant` (its ``result`` solved in the
    class batch); ``credit[label]`` the fraction of an answer's points a carried answer earns
    (problems absent or at 0 are not carried). `check` compares the keys graded against with the
    variants first: where they differ (the bank changed since the keys were frozen), that student's
    problem is not carried, and *warn* gets one line per problem.
    """

    variants: Mapping[str, Mapping[str, object]]
    credit: Mapping[str, float]
    stale: set[tuple[str, str]] = dataclasses.field(default_factory=set)  # (student, label) not carried

    def check(self, keys: Sequence[KeyEntry], warn: Callable[[str], None] | None = None) -> None:
        """Mark each (student, problem) whose key entries differ from the variant's answers."""
        answers: dict[tuple[str, str], dict[str, float]] = {}
        for e in keys:
            if self.credit.get(e.problem, 0.0) <= 0:
                continue
            pair = (e.student_id, e.problem)
            have = answers.get(pair)
            if have is None:
                v = self.variants.get(e.student_id, {}).get(e.problem)
                have = answers[pair] = {} if v is None else {a.key: a.value for a in v.result.answers}
            v = have.get(e.key[len(e.problem) + 1:])
            if v is None or abs(v - e.value) > REL * max(abs(v), abs(e.value), 1e-300):
                self.stale.add(pair)
        for label in sorted({label for _, label in self.stale}):
            n = sum(1 for _, lb in self.stale if lb == label)
            if warn is not None:
                warn(f"{label}: the keys of {n} student(s) differ from the bank's variants now (the bank changed "
                     f"since generation); their answers of {label} are not carried forward")

    def limits(self) -> list[tuple[str, str]]:
        """(answer key, why) for each later answer (inertia, forces, totals) of a carried problem that
        cannot be carried, or only in part, as the problem's model says (read off one student's variant)."""
        from gradekit.solving import carry

        out = []
        for label, credit in self.credit.items():
            if credit <= 0:
                continue
            v = next((per[label] for per in self.variants.values() if label in per), None)
            if v is None:
                continue
            for key, dep in carry.dependencies(v.result).items():
                if dep.stage in ("given", "kinematics"):
                    continue
                held = [h[len("inertia["):-1] for h in dep.held if h.startswith("inertia[")]
                if not dep.carriable:
                    out.append((f"{label}.{key}", dep.reason))
                elif held:
                    out.append((f"{label}.{key}", f"carried with the inertia of link {', '.join(held)} kept exact "
                                                   "(the problem asks none of its motion)"))
        return out

    def apply(self, grade: StudentGrade) -> StudentGrade:
        """*grade* with carried credit on each problem that has some; unchanged when none applies."""
        if grade.submission is None:
            return grade
        sid = grade.student.student_id
        by_problem: dict[str, list[int]] = {}
        for i, r in enumerate(grade.results):
            by_problem.setdefault(r.entry.problem, []).append(i)
        results = list(grade.results)
        changed = False
        for label, rows in by_problem.items():
            credit = self.credit.get(label, 0.0)
            if credit <= 0 or (sid, label) in self.stale:
                continue
            if sum(1 for i in rows if _wrong(results[i])) < 2:
                continue  # carrying needs a wrong upstream answer and a wrong later one
            variant = self.variants.get(sid, {}).get(label)
            if variant is None:
                continue
            for i, c in _credited(label, variant.result, [results[i] for i in rows]).items():
                r = results[rows[i]]
                results[rows[i]] = r._replace(points=max(r.points, r.entry.points * credit), carried=c)
                changed = True
        if not changed:
            return grade
        return dataclasses.replace(grade, results=tuple(results), problems=problem_scores(results))


def _credited(label: str, result, rows: list[AnswerResult]) -> dict[int, object]:
    """Row index → `Carried`, for the rows of one problem wrong against the key and right from the
    student's own upstream answers (each answer's tolerance, the instructor's overrides included)."""
    from gradekit.solving import carry

    short = [r.entry.key[len(label) + 1:] for r in rows]
    submitted = {s: r.value for s, r in zip(short, rows, strict=True) if r.value is not None}
    tolerances = {s: r.entry.tolerance for s, r in zip(short, rows, strict=True)}
    got = carry.credited(result, submitted, tolerances)
    return {i: got[s] for i, s in enumerate(short) if s in got and _wrong(rows[i])}


def _wrong(r: AnswerResult) -> bool:
    """An answer judged wrong: carried credit may go to it. One checked by hand is the instructor's to judge,
    never carried (its value still counts as the student's own upstream)."""
    return r.value is not None and not r.correct and not r.entry.hand_check


def class_carry(asg, ids: Sequence[str], redraws, keys: Sequence[KeyEntry], warn: Callable[[str], None] | None, *,
                forced: bool = False, variants: Mapping | None = None) -> CarryForward | None:
    """The assignment's carried-forward credit for the class *ids* (None when no problem gives any), as
    `gradekit grade` and the online page apply it: the variants behind *keys* (drawn and solved once,
    without the mistakes, with the manifest's *redraws*, unless given) checked against them."""
    credit = asg.carry(forced=forced)
    if not any(credit.values()):
        return None
    if variants is None:
        from gradekit.assignment import class_keys

        variants = class_keys(asg, list(ids), redraws, with_mistakes=False, need_keys=False)[1]
    carry = CarryForward(variants, credit)
    carry.check(keys, warn)
    return carry
