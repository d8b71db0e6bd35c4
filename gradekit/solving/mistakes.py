"""The catalogued mistakes that need a re-solve, evaluated for a batch of variants (or one).

Static answer to a dynamic problem, the inertia torque left out, gravity left out (each solved
again with that mistake, for the whole batch at once), x and y swapped and the magnitude given
for a component (read off the same solution). Sign flips and unit slips need no re-solve
(`gradekit.grading.compare`).
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np

from gradekit import units
from gradekit.bank.model import Problem
from gradekit.errors import GradekitError
from gradekit.solving.keys import Mistake
from gradekit.solving.pipeline import ResultBatch, solve_many


@dataclass(frozen=True)
class MistakeBatch:
    """One mistake's value of one answer in every variant; ``changed`` where it differs from the key."""

    name: str
    text: str
    value: np.ndarray
    changed: np.ndarray


def _resolved(p: Problem) -> list[tuple[str, str, Problem]]:
    out: list[tuple[str, str, Problem]] = []
    if p.analysis == "dynamic":
        out.append(
            (
                "static-answer",
                "a static answer to a dynamic problem (inertia left out)",
                dataclasses.replace(p, analysis="static"),
            )
        )
        if any(m.inertia not in (0, 0.0) for m in p.mass):
            no_i = tuple(dataclasses.replace(m, inertia=0.0) for m in p.mass)
            out.append(("no-inertia-torque", "the inertia torque I·α left out", dataclasses.replace(p, mass=no_i)))
    if p.gravity is not None:
        out.append(("no-gravity", "gravity (the weights) left out", dataclasses.replace(p, gravity=None)))
    return out


def mistakes_many(batch: ResultBatch, values: dict, rows: np.ndarray | None = None) -> dict[str, list[MistakeBatch]]:
    """Every catalogued mistake of every answer of a solved batch (*values*: its raw parameter values).

    Computed once per batch (the re-solves are batched too) and remembered on it. With *rows* (a
    mask), only those variants need be re-solved (a sampler's batch also holds candidates that its
    other constraints rejected): the mistakes of the others read NaN, unchanged, until a later call
    asks for them. Each variant's values are the same however many are re-solved with it.
    """
    p, n = batch.problem, batch.n
    want = np.ones(n, bool) if rows is None else np.asarray(rows, bool)
    memo = batch.derived.get("mistakes")
    if memo is None:
        memo = batch.derived["mistakes"] = _Found(batch)
    todo = want & ~memo.done
    if todo.any():
        sub = np.flatnonzero(todo)
        part = values
        if len(sub) < n:
            part = {k: np.broadcast_to(v, (n,))[sub] if np.ndim(v) else v for k, v in values.items()}
        for (name, _text, mp), entries in zip(_resolved(p), memo.resolved, strict=True):
            if entries is None:  # the problem with this mistake cannot be solved at all
                continue
            try:
                res = solve_many(mp, part, len(sub))
            except GradekitError:
                memo.drop(name)
                continue
            for a, b, m in zip(batch.answer_list, res.answer_list, entries, strict=True):
                key = a.value[sub]
                m.value[sub] = b.value
                m.changed[sub] = res.ok & (np.abs(b.value - key) > 1e-6 * np.maximum(np.abs(key), 1e-12))
        memo.done |= todo
    return memo.out


class _Found:
    """The catalogued mistakes of a batch as far as computed: ``done`` marks the re-solved variants."""

    def __init__(self, batch: ResultBatch) -> None:
        n = batch.n
        self.done = np.zeros(n, bool)
        self.out: dict[str, list[MistakeBatch]] = {a.key: [] for a in batch.answer_list}
        self.resolved: list[list[MistakeBatch] | None] = []
        for name, text, _mp in _resolved(batch.problem):
            entries = [MistakeBatch(name, text, np.full(n, np.nan), np.zeros(n, bool)) for _ in batch.answer_list]
            for a, m in zip(batch.answer_list, entries, strict=True):
                self.out[a.key].append(m)
            self.resolved.append(entries)
        for a in batch.answer_list:  # read off the same solution: no re-solve
            if not a.spec.of.endswith((".x", ".y")):
                continue
            case = next(c for c in batch.cases if c.name == a.case)
            stem, comp = a.spec.of.rsplit(".", 1)
            for name, text, of in (
                ("x-y-swapped", "the x and y components swapped", f"{stem}.{'y' if comp == 'x' else 'x'}"),
                ("magnitude-for-component", "the magnitude given for a component", f"{stem}.mag"),
            ):
                if of in case.results:
                    v, u = case.results[of]
                    m = units.convert(v, u, a.unit)
                    self.out[a.key].append(
                        MistakeBatch(name, text, m, np.abs(m - a.value) > 1e-9 * np.maximum(np.abs(a.value), 1))
                    )

    def drop(self, name: str) -> None:
        """Forget a mistake whose problem cannot be solved (as if it were not catalogued)."""
        for key, found in self.out.items():
            self.out[key] = [m for m in found if m.name != name]
        self.resolved = [None if e and e[0].name == name else e for e in self.resolved]


def catalogued_mistakes(v) -> dict[str, list[Mistake]]:
    """Re-solve one variant with each catalogued mistake; map answer key -> mistakes that change it.

    *v* is a `gradekit.solving.sampling.Variant`: its problem, raw values, and the batch it was solved in
    (``v.batch``, ``v.index``; solved here when it has none).
    """
    batch, i, raw = getattr(v, "batch", None), getattr(v, "index", 0), getattr(v, "batch_values", None)
    if batch is None:
        raw = dict(v.values)
        batch = solve_many(v.problem, raw, 1)
    out: dict[str, list[Mistake]] = {}
    for key, found in mistakes_many(batch, raw).items():
        for m in found:
            if m.changed[i]:
                out.setdefault(key, []).append(Mistake(m.name, m.text, float(m.value[i])))
    return out
