"""An assignment: which bank problems, worth what, for which course and term; and its keys.

The assignment YAML names the problems (bank ids) with their points and optional tolerance
overrides. Every student's variant of every problem follows from (course, salt, student id,
problem id), so generation and grading recompute exactly the same keys; the manifest records
hashes so that grading notices when the bank or the assignment changed.
"""

from __future__ import annotations

import dataclasses
import hashlib
from collections.abc import Mapping
from dataclasses import dataclass, replace
from pathlib import Path

import orjson

from gradekit import __version__, frozen
from gradekit.bank.model import Problem
from gradekit.bank.registry import load_bank, load_problems
from gradekit.bank.schema import _Collector, _tolerance
from gradekit.bank.yamlfile import load
from gradekit.errors import ErrorList, GradekitError, ProblemError
from gradekit.solving.keys import KeyEntry, PartialCredit, Tolerance, tolerance_columns, within
from gradekit.solving.mistakes import catalogued_mistakes
from gradekit.solving.sampling import Variant, derive_seed, variant


@dataclass(frozen=True)
class Item:
    """One problem of an assignment: its label (``p1``), bank problem, points and tolerance override."""

    label: str
    problem: Problem
    points: float
    tolerance: dict | None = None  # fields given for every answer, e.g. {"rel": 0.05}
    tolerances: dict[str, dict] = dataclasses.field(default_factory=dict)  # per answer key
    points_step: float | None = None  # answer points in multiples of this (default: 0.5, finer if needed)
    # carried-forward credit of a later answer consistent with the student's own wrong earlier ones:
    # None when the problem does not say (the assignment's, or --carry-forward's), 0 when off
    carry_credit: float | None = None
    # partial credit in a wider band: None when the problem does not say (the assignment's), False when off
    partial: PartialCredit | bool | None = None


@dataclass(frozen=True)
class Online:
    """The rules of the online page (``online:`` in the assignment; `gradekit serve`).

    ``attempts`` per answer; ``penalty_per_attempt``: the fraction of an answer's points lost for each
    attempt before the one that counts (0: none); ``due``: an ISO date and time with its UTC offset
    ("": no due date), after which the page is read-only; ``late_policy``: ``closed`` (after the due
    date the page shows the verdicts only) or ``show-key`` (it also shows each answer's key).
    """

    attempts: int = 3
    penalty_per_attempt: float = 0.0
    due: str = ""
    late_policy: str = "closed"


LATE_POLICIES = ("closed", "show-key")


@dataclass(frozen=True)
class Assignment:
    title: str
    course: str
    term: str
    due: str
    salt: str
    instructions: str
    submission: str
    items: tuple[Item, ...]
    path: str
    sha256: str
    redraws: dict[str, dict[str, int]] = dataclasses.field(default_factory=dict)
    # what feedback without --reveal says of a wrong answer: "direction" (too high/low, outside
    # the tolerance) or "band" (and a coarse band in multiples of the tolerance)
    feedback: str = "direction"
    carry_credit: float | None = None  # the problems' default carry-forward credit (see Item)
    partial: PartialCredit | None = None  # the problems' default partial credit (see Item); None: off
    online: Online = dataclasses.field(default_factory=lambda: Online())  # `gradekit serve`'s rules
    # what `grade` writes (`gradekit.grading.exports.EXPORTS` names); None: the default set
    exports: tuple[str, ...] | None = None

    def partial_credit(self) -> dict[str, PartialCredit]:
        """Each item's partial credit, for the items that give some (a problem's own setting, else the
        assignment's)."""
        out = {}
        for it in self.items:
            rule = self.partial if it.partial is None else it.partial
            if rule:
                out[it.label] = rule
        return out

    def carry(self, forced: bool = False) -> dict[str, float]:
        """Each item's carry-forward credit (0: not carried). *forced* (``--carry-forward``) turns it
        on at full credit, or the assignment's, for every problem that does not say otherwise."""
        out = {}
        for it in self.items:
            credit = it.carry_credit if it.carry_credit is not None else self.carry_credit
            out[it.label] = credit if credit is not None else (1.0 if forced else 0.0)
        return out


