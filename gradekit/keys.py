"""The answer key: what one student must answer, in which unit, within which tolerance.

Shared by the solver side (which computes keys), the documents (which print them) and the
grader (which compares submissions with them).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace


@dataclass(frozen=True)
class Tolerance:
    """A named tolerance mode with a pure predicate.

    Modes:
        ``relative``: accept x when |x - v| <= max(rel * |v|, abs).
        ``sigfigs``: accept x when it equals v rounded to *sigfigs* significant figures,
            i.e. |x - v| <= 0.5 * 10**(floor(log10|v|) - sigfigs + 1), widened by ``rel``/``abs``
            if those are larger.
    ``floor`` is the absolute floor as a fraction of the variant's scale (the largest answer of
    the same dimension); `resolve` turns it into ``abs`` for one variant, so small components of
    large forces are judged against the error a student makes on the whole problem.
    ``period`` (360 for direction angles in degrees) wraps the difference: 359.9° is 0.2° from 0.1°.
    NaN and infinities are never accepted.
    """

    mode: str = "relative"
    rel: float = 0.01
    abs: float = 0.0
    sigfigs: int = 3
    floor: float = 0.0
    period: float = 0.0

    def resolve(self, scale: float) -> Tolerance:
        """This tolerance with its floor made absolute for a variant whose scale is *scale*."""
        if not self.floor or not math.isfinite(scale):
            return self
        return replace(self, abs=max(self.abs, self.floor * abs(scale)))

    def difference(self, answer: float, value: float) -> float:
        """answer - value, wrapped into [-period/2, period/2) when the tolerance has a period."""
        d = answer - value
        if self.period:
            d = (d + self.period / 2) % self.period - self.period / 2
        return d

    def band(self, value: float) -> float:
        """Half-width of the acceptance band around the key *value*."""
        width = max(self.rel * abs(value), self.abs)
        if self.mode == "sigfigs" and value != 0:
            exponent = math.floor(math.log10(abs(value))) - self.sigfigs + 1
            width = max(width, 0.5 * 10.0**exponent)
        return width

    def bands(self, values, scales):
        """`band` for arrays of key values, each with its variant's scale (floor resolved per variant)."""
        import numpy as np

        v = np.abs(np.asarray(values, float))
        scales = np.abs(np.asarray(scales, float))
        floor = np.where(np.isfinite(scales), np.maximum(self.abs, self.floor * scales), self.abs) if self.floor else 0
        width = np.maximum(self.rel * v, np.maximum(self.abs, floor))
        if self.mode == "sigfigs":
            with np.errstate(divide="ignore", invalid="ignore"):
                exponent = np.floor(np.log10(np.where(v > 0, v, 1.0))) - self.sigfigs + 1
            width = np.where(v > 0, np.maximum(width, 0.5 * 10.0**exponent), width)
        return width

    def accepts_many(self, answers, values, scales):
        """`accepts` for arrays: each answer against its key value, the floor resolved per variant."""
        import numpy as np

        answers, values = np.asarray(answers, float), np.asarray(values, float)
        with np.errstate(invalid="ignore"):
            ok = np.abs(self.difference(answers, values)) <= self.bands(values, scales) * (1 + 1e-12)
        return ok & np.isfinite(answers) & np.isfinite(values)

    def accepts(self, answer: float, value: float) -> bool:
        """True when *answer* is within the band around *value*."""
        if not (math.isfinite(answer) and math.isfinite(value)):
            return False
        return abs(self.difference(answer, value)) <= self.band(value) * (1 + 1e-12)

    def describe(self) -> str:
        """Human text, e.g. ``±1 % (at least 0.05)`` or ``3 significant figures``."""
        if self.mode == "sigfigs":
            return f"{self.sigfigs} significant figures"
        if self.period and not self.rel:
            return f"±{self.abs:.3g}°" if self.period == 360 else f"±{self.abs:.3g}"
        text = f"±{self.rel * 100:g} %"
        if self.abs:
            text += f" (at least ±{self.abs:.2g})"
        return text


@dataclass(frozen=True)
class Mistake:
    """A catalogued mistake re-solved for one answer: its name and the value it leads to."""

    name: str
    description: str
    value: float


@dataclass(frozen=True)
class KeyEntry:
    """One answer of one student's variant.

    ``key`` is unique within an assignment (``<problem-label>.<answer-key>``, e.g. ``p1.T``).
    ``value`` is expressed in ``unit``; ``points`` is what the answer is worth.
    """

    student_id: str
    problem: str
    key: str
    value: float
    unit: str
    tolerance: Tolerance
    points: float = 1.0
    description: str = ""
    sign_convention: str = ""
    mistakes: tuple[Mistake, ...] = field(default=())

    def __getstate__(self) -> dict:
        if "mistakes" not in self.__dict__:  # deferred (`_Deferred`): made now, so a copy stands alone
            self.mistakes  # noqa: B018
        return self.__dict__


class _Deferred:
    """``KeyEntry.mistakes`` of an entry made without its mistakes (the frozen keys: most answers are
    right and never read them): its ``__dict__`` holds ``_mistakes_later``, a pair (function,
    argument) that makes the tuple, made on first read and kept. An entry made by ``__init__`` holds
    its tuple and never reaches this (a non-data descriptor: the instance's own value wins); read on
    the class, it is the field's default."""

    def __get__(self, entry: KeyEntry | None, owner: type | None = None) -> tuple[Mistake, ...]:
        if entry is None:
            return ()
        fields = entry.__dict__
        make, arg = fields["_mistakes_later"]
        mistakes = fields["mistakes"] = make(arg)
        del fields["_mistakes_later"]
        return mistakes


KeyEntry.mistakes = _Deferred()  # after the dataclass took its default


@dataclass(frozen=True)
class KeyColumns:
    """A class's key entries as columns, one row an entry, made without the entries (the frozen keys:
    `gradekit.frozen.FrozenKeys.columns`): what copy detection reads of them
    (`gradekit.grading.integrity.class_keys`).

    ``students`` in order, a student's ``count`` entries standing together; per entry its answer
    ``keys``, ``values`` and ``floors`` (the absolute floor of its tolerance, as ``Tolerance.abs``,
    arrays of floats); per answer key, ``answers`` holds its problem and its tolerance without the
    floor (``abs`` 0): an entry's tolerance is that one with its own floor.
    """

    students: list[str]
    counts: list[int]
    keys: list[str]
    values: object  # numpy.ndarray
    floors: object  # numpy.ndarray
    answers: dict[str, tuple[str, Tolerance]]

    def tolerance(self, i: int) -> Tolerance:
        """Entry *i*'s tolerance."""
        return replace(self.answers[self.keys[i]][1], abs=float(self.floors[i]))
