"""Copy detection that chance cannot trigger.

Two kinds of evidence, each flagged only when chance explains it with probability below
``alpha`` after accounting for every classmate the student was compared with:

**Matches a classmate's key.** An answer *x* that is wrong for the student (outside their own
band) "matches" classmate *j* when it lies in *j*'s band. For one answer the chance that a
random classmate's key falls in a band around *x* is estimated from the class's keys for that
answer: ``p = 2·max(W_left, W_right) / (h·(N−1))``, where ``W_left``/``W_right`` sum the band
half-widths of the keys within ``h`` below/above *x* (the larger side, so an answer at the edge
of the class's range is not given a thin density) and ``h`` reaches at least the 10th nearest key
and 3 bands. A second, sharper look asks for *x* to equal the key to the digits it was given
(radius half a unit of its last digit, at most 6 significant figures) with ``p`` scaled by that
radius over the band. Answers of one problem are functions of the same few inputs (some are
identical), so answers whose keys are rank-correlated across the class at ``|ρ| ≥ 0.7`` form one
trial with ``p = Σ p`` (a union bound). The matches with one classmate are then a sum of
independent Bernoulli trials (Poisson-binomial): the tail ``P(M ≥ m)`` of the best classmate's
count is corrected for the N−1 classmates, ``1 − (1 − P)^(N−1)``, and for the two looks (×2).

**Shares wrong answers.** Submitted values that are wrong for both students are indexed per answer
by their value rounded to 4 significant figures (hashing, never pairs of students). The chance
that a classmate's wrong answer lands in the same bin is the density of the class's wrong answers
near it times the bin's width at the precision the value was given in (a value given to 2
significant figures is easily shared), and never less than the share of the class (outside the
pair) that gave that same value. The count of shared trials is tested as above, and at least
``min_shared`` shared answers are required.

Everything is sorted arrays, ``searchsorted`` and hashing per answer key: a class of n students
with k answers costs O(n·k·log n) plus the matches found.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from itertools import chain, repeat
from operator import attrgetter

import numpy as np

from gradekit.grading.compare import StudentGrade
from gradekit.solving.keys import KeyEntry, half_widths

KEY_MATCH = "matches classmate's key"
SHARED_WRONG = "shares wrong answers"


@dataclass(frozen=True)
class IntegrityFlag:
    """Evidence that *student_id* handed in answers that come from *other_id*.

    ``reason`` is ``matches classmate's key`` (``other_matches`` answers of *student_id* fall in
    *other_id*'s bands, ``own_matches`` in their own) or ``shares wrong answers`` (both gave the
    same values, wrong for both, on ``other_matches`` answers). ``keys`` names the answers;
    ``p_value`` is the chance of that much agreement between independent students, already
    corrected for the number of classmates compared (None when not computed).
    """

    student_id: str
    other_id: str
    path: str
    own_matches: int
    other_matches: int
    keys: tuple[str, ...]
    p_value: float | None = None
    reason: str = KEY_MATCH
    other_path: str = ""

    def describe(self) -> str:
        """One line for the report."""
        chance = f"; chance {_odds(self.p_value)}" if self.p_value is not None else ""
        if self.reason == SHARED_WRONG:
            where = f"{self.path} and {self.other_path}" if self.other_path else self.path
            return (
                f"{where}: {self.student_id} and {self.other_id} give the same wrong values on "
                f"{self.other_matches} answers ({', '.join(self.keys)}){chance}"
            )
        return (
            f"{self.path}: {self.student_id} matches {self.other_id}'s key on "
            f"{self.other_matches} answers ({', '.join(self.keys)}) but their own on "
            f"{self.own_matches}{chance}"
        )


def _odds(p: float) -> str:
    """``p ≈ 3e-07 (1 in 3,000,000) for independent work, all classmates compared``."""
    if p <= 0:
        return "below 1e-300 for independent work, all classmates compared"
    return f"p ≈ {p:.1g} (1 in {1 / p:,.0f}) for independent work, all classmates compared"


def poisson_binomial_tails(probs: np.ndarray) -> np.ndarray:
    """``P(M ≥ m)`` for m = 0..T of M = Σ Bernoulli(probs[:, t]), one row per student.

    Args:
        probs: (students, T) success probabilities (0 for trials that do not exist).

    Returns:
        (students, T + 1) upper tails.
    """
    n, t = probs.shape
    dist = np.zeros((n, t + 1))
    dist[:, 0] = 1.0
    for i in range(t):
        p = probs[:, i : i + 1]
        dist[:, 1 : i + 2] = dist[:, 1 : i + 2] * (1 - p) + dist[:, : i + 1] * p
        dist[:, 0:1] *= 1 - p
    return np.clip(np.cumsum(dist[:, ::-1], axis=1)[:, ::-1], 0.0, 1.0)


def corrected(p: np.ndarray, comparisons: int) -> np.ndarray:
    """``1 − (1 − p)^comparisons``: the chance that any of that many classmates does as well."""
    p = np.clip(p, 0.0, 1.0)
    with np.errstate(divide="ignore"):
        return -np.expm1(comparisons * np.log1p(-np.minimum(p, 1 - 1e-16)))


def _digits_radius(x: np.ndarray, cap: int) -> tuple[np.ndarray, np.ndarray]:
    """(significant figures given, at most *cap*; half a unit of the last one) per value."""
    ax = np.abs(x)
    with np.errstate(divide="ignore", invalid="ignore"):
        e = np.floor(np.log10(np.where(ax > 0, ax, 1.0)))
    sig = np.full(x.shape, cap)
    for s in range(cap - 1, 0, -1):
        q = 10.0 ** (e - s + 1)
        exact = np.abs(np.round(x / q) * q - x) <= 1e-9 * np.maximum(ax, 1e-300)
        sig = np.where(exact, s, sig)
    return sig, 0.5 * 10.0 ** (e - sig + 1) * (1 + 1e-9)


def _density(sorted_values: np.ndarray, weights: np.ndarray, x: np.ndarray, floor: np.ndarray, k: int):
    """For each x: the larger one-sided sum of *weights* within h of x, and h.

    h is at least *floor* and reaches the k-th nearest of *sorted_values*.
    """
    n = len(sorted_values)
    if n == 0:
        return np.zeros_like(x), np.maximum(floor, 1e-300)
    k = max(1, min(k, n))
    at = np.searchsorted(sorted_values, x)
    offsets = np.arange(-k, k)
    idx = np.clip(at[:, None] + offsets[None, :], 0, n - 1)
    dist = np.abs(sorted_values[idx] - x[:, None])
    kth = np.partition(dist, k - 1, axis=1)[:, k - 1]
    h = np.maximum(np.maximum(kth, floor), 1e-300)
    cum = np.concatenate([[0.0], np.cumsum(weights)])
    lo = np.searchsorted(sorted_values, x - h, "left")
    mid_l = np.searchsorted(sorted_values, x, "left")
    mid_r = np.searchsorted(sorted_values, x, "right")
    hi = np.searchsorted(sorted_values, x + h, "right")
    left = cum[mid_r] - cum[lo]
    right = cum[hi] - cum[mid_l]
    return np.maximum(left, right), h


def _clusters(
    names: list[str], problem_of: list[str], everyone: list[str], key_ix: np.ndarray, cols: np.ndarray,
    values: np.ndarray, threshold: float,
) -> dict[str, int]:
    """Answer key → trial id: answers of one problem whose keys are rank-correlated at |ρ| ≥ threshold share one.

    *names* and *problem_of* list each answer key and its problem; entry i of *key_ix*, *cols* and
    *values* is the key of answer ``names[key_ix[i]]`` for student ``everyone[cols[i]]``.
    """
    table = np.zeros((len(names), len(everyone)))
    present = np.zeros((len(names), len(everyone)), bool)
    table[key_ix, cols] = values
    present[key_ix, cols] = True
    by_sid = np.array(sorted(range(len(everyone)), key=everyone.__getitem__), dtype=np.int64)
    out: dict[str, int] = {}
    by_problem: dict[str, list[int]] = {}
    for i, problem in enumerate(problem_of):
        by_problem.setdefault(problem, []).append(i)
    for members in by_problem.values():
        parent = list(range(len(members)))

        def root(i: int, parent: list[int] = parent) -> int:
            while parent[i] != i:
                parent[i] = parent[parent[i]]
                i = parent[i]
            return i

        common = by_sid[present[members][:, by_sid].all(axis=0)]  # students with every one, by id
        if len(members) > 1 and len(common) >= 5:
            matrix = table[members][:, common].T
            ranks = np.argsort(np.argsort(matrix, axis=0), axis=0).astype(float)
            with np.errstate(invalid="ignore", divide="ignore"):
                rho = np.corrcoef(ranks, rowvar=False)
            rho = np.nan_to_num(np.atleast_2d(rho), nan=0.0)
            for i in range(len(members)):
                for j in range(i + 1, len(members)):
                    if abs(rho[i, j]) >= threshold:
                        parent[root(i)] = root(j)
        base = len(out)
        roots: dict[int, int] = {}
        for i, m in enumerate(members):
            out[names[m]] = base + roots.setdefault(root(i), len(roots))
    return out


def _bands(tolerances: list, values: np.ndarray) -> np.ndarray:
    """Each key value's band (`gradekit.solving.keys.half_widths`, each entry's floor resolved in its ``abs``)."""
    return half_widths(
        values,
        np.array([t.rel for t in tolerances], float),
        np.array([t.abs for t in tolerances], float),
        np.array([t.sigfigs if t.mode == "sigfigs" else 0 for t in tolerances], float),
    )


def _best_pairs(hits: list[tuple[np.ndarray, np.ndarray]], n_sub: int, n_all: int, n_trials: int):
    """Per student: the classmate sharing the most distinct trials, that count and the answers.

    *hits* holds (code, answer id) arrays with code = (student row · N + classmate) · trials + trial.
    """
    count = np.zeros(n_sub, int)
    other = np.full(n_sub, -1)
    if not hits:
        return count, other, {}
    code = np.concatenate([h[0] for h in hits])
    answer = np.concatenate([h[1] for h in hits])
    if not len(code):
        return count, other, {}
    pair = code // n_trials
    s = pair // n_all
    codes = np.sort(code)
    codes = codes[np.concatenate([[True], codes[1:] != codes[:-1]])] // n_trials
    starts = np.flatnonzero(np.concatenate([[True], codes[1:] != codes[:-1]]))
    pairs, counts = codes[starts], np.diff(np.append(starts, len(codes)))
    owner = pairs // n_all  # sorted, and classmates ascending within each owner
    groups = np.flatnonzero(np.concatenate([[True], owner[1:] != owner[:-1]]))
    best = np.maximum.reduceat(counts, groups)
    top = np.flatnonzero(counts == np.repeat(best, np.diff(np.append(groups, len(owner)))))
    top = top[np.concatenate([[True], owner[top][1:] != owner[top][:-1]])]  # first classmate of the most
    count[owner[top]] = counts[top]
    other[owner[top]] = pairs[top] % n_all
    chosen = np.full(n_sub, -1, np.int64)
    chosen[owner[top]] = pairs[top]
    mine = pair == chosen[s]
    answers: dict[int, list[int]] = {}
    for p, a in zip(pair[mine].tolist(), answer[mine].tolist(), strict=True):
        answers.setdefault(p // n_all, []).append(a)
    return count, other, answers


@dataclass(frozen=True)
class AnswerKeys:
    """The class's keys as copy detection reads them, made from the key entries alone (`answer_keys`).

    ``everyone`` lists the students with keys in key order, ``col`` their column; ``names`` the
    answer keys in order of first appearance; ``per_key[a]`` the class's keys of answer *a* sorted
    by value, as (values, bands, columns, median band), repeated a period below and above for an
    answer with a ``period`` (of its last entry); ``trial_of`` each answer key's trial.
    """

    everyone: list[str]
    col: dict[str, int]
    names: list[str]
    trial_of: dict[str, int]
    per_key: dict[int, tuple[np.ndarray, np.ndarray, np.ndarray, float]]
    period: np.ndarray


def answer_keys(keys: Sequence[KeyEntry], correlated: float = 0.7) -> AnswerKeys:
    """The part of copy detection that reads the keys alone (see `AnswerKeys`)."""
    sids = list(map(_STUDENT, keys))
    everyone = list(dict.fromkeys(sids))
    col = {sid: i for i, sid in enumerate(everyone)}
    key_names = list(map(_KEY, keys))
    names = list(dict.fromkeys(key_names))
    aid = {name: i for i, name in enumerate(names)}
    n = len(keys)
    key_ix = np.fromiter(map(aid.__getitem__, key_names), np.int64, n)
    cols = np.fromiter(map(col.__getitem__, sids), np.int64, n)
    values = np.fromiter(map(_VALUE, keys), float, n)
    bands = _bands(list(map(_TOLERANCE, keys)), values)
    by_key = np.argsort(key_ix, kind="stable")
    starts = np.searchsorted(key_ix[by_key], np.arange(len(names) + 1))
    problems = [keys[i].problem for i in by_key[starts[:-1]]]  # each key's first entry
    period = np.array([keys[i].tolerance.period for i in by_key[starts[1:] - 1]], float)  # each key's last entry
    trial_of = _clusters(names, problems, everyone, key_ix, cols, values, correlated)
    per_key = {}
    for a, idx in enumerate(np.split(by_key, starts[1:-1])):
        v, w, o = values[idx], bands[idx], cols[idx]
        if period[a]:
            v = np.mod(v, period[a])
            v, w, o = np.concatenate([v - period[a], v, v + period[a]]), np.tile(w, 3), np.tile(o, 3)
        order = np.argsort(v, kind="stable")
        w = w[order]
        per_key[a] = (v[order], w, o[order], np.median(w) if len(w) else 0.0)
    return AnswerKeys(everyone, col, names, trial_of, per_key, period)


_STUDENT, _KEY, _VALUE, _TOLERANCE = (attrgetter(f) for f in ("student_id", "key", "value", "tolerance"))
_KEYS, _VALUES, _CORRECTS = attrgetter("keys"), attrgetter("values"), attrgetter("correct")  # of `ResultColumns`


def find_copies(
    grades: Sequence[StudentGrade],
    keys: Sequence[KeyEntry],
    *,
    alpha: float = 1e-3,
    min_matches: int = 2,
    min_shared: int = 3,
    correlated: float = 0.7,
    dense: float = 0.02,
) -> list[IntegrityFlag]:
    """Flag submissions copied from a classmate: their key matched, or wrong answers shared.

    See the module docstring for the chance model. A student is flagged only when the chance of
    the agreement between independent students, corrected for every classmate compared, is below
    *alpha*.

    Args:
        grades: the graded students (those without a submission are skipped).
        keys: every student's key entries (students without a submission are still classmates
            whose key can be copied).
        alpha: the largest corrected chance that is flagged.
        min_matches: at least this many answers in a classmate's bands.
        min_shared: at least this many identical wrong answers.
        correlated: answers of one problem whose keys are rank-correlated at least this much
            across the class count as one trial.
        dense: an answer that a random classmate's band holds with a larger chance than this
            is left out of the band look (too common to be evidence; it costs the most to
            index), and kept in the sharper look at the digits given.

    Returns:
        Key matches (one per flagged student, naming the classmate) then shared wrong answers
        (one per pair), each with its corrected chance.
    """
    subs = [g for g in grades if g.submission is not None]
    if not subs or not keys:
        return []
    ck = answer_keys(keys, correlated)
    everyone, col, names, trial_of, per_key, period = ck.everyone, ck.col, ck.names, ck.trial_of, ck.per_key, ck.period
    extra = [g.student.student_id for g in subs if g.student.student_id not in col]
    if extra:  # students with a submission but no key (still classmates of no one's key)
        everyone, col = list(everyone), dict(col)
        for sid in extra:
            if sid not in col:
                col[sid] = len(everyone)
                everyone.append(sid)
    n_all, n_sub = len(everyone), len(subs)
    classmates = max(n_all - 1, 1)
    aid = {name: i for i, name in enumerate(names)}
    sub_col = np.array([col[g.student.student_id] for g in subs])
    n_trials = max(trial_of.values()) + 1
    # per answer key: the submitted values (student row, value, wrong for them), keys in the order first answered
    # every result as columns (student row, answer, value, wrong for them), then those with a finite value
    # of an answer of the keys
    columns = [g.columns() for g in subs]
    keys_of = list(map(_KEYS, columns))
    lengths = list(map(len, keys_of))
    n = sum(lengths)
    g_row = np.repeat(np.arange(n_sub), lengths)
    g_key = np.fromiter(map(aid.get, chain.from_iterable(keys_of), repeat(-1)), np.int64, n)
    g_x = np.array(list(chain.from_iterable(map(_VALUES, columns))), dtype=float)  # None (no value) as NaN
    g_wrong = ~np.fromiter(chain.from_iterable(map(_CORRECTS, columns)), bool, n)
    own = np.bincount(g_row[~g_wrong], minlength=n_sub).tolist()  # each one's right answers
    given = np.isfinite(g_x) & (g_key >= 0)
    g_row, g_key, g_x, g_wrong = g_row[given], g_key[given], g_x[given], g_wrong[given]
    answered: dict[int, tuple[np.ndarray, np.ndarray, np.ndarray]] = {}
    if len(g_x):
        order = np.argsort(g_key, kind="stable")
        bounds = np.flatnonzero(np.diff(g_key[order])) + 1
        groups = np.split(order, bounds) if len(order) else []
        for idx in sorted(groups, key=lambda idx: idx[0]):
            answered[int(g_key[idx[0]])] = (g_row[idx], g_x[idx], g_wrong[idx])
    p_band = np.zeros((n_sub, n_trials))
    p_exact = np.zeros((n_sub, n_trials))
    p_share = np.zeros((n_sub, n_trials))
    band_hits: list[tuple[np.ndarray, np.ndarray]] = []
    exact_hits: list[tuple[np.ndarray, np.ndarray]] = []
    share_hits: list[tuple[np.ndarray, np.ndarray]] = []
    for a, (rows_l, xs_l, wrong_l) in answered.items():
        t = trial_of[names[a]]
        rows, xs = rows_l[wrong_l], xs_l[wrong_l]
        if not len(rows) or a not in per_key:
            continue
        v, w, o, typical = per_key[a]
        xs_key = np.mod(xs, period[a]) if period[a] else xs
        sig, radius = _digits_radius(xs, 6)
        # the chance that a random classmate's band holds x (larger one-sided density × band)
        weight, h = _density(v, w, xs_key, 3 * np.maximum(typical, radius), 10)
        pb = np.minimum(1.0, 2 * weight / (h * classmates))
        count, _ = _density(v, np.ones_like(w), xs_key, h, 1)
        pe = np.minimum(pb, 2 * count * 2 * radius / (2 * h * classmates))
        crowded = pb > dense  # too common to be evidence in a band: only the sharper look uses it
        np.add.at(p_band, (rows, t), np.where(crowded, 0.0, pb))
        np.add.at(p_exact, (rows, t), pe)
        # every classmate whose band holds x
        reach = np.where(crowded, np.minimum(radius, w.max()), w.max()) if len(w) else np.zeros(len(xs))
        lo = np.searchsorted(v, xs_key - reach, "left")
        hi = np.searchsorted(v, xs_key + reach, "right")
        sizes = hi - lo
        if sizes.sum():
            which = np.repeat(np.arange(len(xs)), sizes)
            idx = np.arange(sizes.sum()) - np.repeat(np.cumsum(sizes) - sizes, sizes) + np.repeat(lo, sizes)
            gap = np.abs(v[idx] - xs_key[which])
            other = o[idx]
            keep = (gap <= w[idx] * (1 + 1e-12)) & (other != sub_col[rows[which]])
            sel = which[keep]
            code = ((rows[sel].astype(np.int64) * n_all + other[keep]) * n_trials) + t
            ex = gap[keep] <= radius[sel]
            exact_hits.append((code[ex], np.full(int(ex.sum()), a, np.int32)))
            inband = ~crowded[sel]
            band_hits.append((code[inband], np.full(int(inband.sum()), a, np.int32)))
        # identical wrong answers: hash of the value rounded to 4 significant figures
        digits = np.minimum(sig, 4)
        ax = np.abs(xs)
        with np.errstate(divide="ignore"):
            e = np.floor(np.log10(np.where(ax > 0, ax, 1.0)))
        mant = np.round(xs / 10.0 ** (e - 3)).astype(np.int64)
        bins: dict[tuple[int, int], list[int]] = {}
        for i, key in enumerate(zip(mant.tolist(), e.astype(int).tolist(), strict=True)):
            bins.setdefault(key, []).append(i)
        srt = np.sort(xs)
        width = 10.0 ** (e - digits + 1)
        dens, hw = _density(srt, np.ones_like(srt), xs, 3 * width, 10)
        popular = np.zeros(len(xs))
        pairs_s, pairs_j = [], []
        for members in bins.values():
            c = len(members)
            if c < 2:
                continue
            popular[members] = (c - 2) / max(n_all - 2, 1)
            if c <= 30:
                for i in members:
                    for j in members:
                        if i != j:
                            pairs_s.append(i)
                            pairs_j.append(j)
        ps = np.maximum(2 * dens * width / (2 * hw * classmates), popular)
        np.add.at(p_share, (rows, t), np.minimum(ps, 1.0))
        if pairs_s:
            si, sj = np.array(pairs_s), np.array(pairs_j)
            code = ((rows[si].astype(np.int64) * n_all + sub_col[rows[sj]]) * n_trials) + t
            share_hits.append((code, np.full(len(si), a, np.int32)))

    flags: list[IntegrityFlag] = []
    looks = []
    for hits, probs in ((band_hits, p_band), (exact_hits, p_exact)):
        count, other, answers = _best_pairs(hits, n_sub, n_all, n_trials)
        tails = poisson_binomial_tails(np.minimum(probs, 1.0))
        p = corrected(tails[np.arange(n_sub), count], classmates) * 2  # two looks
        looks.append((count, other, answers, p))
    (cb, ob, ab, pvb), (ce, oe, ae, pve) = looks
    for i, g in enumerate(subs):
        use_exact = pve[i] < pvb[i]
        c, o, ans, p = (ce[i], oe[i], ae, pve[i]) if use_exact else (cb[i], ob[i], ab, pvb[i])
        if o < 0 or p >= alpha:
            continue
        matched = tuple(dict.fromkeys(names[a] for a in ans.get(i, [])))
        if len(matched) < min_matches:
            continue
        flags.append(
            IntegrityFlag(
                g.student.student_id, everyone[o], g.submission.path, own[i], len(matched), matched, float(min(p, 1.0))
            )
        )

    count, other, answers = _best_pairs(share_hits, n_sub, n_all, n_trials)
    p = corrected(poisson_binomial_tails(np.minimum(p_share, 1.0))[np.arange(n_sub), count], classmates)
    row_of = {c: i for i, c in enumerate(sub_col.tolist())}
    seen: set[frozenset[str]] = set()
    for i, g in enumerate(subs):
        if other[i] < 0 or p[i] >= alpha:
            continue
        shared = tuple(dict.fromkeys(names[a] for a in answers.get(i, [])))
        partner = everyone[other[i]]
        pair = frozenset((g.student.student_id, partner))
        if len(shared) < min_shared or pair in seen:
            continue
        seen.add(pair)
        twin = subs[row_of[other[i]]].submission
        flags.append(
            IntegrityFlag(
                g.student.student_id,
                partner,
                g.submission.path,
                own[i],
                len(shared),
                shared,
                float(min(p[i], 1.0)),
                SHARED_WRONG,
                twin.path if twin else "",
            )
        )
    return flags