def load_assignment(path: Path | str, bank: Path | str | None = None) -> Assignment:
    """Load and validate an assignment file; every error is reported together."""
    path = Path(path)
    data = load(path)
    c = _Collector(str(path))
    c.mapping(
        data,
        "",
        ("title", "course", "salt", "problems"),
        ("term", "due", "instructions", "submission", "bank", "redraws", "feedback", "carry_forward", "partial_credit",
         "online",
         "exports"),
    )
    listed = data.get("problems") if isinstance(data.get("problems"), list) else []
    named = [it.get("id") for it in listed if isinstance(it, dict) and isinstance(it.get("id"), str)]
    folder = bank or (path.parent / data["bank"] if isinstance(data.get("bank"), str) else None)
    problems = load_problems(named, folder) if named else load_bank(folder)
    items = []
    labels: set[str] = set()
    node = data.get("problems")
    if not isinstance(node, list) or not node:
        c.err(data, "problems", "problems", "expected a list of problems (id, points), got nothing")
        node = []
    for i, it in enumerate(node):
        w = f"problems[{i}]"
        m = c.mapping(it, w, ("id", "points"), ("label", "tolerance", "tolerances", "points_step", "carry_forward",
                                               "partial_credit"),
                      node, i)
        if m is None:
            continue
        pid = m.get("id")
        if pid not in problems:
            c.err(m, "id", f"{w}.id", f"expected a bank problem id, got {pid!r}")
            continue
        prob = problems[pid]
        label = str(m.get("label", f"p{i + 1}"))
        if label in labels:
            c.err(m, "label", f"{w}.label", f"expected a unique label, got {label!r} twice")
        labels.add(label)
        pts = c.number(m, "points", f"{w}.points", 0.0, positive=True) or 0.0
        tol = _override(c, m.get("tolerance"), f"{w}.tolerance", m) if "tolerance" in m else None
        per = {}
        tm = m.get("tolerances", {})
        keys = {a.key for a in prob.answers}
        for k in c.mapping(tm, f"{w}.tolerances", (), tuple(sorted(keys)), m, "tolerances") or {}:
            per[k] = _override(c, tm[k], f"{w}.tolerances.{k}", tm)
        step = c.number(m, "points_step", f"{w}.points_step", 0.0, positive=True) if "points_step" in m else None
        carry = _carry(c, m, "carry_forward", f"{w}.carry_forward") if "carry_forward" in m else None
        partial = _partial(c, m, f"{w}.partial_credit") if "partial_credit" in m else None
        items.append(Item(label, prob, pts, tol, per, step or None, carry, partial))
    redraws: dict[str, dict[str, int]] = {}
    rd = data.get("redraws", {})
    for sid in (
        c.mapping(rd, "redraws", (), tuple(str(k) for k in rd) if isinstance(rd, dict) else (), data, "redraws") or {}
    ):
        per = rd[sid]
        m = c.mapping(per, f"redraws.{sid}", (), tuple(sorted(labels)), rd, sid) or {}
        for label, n in m.items():
            if not isinstance(n, int) or isinstance(n, bool) or n < 0:
                c.err(m, label, f"redraws.{sid}.{label}", f"expected a whole number of at least 0, got {n!r}")
            else:
                redraws.setdefault(str(sid), {})[label] = n
    for k in ("title", "course", "salt"):
        if not isinstance(data.get(k), str) or not data.get(k):
            c.err(data, k, k, f"expected text, got {data.get(k)!r}")
    feedback = data.get("feedback", "direction")
    if feedback not in ("direction", "band"):
        c.err(data, "feedback", "feedback", f"expected direction or band, got {feedback!r}")
    carry = _carry(c, data, "carry_forward", "carry_forward") if "carry_forward" in data else None
    partial = _partial(c, data, "partial_credit") if "partial_credit" in data else None
    online = _online(c, data) if "online" in data else Online()
    exports = _exports(c, data) if "exports" in data else None
    if c.errors:
        raise ErrorList(c.errors)
    return Assignment(
        str(data["title"]),
        str(data["course"]),
        str(data.get("term", "")),
        str(data.get("due", "")),
        str(data["salt"]),
        str(data.get("instructions", "")),
        str(data.get("submission", "")),
        tuple(items),
        str(path),
        hashlib.sha256(path.read_bytes()).hexdigest(),
        redraws,
        str(feedback),
        carry,
        partial or None,
        online,
        exports,
    )


def _exports(c: _Collector, data) -> tuple[str, ...] | None:
    """``exports: [grades, canvas, moodle-feedback-zip, ...]``: the names of the exports table."""
    from gradekit.grading.exports import choose_exports

    node = data["exports"]
    if not isinstance(node, list) or not all(isinstance(n, str) for n in node):
        c.err(data, "exports", "exports", f"expected a list of export names, got {node!r}")
        return None
    try:
        return choose_exports(node)
    except GradekitError as exc:
        c.err(data, "exports", "exports", exc.detail)
        return None


