"""The worked key's route checks itself: every printed equation is parsed back from the markup the
key template prints (the context dict of `build_context`) and must hold with the printed numbers,
within their printed rounding. No expected value is taken from today's output of the code.
"""

from __future__ import annotations

import functools
import re
from pathlib import Path

import pytest
from quick import bank_params

import gradekit
from gradekit.bank.registry import load_bank
from gradekit.documents.context import case_context

ROOT = Path(__file__).resolve().parents[1]
BANK = sorted(load_bank(ROOT / "problem_bank"))
NUMBER = r"−?\d+(?:\.\d+)?"


def _f(s: str) -> float:
    return float(s.replace("−", "-"))


def _half_ulp(s: str, sig: int = 5) -> float:
    """Half a unit in the last printed place of *s* (printed with at most *sig* significant figures)."""
    s = s.replace("−", "").strip()
    if "." in s:
        return 0.5 * 10.0 ** -len(s.split(".")[1])
    digits = len(s.lstrip("0")) or 1
    return 0.5 * 10.0 ** max(0, digits - sig)


def _cases(pid: str, seeds=(None, 7)):
    for seed in seeds:
        yield from _worked(pid, seed)


@functools.cache
def _worked(pid: str, seed: int | None) -> tuple:
    """A variant's cases with their worked steps, made once for all the tests of this module (the steps
    draw the key's figures: most of the module's time)."""
    v = gradekit.sample(pid) if seed is None else gradekit.sample(pid, seed=seed)
    res = gradekit.solve(v)
    return tuple((res, case, case_context(res, case)["steps"]) for case in res.cases)


def _math(t) -> str:
    s = str(t)
    return s[s.index("$") + 1: s.rindex("$")]


def _terms(line: str) -> list[str]:
    """The signed numbers of a ``a + b − c = 0`` line."""
    lhs, rhs = _math(line).rsplit("=", 1)
    assert rhs.strip() == "0", line
    toks = re.findall(r"([+−]?)\s*(\d+(?:\.\d+)?)", lhs)
    return [("−" if sign == "−" else "") + v for sign, v in toks]


@pytest.mark.parametrize("pid", bank_params(BANK))
def test_each_equilibrium_equation_adds_up_to_zero(pid):
    for _res, case, st in _cases(pid):
        assert st["equilibrium"], pid
        for link in st["equilibrium"]:
            assert len(link["lines"]) == 3
            for line in link["lines"]:
                terms = _terms(line["solved"])
                total = sum(_f(t) for t in terms)
                slack = sum(_half_ulp(t) for t in terms) + 1e-12
                assert abs(total) <= slack, (pid, case.name, link["body"], str(line["solved"]), total, slack)
                # the symbolic line names an unknown for every unknown term of the numbers line
                assert str(line["symbolic"]).count("=") == 2
                assert len(terms) >= 1


def _matrix(st):
    mx = st["matrix"]
    A = [[_f(str(c)) for c in r["cells"]] for r in mx["rows"]]
    Au = [[_half_ulp(str(c), 4) for c in r["cells"]] for r in mx["rows"]]
    b = [_f(str(r["b"])) for r in mx["rows"]]
    bu = [_half_ulp(str(r["b"])) for r in mx["rows"]]
    x = [_f(str(v["value"])) for v in mx["x"]]
    xu = [_half_ulp(str(v["value"])) for v in mx["x"]]
    return A, Au, b, bu, x, xu


@pytest.mark.parametrize("pid", bank_params(p for p in BANK if gradekit.load_problem(p).method == "analytical"))
def test_printed_matrix_times_printed_solution_is_printed_rhs(pid):
    for _res, _c, st in _cases(pid):
        assert st["matrix"] is not None
        A, Au, b, bu, x, xu = _matrix(st)
        assert len(A) == len(b) and all(len(r) == len(x) for r in A)
        for i, row in enumerate(A):
            lhs = sum(a * v for a, v in zip(row, x, strict=True))
            slack = sum(abs(du) * abs(v) + abs(a) * dx + du * dx
                        for a, du, v, dx in zip(row, Au[i], x, xu, strict=True)) + bu[i] + 1e-12
            assert abs(lhs - b[i]) <= slack, (pid, i, lhs, b[i], slack)


