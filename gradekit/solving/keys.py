"""The answer key: what one student must answer, in which unit, within which tolerance.

Shared by the solver side (which computes keys), the documents (which print them) and the
grader (which compares submissions with them).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import NamedTuple

import numpy as np


def half_widths(values, rel, abs_, sigfigs=0):
    """Half-widths of the acceptance bands around key *values*: max(rel·|v|, abs), and where
    *sigfigs* > 0 at least half a unit in the last of that many significant figures. Every argument
    may be an array (one item a cell) or one number. The one band rule of gradekit: grading, copy
    detection, the documents and the quiz exports all read it."""
    v = np.abs(np.asarray(values, float))
    width = np.maximum(np.multiply(rel, v), abs_)
    sig = np.asarray(sigfigs)
    if np.any(sig > 0):
        with np.errstate(divide="ignore", invalid="ignore"):
            exponent = np.floor(np.log10(np.where(v > 0, v, 1.0))) - sig + 1
        width = np.where((v > 0) & (sig > 0), np.maximum(width, 0.5 * 10.0**exponent), width)
    return width


def wrapped(difference, period):
    """*difference* wrapped into [−period/2, period/2) where *period* > 0 (360 for directions in degrees)."""
    period = np.asarray(period, float)
    if not np.any(period > 0):
        return difference
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(period > 0, (difference + period / 2) % np.where(period > 0, period, 1.0) - period / 2,
                        difference)


def within(answers, values, rel, abs_, sigfigs=0, period=0.0, widen=1.0):
    """True where each answer lies in the band around its key value: |wrapped(x − v)| ≤ *widen* ·
    `half_widths` (with a relative allowance of 1e-12 for rounding; *widen* > 1 for the wider band of
    partial credit). NaN and infinities are never within."""
    answers, values = np.asarray(answers, float), np.asarray(values, float)
    with np.errstate(invalid="ignore"):
        band = np.multiply(widen, half_widths(values, rel, abs_, sigfigs))
        ok = np.abs(wrapped(answers - values, period)) <= band * (1 + 1e-12)
    return ok & np.isfinite(answers) & np.isfinite(values)


def tolerance_columns(tolerances) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Tolerances (each with its floor resolved into ``abs``) as the columns `within` reads: rel, abs,
    significant figures (0 where the mode is not ``sigfigs``) and period."""
    return (
        np.array([t.rel for t in tolerances], float),
        np.array([t.abs for t in tolerances], float),
        np.array([t.sigfigs if t.mode == "sigfigs" else 0 for t in tolerances], float),
        np.array([t.period for t in tolerances], float),
    )


@dataclass(frozen=True)
class PartialCredit:
    """The instructor's partial credit: an answer outside its band but within *within* times it earns
    *credit* of its points (``partial_credit: {within: 3, credit: 0.5}``); nothing beyond."""

    within: float
    credit: float


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

    def difference(self, answer, value):
        """answer − value, wrapped into [−period/2, period/2) when the tolerance has a period."""
        return wrapped(np.subtract(answer, value), self.period)

    def bands(self, values, scales=0.0):
        """Half-widths of the acceptance bands around key *values* (an array, or one value), each with
        its variant's *scale* for the floor (`half_widths` with ``abs`` raised to floor·|scale|)."""
        return half_widths(values, self.rel, self._abs(scales), self.sigfigs if self.mode == "sigfigs" else 0)

    def band(self, value: float) -> float:
        """Half-width of the acceptance band around the key *value*."""
        return float(self.bands(value))

    def accepts_many(self, answers, values, scales=0.0):
        """`within` for this tolerance: True where an answer lies in the band around its key value."""
        return within(answers, values, self.rel, self._abs(scales), self.sigfigs if self.mode == "sigfigs" else 0,
                      self.period)

    def accepts(self, answer: float, value: float) -> bool:
        """True when *answer* is within the band around *value*."""
        return bool(self.accepts_many(answer, value))

    def _abs(self, scales):
        if not self.floor:
            return self.abs
        scales = np.abs(np.asarray(scales, float))
        return np.maximum(self.abs, np.where(np.isfinite(scales), self.floor * scales, 0.0))

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


class Mistake(NamedTuple):
    """A catalogued mistake re-solved for one answer: its name and the value it leads to."""

    name: str
    description: str
    value: float


class KeyEntry(NamedTuple):
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
    mistakes: tuple[Mistake, ...] = ()
    # no band both admits honest work and rejects an answer 10 % off (benchmarks/RESULTS.md,
    # "Discrimination"): the instructor checks it, the grader only reads it
    hand_check: bool = False