def _online(c: _Collector, data) -> Online:
    """``online: {attempts, penalty_per_attempt, due, late_policy}``, each optional (see `Online`)."""
    import datetime as dt

    m = c.mapping(data["online"], "online", (), ("attempts", "penalty_per_attempt", "due", "late_policy"), data,
                  "online")
    if m is None:
        return Online()
    attempts = m.get("attempts", 3)
    if not isinstance(attempts, int) or isinstance(attempts, bool) or not 1 <= attempts <= 100:
        c.err(m, "attempts", "online.attempts", f"expected a whole number from 1 to 100, got {attempts!r}")
        attempts = 3
    penalty = c.number(m, "penalty_per_attempt", "online.penalty_per_attempt", 0.0)
    if penalty is not None and not 0 <= penalty <= 1:
        c.err(m, "penalty_per_attempt", "online.penalty_per_attempt",
              f"expected a fraction of the points from 0 to 1, got {penalty}")
    due = m.get("due", "")
    if isinstance(due, str) and due:
        try:
            due = dt.datetime.fromisoformat(due)
        except ValueError:
            pass
    if isinstance(due, dt.datetime) and due.tzinfo is not None:
        due = due.isoformat()
    elif due != "":
        c.err(m, "due", "online.due",
              f"expected a date and time with its UTC offset (2026-12-01T23:59:00+01:00), got {str(due)!r}")
        due = ""
    policy = m.get("late_policy", "closed")
    if policy not in LATE_POLICIES:
        c.err(m, "late_policy", "online.late_policy", f"expected {' or '.join(LATE_POLICIES)}, got {policy!r}")
        policy = "closed"
    return Online(attempts, penalty or 0.0, due, policy)


def _carry(c: _Collector, node, key: str, where: str) -> float | None:
    """``carry_forward: true | false | {credit: 0.5}`` as the credit of a carried answer (0: off)."""
    v = node[key]
    if isinstance(v, bool):
        return 1.0 if v else 0.0
    m = c.mapping(v, where, ("credit",), (), node, key) if isinstance(v, dict) else None
    if m is None:
        if not isinstance(v, dict):
            c.err(node, key, where, f"expected true, false or a mapping {{credit: 0.5}}, got {v!r}")
        return None
    credit = c.number(m, "credit", f"{where}.credit", 1.0, positive=True)
    if credit is not None and credit > 1:
        c.err(m, "credit", f"{where}.credit", f"expected a fraction of the points from 0 to 1, got {credit}")
    return credit


def _partial(c: _Collector, node, where: str) -> PartialCredit | bool | None:
    """``partial_credit: {within: 3, credit: 0.5}`` (or ``false``: none for this problem)."""
    v = node["partial_credit"]
    if v is False:
        return False
    m = c.mapping(v, where, ("within", "credit"), (), node, "partial_credit") if isinstance(v, dict) else None
    if m is None:
        if not isinstance(v, dict):
            c.err(node, "partial_credit", where, f"expected false or a mapping {{within: 3, credit: 0.5}}, got {v!r}")
        return None
    within = c.number(m, "within", f"{where}.within", 0.0, positive=True)
    credit = c.number(m, "credit", f"{where}.credit", 0.0, positive=True)
    if within is not None and within <= 1:
        c.err(m, "within", f"{where}.within", f"expected a multiple of the tolerance above 1, got {within}")
        return None
    if credit is not None and not 0 < credit < 1:
        c.err(m, "credit", f"{where}.credit", f"expected a fraction of the points between 0 and 1, got {credit}")
        return None
    return PartialCredit(within, credit) if within is not None and credit is not None else None


def _override(c: _Collector, node, where: str, parent) -> dict:
    """The tolerance fields an instructor gave, validated; laid over each answer's own tolerance."""
    tol = _tolerance(c, node, where, Tolerance(), parent)
    return {k: getattr(tol, k) for k in (node if isinstance(node, dict) else {}) if hasattr(tol, k)}


def student_variant(asg: Assignment, item: Item, student_id: str, redraw: int = 0) -> Variant:
    """The variant of one item for one student (deterministic)."""
    try:
        return variant(item.problem, course=asg.course, salt=asg.salt, student=student_id, redraw=redraw)
    except GradekitError as exc:
        raise ProblemError(
            f"student {student_id}: {exc.format_message()}", path=asg.path, field=f"problems.{item.label}"
        ) from None