def _vector_terms(side: str, values: dict[str, float]) -> tuple[float, float]:
    """Sum of the ``(x, y)`` and ``sym (x, y)`` terms of one side of a printed vector equation."""
    x = y = 0.0
    for term in side.split(" + "):
        sym, a, b = re.fullmatch(rf"(.*?)\s*\(({NUMBER}), ({NUMBER})\)", term.strip()).groups()
        k = 1.0
        sym = sym.strip()
        if sym:
            assert sym in values, (sym, values)
            k = values[sym]
        x += k * _f(a)
        y += k * _f(b)
    return x, y


def _solved(line: str) -> dict[str, float]:
    body = _math(line).replace("arrow.double.r", "")
    out = {}
    for part in body.split(","):
        if "=" in part:
            sym, val = part.split("=")
            sym = sym.replace("#h(0.6em)", "").strip()
            out[sym] = _f(re.search(NUMBER, val).group(0))
    return out


@pytest.mark.parametrize("pid", bank_params(p for p in BANK if gradekit.load_problem(p).analysis == "dynamic"))
def test_velocity_and_acceleration_equations_hold_with_the_printed_solution(pid):
    for _res, _c, st in _cases(pid, seeds=(None,)):
        k = st["kinematics"]
        assert k["centres"], pid  # every mass centre's acceleration, with its terms
        if not k["closure"]:  # a single driven link: no loop to close
            continue
        assert k["velocity"] and k["acceleration"], pid
        for lines in (k["velocity"], k["acceleration"]):
            # per loop: symbolic line, numbers line, solved line (⇒ ...)
            for i in range(0, len(lines), 3):
                numbers, solved = str(lines[i + 1]), _solved(str(lines[i + 2]))
                lhs, rhs = _math(numbers).split("=")
                lx, ly = _vector_terms(lhs, solved)
                rx, ry = _vector_terms(rhs, solved)
                size = max(abs(lx), abs(ly), abs(rx), abs(ry), 1e-300)
                assert abs(lx - rx) <= 2e-3 * size and abs(ly - ry) <= 2e-3 * size, (pid, numbers, solved)


@pytest.mark.parametrize("pid", bank_params(BANK))
def test_only_what_the_problem_needs(pid):
    p = gradekit.load_problem(pid)
    for _res, _c, st in _cases(pid, seeds=(None,)):
        assert bool(st["inertia"]) == (p.analysis == "dynamic")
        assert (st["matrix"] is not None) == (p.method == "analytical")
        assert bool(st["construction"]) == (p.method == "graphical")
        asks_motion = any(a.of.startswith(("omega[", "alpha[", "v[", "a[", "aG[", "vG[")) for a in p.answers)
        assert bool(st["kinematics"]["velocity"]) == (p.analysis == "dynamic" or asks_motion) or not \
            st["kinematics"]["closure"]


def _superposed(pid: str) -> bool:
    return len(gradekit.solve(gradekit.sample(pid)).cases[0].solution.groups) > 1


@pytest.mark.parametrize("pid", bank_params(p for p in BANK if _superposed(p)))
def test_superposition_parts_add_up_to_the_total(pid):
    for _res, _c, st in _cases(pid):
        line = _math(st["superposition"][1])
        *parts, total = line.split("=")[1:]
        terms = re.findall(r"([+−]?)\s*(\d+(?:\.\d+)?)", parts[0])
        vals = [("−" if s == "−" else "") + v for s, v in terms]
        slack = sum(_half_ulp(v) for v in vals) + _half_ulp(total.strip())
        assert abs(sum(_f(v) for v in vals) - _f(total.strip())) <= slack, line


def test_names_are_the_problems_own():
    """ch5-ex5-3 calls its pivots O1, O3 and its links 1, 2, 3: the route prints those, never O2/O4."""
    for _res, _c, st in _cases("ch5-ex5-3", seeds=(None,)):
        text = " ".join(str(x) for x in st["kinematics"]["closure"])
        text += " ".join(str(ln["symbolic"]) for lk in st["equilibrium"] for ln in lk["lines"])
        text += st["kinematics"]["branch"]
        assert '"O1B"' in text and '"O3C"' in text
        assert "O2" not in text and "O4" not in text
        assert [lk["body"] for lk in st["equilibrium"]] == ["1", "2", "3"]
