"""Keys frozen when they are issued: `generate` writes every student's key to ``keys.json`` beside the
manifest, and `grade --manifest` grades against exactly those keys, never re-sampling.

A later change of the bank, the measured tolerance table or gradekit itself can therefore never
change what a student is graded against; `grade` names what changed and keeps the frozen keys
unless the instructor asks for keys recomputed from the current bank (``--recompute-keys``).

Layout (compact: what is the same for the whole class is written once per answer)::

    {"format": 1, "gradekit": "0.1.0",
     "answers": {"p1.T": {"problem": "p1", "unit": "N*m", "points": 2, "description": …,
                          "sign": …, "tolerance": {"mode", "rel", "sigfigs", "floor", "period"}}},
     "mistakes": {"static-answer": "a static answer to a dynamic problem (inertia left out)"},
     "students": {"1001": {"p1.T": [value, tolerance abs, [[mistake, value], …]]}}}
"""

from __future__ import annotations

import hashlib
import json
from collections.abc import Iterable, Iterator, Mapping
from functools import partial
from itertools import chain
from operator import itemgetter

import orjson

from gradekit import __version__
from gradekit.errors import GradekitError
from gradekit.keys import KeyColumns, KeyEntry, Mistake, Tolerance

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
            },
        )
        for m in e.mistakes:
            mistakes.setdefault(m.name, m.description)
        students.setdefault(e.student_id, {})[e.key] = [e.value, t.abs, [[m.name, m.value] for m in e.mistakes]]
    doc = {"format": FORMAT, "gradekit": __version__, "answers": answers, "mistakes": mistakes, "students": students}
    return json.dumps(doc, ensure_ascii=False, separators=(",", ":"), allow_nan=False) + "\n"


def loads(text: str | bytes, path: str) -> FrozenKeys:
    """Every student's frozen key entries, ``{student: [KeyEntry, …]}``, from a ``keys.json`` text
    (or its UTF-8 bytes).

    Parsed by orjson: the same values as the standard library's `json` (the file holds objects,
    arrays, strings and finite floats only, as `dumps` writes it) in a quarter of the time: the
    12 MB of 3,000 students in 52 against 205 ms (2026-11-24), of `grade`'s serial start.

    The text is parsed and what is the same for the class is read here; each student's entries are
    built on first access (`FrozenKeys`), so that a forked helper process builds those of the students
    it grades, not the parent before the fork. A student's malformed entries raise the same
    `GradekitError` (naming *path*) when they are first read.
    """
    try:
        doc = orjson.loads(text)
        if doc.get("format") != FORMAT:
            raise ValueError(f"format {doc.get('format')!r}, expected {FORMAT}")
        names = doc["mistakes"]
        shared: dict[str, tuple] = {}
        for key, a in doc["answers"].items():
            t = a["tolerance"]
            make = partial(Tolerance, t["mode"], t["rel"], sigfigs=t["sigfigs"], floor=t["floor"], period=t["period"])
            fields = {"student_id": None, "problem": a["problem"], "key": key, "value": None, "unit": a["unit"],
                      "tolerance": None, "points": a["points"], "description": a["description"],
                      "sign_convention": a["sign"]}  # an entry's, in order; the student's three filled in
            shared[key] = (a["problem"], make, {}, fields)
        students = doc["students"]
        if not isinstance(students, dict):
            raise TypeError(f"students as {type(students).__name__}, expected an object")
        return FrozenKeys(students, shared, names, path)
    except (ValueError, KeyError, TypeError, AttributeError) as exc:
        raise _corrupt(exc, path) from None


def _corrupt(exc: Exception, path: str) -> GradekitError:
    return GradekitError(f"expected the frozen keys written by gradekit generate, got {exc}", path=path)