def sheet_variant(
    assignment: Path | str, problem: str, student: str, manifest: Path | str | None = None, bank=None
) -> Variant:
    """The variant *student*'s sheet of *assignment* printed for *problem* (an item label or bank id).

    Course and salt come from the assignment, the re-draw counter from the generation's
    *manifest* when given (it records the class de-duplication), else from the assignment's
    ``redraws:``.
    """
    asg = load_assignment(assignment, bank)
    item = next((it for it in asg.items if problem in (it.label, it.problem.id)), None)
    if item is None:
        choices = ", ".join(f"{it.label} ({it.problem.id})" for it in asg.items)
        raise GradekitError(f"expected a problem of the assignment ({choices}), got {problem!r}", path=asg.path)
    redraw = asg.redraws.get(student, {}).get(item.label, 0)
    if manifest is not None:
        redraw = redraws_from_manifest(Path(manifest)).get(student, {}).get(item.label, redraw)
    return student_variant(asg, item, student, redraw)


def keys_for(asg: Assignment, item: Item, student_id: str, v: Variant, with_mistakes: bool = True) -> list[KeyEntry]:
    """The key entries of one item for one student; points of the item shared by answer points."""
    answers = v.result.answers
    shares = split_points(item.points, [a.points for a in answers], item.points_step)
    mistakes = catalogued_mistakes(v) if with_mistakes else {}
    specs = {spec.key: spec for spec in item.problem.answers}
    out = []
    for i, a in enumerate(answers):
        spec = specs[a.base_key]
        override = item.tolerances.get(a.base_key) or item.tolerance
        if override:  # the instructor's fields over the answer's own (measured) tolerance
            tol = replace(spec.tolerance, **override).resolve(a.scale)
        else:
            tol = a.tolerance
        out.append(
            KeyEntry(
                student_id,
                item.label,
                f"{item.label}.{a.key}",
                float(a.value),
                a.unit,
                tol,
                shares[i],
                a.description,
                a.sign,
                tuple(mistakes.get(a.key, ())),
                spec.hand_check,
            )
        )
    return _distinct_mistakes(out)


def _distinct_mistakes(entries: list[KeyEntry]) -> list[KeyEntry]:
    """*entries* each without the catalogued mistakes its own band accepts around the key (no mistake a
    right answer could be taken for), all checked in one pass."""
    pairs = [(e, m) for e in entries for m in e.mistakes]
    if not pairs:
        return entries
    same = within([m.value for _, m in pairs], [e.value for e, _ in pairs],
                  *tolerance_columns([e.tolerance for e, _ in pairs])).tolist()
    kept: dict[int, list] = {id(e): [] for e in entries}
    for (e, m), hit in zip(pairs, same, strict=True):
        if not hit:
            kept[id(e)].append(m)
    return [e._replace(mistakes=tuple(kept[id(e)])) if len(kept[id(e)]) != len(e.mistakes) else e for e in entries]


STEPS = (0.5, 0.25, 0.1, 0.05, 0.01)  # readable answer points, coarsest first


def split_points(total: float, weights: list[float], step: float | None = None) -> list[float]:
    """*total* points shared among answers in proportion to *weights*, in whole multiples of a step.

    The step is *step* when the assignment states one, else the coarsest of 0.5, 0.25, 0.1, ...
    that divides *total* and gives every answer at least one step. Shares are rounded by the
    largest remainder, so they add up to *total* exactly (10 points over 9 answers: 1 and 1.5,
    never 1.111).
    """
    n = len(weights)
    if n == 0:
        return []
    weight = sum(weights) or float(n)
    weights = [w if sum(weights) else 1.0 for w in weights]
    candidates = (step,) if step else STEPS
    for st in candidates:
        units = total / st
        if abs(units - round(units)) < 1e-9 and (round(units) >= n or st == candidates[-1]):
            break
    else:
        return [round(total * w / weight, 6) for w in weights]
    units = round(total / st)
    exact = [units * w / weight for w in weights]
    base = [int(e + 1e-9) for e in exact]
    order = sorted(range(n), key=lambda i: (-(exact[i] - base[i]), i))
    for i in order[: units - sum(base)]:
        base[i] += 1
    return [float(round(b * st, 6)) for b in base]


