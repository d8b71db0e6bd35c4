"""Keys frozen when they are issued: `generate` writes every student's key to ``keys.json`` beside the
manifest, and `grade --manifest` grades against exactly those keys, never re-sampling.

A later change of the bank, the measured tolerance table or gradekit itself can therefore never
change what a student is graded against; `grade` names what changed and keeps the frozen keys
unless the instructor asks for keys recomputed from the current bank (``--recompute-keys``).

Layout (compact: what is the same for the whole class is written once per answer)::

    {"format": 1, "gradekit": "0.1.0",
     "answers": {"p1.T": {"problem": "p1", "unit": "N*m", "points": 2, "description": …,
                          "sign": …, "tolerance": {"mode", "rel", "sigfigs", "floor", "period"},
                          "hand_check": true (only where the bank marks the answer for hand checking)}},
     "mistakes": {"static-answer": "a static answer to a dynamic problem (inertia left out)"},
     "students": {"1001": {"p1.T": [value, tolerance abs, [[mistake, value], …]]}}}
"""

from __future__ import annotations

import hashlib
import json
import math
from collections.abc import Iterable

import numpy as np
import orjson

from gradekit import __version__
from gradekit.errors import GradekitError
from gradekit.solving.keys import KeyEntry, Mistake, Tolerance

FILE = "keys.json"
FORMAT = 1


def dumps(keys: Iterable[KeyEntry]) -> str:
    """The frozen-keys document of *keys* (every student's entries, in order)."""
    answers: dict[str, dict] = {}
    mistakes: dict[str, str] = {}
    students: dict[str, dict[str, list]] = {}
    for e in keys:
        t = e.tolerance
        answers.setdefault(
            e.key,
            {
                "problem": e.problem,
                "unit": e.unit,
                "points": e.points,
                "description": e.description,
                "sign": e.sign_convention,
                "tolerance": {"mode": t.mode, "rel": t.rel, "sigfigs": t.sigfigs, "floor": t.floor, "period": t.period},
                **({"hand_check": True} if e.hand_check else {}),
            },
        )
        for m in e.mistakes:
            mistakes.setdefault(m.name, m.description)
        students.setdefault(e.student_id, {})[e.key] = [e.value, t.abs, [[m.name, m.value] for m in e.mistakes]]
    doc = {"format": FORMAT, "gradekit": __version__, "answers": answers, "mistakes": mistakes, "students": students}
    return json.dumps(doc, ensure_ascii=False, separators=(",", ":"), allow_nan=False) + "\n"


def loads(text: str | bytes, path: str) -> dict[str, list[KeyEntry]]:
    """Every student's frozen key entries, ``{student: [KeyEntry, …]}``, from a ``keys.json`` text
    (or its UTF-8 bytes).

    Parsed by orjson (a quarter of the standard `json`'s time on a class's file). Every number of the
    file is checked at once at the end: a value that is not a finite number, a negative tolerance or
    any other malformed part is refused with one message naming *path*.
    """
    try:
        doc = orjson.loads(text)
        if not isinstance(doc, dict) or doc.get("format") != FORMAT:
            found = doc.get("format") if isinstance(doc, dict) else type(doc).__name__
            raise ValueError(f"format {found!r}, expected {FORMAT}")
        names = doc["mistakes"]
        shared = {key: _shared(key, a) for key, a in doc["answers"].items()}
        students = doc["students"]
        if not isinstance(students, dict):
            raise TypeError(f"students as {type(students).__name__}, expected an object")
        out: dict[str, list[KeyEntry]] = {}
        numbers: list = []  # every value, tolerance and mistake value, checked together below
        floors: list = []
        for sid, rows in students.items():
            entries = []
            for key, (value, tol_abs, found) in rows.items():
                problem, tolerance, tolerances, (unit, points, description, sign, hand) = shared[key]
                tol = tolerances.get(tol_abs)
                if tol is None:
                    tol = tolerances[tol_abs] = tolerance(tol_abs)
                mistakes = tuple([Mistake(name, names[name], v) for name, v in found]) if found else ()
                entries.append(KeyEntry(sid, problem, key, value, unit, tol, points, description, sign, mistakes,
                                        hand))
                numbers.append(value)
                floors.append(tol_abs)
                numbers.extend([v for _, v in found])
            out[sid] = entries
        _check_numbers(numbers, floors, out)
        return out
    except (ValueError, KeyError, TypeError, AttributeError) as exc:
        raise _corrupt(exc, path) from None


def _check_numbers(numbers: list, floors: list, out: dict[str, list[KeyEntry]]) -> None:
    """Refuse a value, mistake value or tolerance that is not a finite number, or a negative tolerance,
    naming the first entry that holds one."""
    values, tolerances = np.array(numbers), np.array(floors)
    if (values.dtype.kind in "fi" and tolerances.dtype.kind in "fi" and np.isfinite(values).all()
            and np.isfinite(tolerances).all() and (tolerances >= 0).all()):
        return
    for entries in out.values():
        for e in entries:
            _finite(e.value, f"{e.student_id} {e.key} value")
            _nonnegative(e.tolerance.abs, f"{e.student_id} {e.key} tolerance")
            for m in e.mistakes:
                _finite(m.value, f"{e.student_id} {e.key} {m.name}")
    raise ValueError("a value that is not a finite number")


def _shared(key: str, a: dict) -> tuple:
    """What every student's entry of answer *key* shares: its problem, a maker of its tolerance given the
    student's absolute floor, and the entry's other fields."""
    t = a["tolerance"]
    rel, floor, period, sigfigs = (_nonnegative(t[f], f"{key} tolerance {f}")
                                   for f in ("rel", "floor", "period", "sigfigs"))
    if t["mode"] not in ("relative", "sigfigs"):
        raise ValueError(f"{key} tolerance mode {t['mode']!r}, expected relative or sigfigs")

    def tolerance(floor_abs: float) -> Tolerance:
        return Tolerance(t["mode"], rel, floor_abs, sigfigs=int(sigfigs), floor=floor, period=period)

    fields = (str(a["unit"]), _nonnegative(a["points"], f"{key} points"), str(a["description"]), str(a["sign"]),
              a.get("hand_check", False) is True)
    return str(a["problem"]), tolerance, {}, fields


def _finite(value, what: str) -> float:
    """*value* as a finite float."""
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
        raise ValueError(f"{what} {value!r}, expected a finite number")
    return float(value)


def _nonnegative(value, what: str) -> float:
    value = _finite(value, what)
    if value < 0:
        raise ValueError(f"{what} {value!r}, expected a number of at least 0")
    return value


def _corrupt(exc: Exception, path: str) -> GradekitError:
    return GradekitError(f"expected the frozen keys written by gradekit generate, got {exc}", path=path)


def sha256(text: str | bytes) -> str:
    """The hex SHA-256 of a ``keys.json`` text (as UTF-8) or of its bytes."""
    return hashlib.sha256(text.encode("utf-8") if isinstance(text, str) else text).hexdigest()