class FrozenKeys(Mapping[str, list[KeyEntry]]):
    """The students of a ``keys.json`` and their key entries, each student's list built on first access
    and kept (`loads`).

    Students whose tolerance resolved to the same absolute floor share one (frozen) `Tolerance`. The
    records are filled in directly (as `_mistake`), not through their dataclass ``__init__``: equal
    to those it would make, at a third of the cost. An entry's catalogued mistakes (about 1.5 an
    answer) are checked when it is built but made only when first read (``KeyEntry.mistakes``
    deferred): grading reads them for wrong answers alone, about a quarter.
    """

    def __init__(self, students: dict[str, dict], shared: dict[str, tuple], names: dict[str, str], path: str) -> None:
        self._students, self._shared, self._names, self._path = students, shared, names, path
        self._built: dict[str, list[KeyEntry]] = {}

    def __getitem__(self, sid: str) -> list[KeyEntry]:
        entries = self._built.get(sid)
        if entries is None:
            rows = self._students[sid]  # KeyError: not a student of the file
            entries = self._built[sid] = self._build(sid, rows)
        return entries

    def __contains__(self, sid: object) -> bool:
        return sid in self._students

    def __iter__(self) -> Iterator[str]:
        return iter(self._students)

    def __len__(self) -> int:
        return len(self._students)

    def answers(self, sids: Iterable[str]) -> dict[str, str]:
        """Each answer key the entries of *sids* (students of the file) hold, with its problem, in the
        order of first appearance in their entries one student after the other (built or not)."""
        try:
            shared = self._shared
            return {key: shared[key][0] for key in dict.fromkeys(chain.from_iterable(map(self._students.get, sids)))}
        except (KeyError, TypeError) as exc:
            raise _corrupt(exc, self._path) from None

    def columns(self, sids: Iterable[str]) -> KeyColumns:
        """The entries of *sids* (students of the file, in that order) as columns, without building them
        (`KeyColumns`: what copy detection reads)."""
        import numpy as np

        sids = list(sids)
        try:
            rows = list(map(self._students.__getitem__, sids))
            cells = list(chain.from_iterable(map(dict.values, rows)))
            values = np.fromiter(map(_FIRST, cells), float, len(cells))
            floors = np.fromiter(map(_SECOND, cells), float, len(cells))
            keys = list(chain.from_iterable(rows))
            answers = {key: (shared[0], shared[1](abs=0.0)) for key, shared in self._shared.items()}
            return KeyColumns(sids, list(map(len, rows)), keys, values, floors, answers)
        except (ValueError, KeyError, TypeError, AttributeError, IndexError) as exc:
            raise _corrupt(exc, self._path) from None

    def _build(self, sid: str, rows: dict) -> list[KeyEntry]:
        try:
            shared, names, mistakes = self._shared, self._names, self._mistakes
            entries = []
            for key, (value, tol_abs, found) in rows.items():
                _, make, tolerances, common = shared[key]
                tol = tolerances.get(tol_abs)
                if tol is None:
                    tol = tolerances[tol_abs] = make(abs=tol_abs)
                entry = _new(KeyEntry)
                fields = entry.__dict__
                fields.update(common)
                fields["student_id"] = sid
                fields["value"] = float(value)
                fields["tolerance"] = tol
                if found:
                    for name, v in found:  # checked now, as the records would be; made when read
                        names[name]
                        float(v)
                    fields["_mistakes_later"] = (mistakes, found)
                else:
                    fields["mistakes"] = ()
                entries.append(entry)
            return entries
        except (ValueError, KeyError, TypeError, AttributeError) as exc:
            raise _corrupt(exc, self._path) from None

    def _mistakes(self, found: list) -> tuple[Mistake, ...]:
        """The `Mistake` records of one entry's ``[[name, value], …]`` (checked by `_build`)."""
        names = self._names
        return tuple([_mistake(name, names[name], float(v)) for name, v in found])


_new = object.__new__
_FIRST, _SECOND = itemgetter(0), itemgetter(1)


def _mistake(name: str, description: str, value: float) -> Mistake:
    """``Mistake(name, description, value)`` without the frozen dataclass's ``__init__`` (a class
    holds a few hundred thousand: its field-by-field ``object.__setattr__`` was most of their cost)."""
    m = _new(Mistake)
    m.__dict__.update(name=name, description=description, value=value)
    return m


def sha256(text: str | bytes) -> str:
    """The hex SHA-256 of a ``keys.json`` text (as UTF-8) or of its bytes."""
    return hashlib.sha256(text.encode("utf-8") if isinstance(text, str) else text).hexdigest()