def manifest(asg: Assignment, students: list[str], seeds: dict[str, dict[str, int]], keys_text: str = "") -> dict:
    """What grading needs: the frozen keys' file and hash, and what fixed them (seeds, re-draws, the
    hashes of each problem file and of the measured tolerance table, the gradekit version)."""
    return {
        "gradekit": __version__,
        "keys": {"file": frozen.FILE, "sha256": frozen.sha256(keys_text)} if keys_text else {},
        "tolerances_sha256": tolerance_table_hash(asg),
        "assignment": {
            "path": asg.path,
            "sha256": asg.sha256,
            "title": asg.title,
            "course": asg.course,
            "salt": asg.salt,
        },
        "problems": {
            it.label: {"id": it.problem.id, "sha256": problem_hash(it.problem), "points": it.points} for it in asg.items
        },
        "students": {s: seeds.get(s, {}) for s in students},
    }


def problem_hash(p: Problem) -> str:
    return hashlib.sha256(Path(p.path).read_bytes()).hexdigest() if p.path else ""


def tolerance_table_hash(asg: Assignment) -> str:
    """SHA-256 of the measured tolerance table of the bank the assignment's problems come from."""
    folders = {Path(it.problem.path).resolve().parent for it in asg.items if it.problem.path}
    h = hashlib.sha256()
    for folder in sorted(folders):
        f = folder / "_tolerances.yaml"
        h.update(f.read_bytes() if f.is_file() else b"")
    return h.hexdigest()


def frozen_keys(path: Path) -> Mapping[str, list[KeyEntry]] | None:
    """The keys frozen by generate beside *path* (a manifest.json), verified; None for an older run (a
    manifest without ``keys``). A ``keys`` entry without the file's name and hash, or naming a file
    outside the manifest's folder, is refused."""
    data = _manifest_data(path)
    if "keys" not in data:
        return None
    info = data["keys"]
    name = info.get("file") if isinstance(info, dict) else None
    if not isinstance(name, str) or not isinstance(info.get("sha256"), str):
        raise ProblemError(f"expected keys: {{file, sha256}} naming the frozen keys, got {info!r} (grade with "
                           "--recompute-keys to grade against the current bank instead)", path=str(path))
    if Path(name).name != name or name in ("", ".", ".."):
        raise ProblemError(f"expected keys.file to name a file beside the manifest, got {name!r}", path=str(path))
    f = path.parent / name
    try:
        data = f.read_bytes()  # hashed and parsed as bytes: a 3,000-student file is 12 MB
    except OSError as exc:
        raise ProblemError(f"expected the frozen keys the manifest names, got {exc}", path=str(f)) from None
    if b"\r" in data:  # line ends as text mode reads them (a copy that went through Windows); one byte:
        data = data.replace(b"\r\n", b"\n")  # a memchr, where looking for two took 25 ms at 12 MB
    if frozen.sha256(data) != info.get("sha256"):
        raise ProblemError(
            "expected the frozen keys the manifest was written with, got a file whose SHA-256 differs "
            "(edited or from another run)",
            path=str(f),
        )
    return frozen.loads(data, str(f))


def _manifest_data(path: Path) -> dict:
    try:
        data = orjson.loads(path.read_bytes())  # read three times by grade: 0.6 MB for 3,000 students
    except (OSError, ValueError) as exc:
        raise ProblemError(
            f"expected a manifest.json written by gradekit generate, got {exc}", path=str(path)
        ) from None
    if not isinstance(data, dict):
        raise ProblemError("expected a manifest.json written by gradekit generate, got another JSON", path=str(path))
    return data


def check_manifest(asg: Assignment, path: Path) -> list[str]:
    """Differences between an assignment, its bank and gradekit as they are now and at generation."""
    data = _manifest_data(path)
    given = data.get("assignment") if isinstance(data.get("assignment"), dict) else {}
    problems = data.get("problems") if isinstance(data.get("problems"), dict) else {}
    theirs = (given.get("course"), given.get("salt"),
              sorted((str(label), str(p.get("id") if isinstance(p, dict) else p)) for label, p in problems.items()))
    mine = (asg.course, asg.salt, sorted((it.label, it.problem.id) for it in asg.items))
    if theirs != mine:
        def said(course, salt, items) -> str:
            listed = ", ".join(f"{lb}={pid}" for lb, pid in items) or "none"
            return f"course {course!r}, salt {salt!r}, problems {listed}"

        raise ProblemError(
            f"expected the manifest of this assignment ({asg.path}: {said(*mine)}), got one generated for "
            f"{given.get('path') or 'another assignment'} ({said(*theirs)})", path=str(path))
    notes = []
    if data.get("gradekit") != __version__:
        notes.append(f"gradekit is now {__version__}, the documents were generated by {data.get('gradekit')}")
    if data.get("tolerances_sha256") and data["tolerances_sha256"] != tolerance_table_hash(asg):
        notes.append("the measured tolerance table (_tolerances.yaml) changed since generation")
    if data.get("assignment", {}).get("sha256") != asg.sha256:
        notes.append("the assignment file changed since the documents were generated")
    for it in asg.items:
        old = data.get("problems", {}).get(it.label, {})
        if old.get("id") != it.problem.id:
            notes.append(f"{it.label}: the problem is now {it.problem.id}, was {old.get('id')}")
        elif old.get("sha256") != problem_hash(it.problem):
            notes.append(f"{it.label}: bank problem {it.problem.id} changed since generation (keys may differ)")
    return notes


def seeds_of(asg: Assignment, student_id: str, redraws: dict[str, int] | None = None) -> dict[str, dict]:
    """Per item: the seed and re-draw counter of a student's variant (for the manifest)."""
    out = {}
    for it in asg.items:
        redraw = (redraws or {}).get(it.label, 0)
        out[it.label] = {"seed": derive_seed(asg.course, asg.salt, student_id, it.problem.id, redraw), "redraw": redraw}
    return out


def class_redraws(asg: Assignment, student_ids: list[str]) -> dict[str, dict[str, int]]:
    """Each student's re-draw counter per item: the assignment's explicit re-draws plus the class
    de-duplication (no two students share a variant). Generation and grading both use this."""
    _, variants = class_keys(asg, student_ids, with_mistakes=False, need_keys=False)
    return {s: {label: v.redraw for label, v in per.items()} for s, per in variants.items()}


def class_keys(
    asg: Assignment,
    student_ids: list[str],
    redraws: dict[str, dict[str, int]] | None = None,
    with_mistakes: bool = True,
    need_keys: bool = True,
    progress=None,
) -> tuple[list[KeyEntry], dict[str, dict[str, Variant]]]:
    """Every student's variants and key entries, no two students alike within an item.

    Args:
        asg: the assignment.
        student_ids: the roster's ids, in roster order (later students are re-drawn on a clash).
        redraws: ``{student: {label: redraw}}`` from a manifest, to reproduce generation exactly.
        with_mistakes: re-solve the catalogued mistakes for diagnosis.
        progress: called with each item's label once its whole class is drawn and solved.

    Returns:
        (key entries, ``{student: {label: Variant}}``).
    """
    from gradekit.solving.sampling import class_variants

    variants: dict[str, dict[str, Variant]] = {s: {} for s in student_ids}
    for item in asg.items:
        source = redraws if redraws is not None else asg.redraws
        start = {s: r[item.label] for s, r in source.items() if item.label in r}
        try:
            per = class_variants(item.problem, asg.course, asg.salt, student_ids, start, frozen=redraws is not None)
        except GradekitError as exc:
            raise ProblemError(exc.format_message(), path=asg.path, field=f"problems.{item.label}") from None
        for s, v in per.items():
            variants[s][item.label] = v
        if progress is not None:
            progress(item.label)
    if not need_keys:
        return [], variants
    keys = [
        k
        for s in student_ids
        for item in asg.items
        for k in keys_for(asg, item, s, variants[s][item.label], with_mistakes)
    ]
    return keys, variants


def redraws_from_manifest(path: Path) -> dict[str, dict[str, int]]:
    """The re-draw counters recorded at generation (``students.<id>.<label>.redraw``)."""
    data = _manifest_data(path)
    out = {}
    for s, seeds in data.get("students", {}).items():
        out[s] = {label: _redraw(v.get("redraw", 0), path, f"students.{s}.{label}.redraw") if isinstance(v, dict)
                  else 0 for label, v in seeds.items()}
    return out


def _redraw(value, path: Path, field: str) -> int:
    """A recorded re-draw counter: a whole number from 0 (a manifest edited by hand says where it is not)."""
    if isinstance(value, bool) or not isinstance(value, int) or value < 0:
        raise ProblemError(f"expected a re-draw counter (a whole number from 0), got {value!r}", path=str(path),
                           field=field)
    return value
