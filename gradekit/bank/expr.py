"""A safe arithmetic evaluator for derived parameters and constraints (never `eval`), batched.

Expressions are parsed with `ast` and only numbers, parameter names, arithmetic, comparisons,
``and``/``or``/``not``, conditional expressions and a fixed set of math functions are allowed. One
evaluator runs an expression over arrays with one entry per variant (`evaluate_rows`); `evaluate`
is its batch of one.
"""

from __future__ import annotations

import ast
import math
from collections.abc import Callable, Mapping
from functools import lru_cache
from typing import NamedTuple

import numpy as np


class ExprError(ValueError):
    """An expression that is not allowed or cannot be evaluated."""


MAX_LENGTH = 500  # characters: the longest bank expression is under 100
MAX_DEPTH = 40  # nesting of operators, calls and parentheses
MAX_EXPONENT = 1000.0  # |b| in a**b: physics never needs more, and larger towers are refused unevaluated

Checks = list[tuple[np.ndarray, Callable[[int], str]]]


def _math_errors(overflow: str = "math domain error"):
    """The rows where a function of Python's `math` would raise (its own rule): a NaN from arguments
    that are not NaN has no value ("math domain error"), nor an infinity from finite ones (*overflow*)."""

    def check(args: list[np.ndarray], value: np.ndarray) -> Checks:
        some_nan = np.logical_or.reduce([np.isnan(a) for a in args])
        finite = np.logical_and.reduce([np.isfinite(a) for a in args])
        return [
            (np.isnan(value) & ~some_nan, lambda _i: "math domain error"),
            (np.isinf(value) & finite, lambda _i: overflow),
        ]

    return check


def _round_errors(args: list[np.ndarray], value: np.ndarray) -> Checks:
    """`round` gives a whole number, which neither a NaN nor an infinity has."""
    return [
        (np.isnan(args[0]), lambda _i: "cannot convert float NaN to integer"),
        (np.isinf(args[0]), lambda _i: "cannot convert float infinity to integer"),
    ]


def _least(*xs: np.ndarray) -> np.ndarray:
    """Python's `min`: the first argument unless a later one is smaller (so NaN and -0.0 as Python has them)."""
    out = xs[0]
    for x in xs[1:]:
        out = np.where(x < out, x, out)
    return out


def _greatest(*xs: np.ndarray) -> np.ndarray:
    """Python's `max`: the first argument unless a later one is larger."""
    out = xs[0]
    for x in xs[1:]:
        out = np.where(x > out, x, out)
    return out


def _hypot(*xs: np.ndarray) -> np.ndarray:
    # Python's hypot is its own algorithm, not the C library's that numpy calls (the two differ
    # in the last bit for about 1 in 200 pairs); derived values were Python's before the batch.
    return np.frompyfunc(math.hypot, len(xs), 1)(*xs).astype(float)


class Function(NamedTuple):
    """One function of the language: how many arguments (``None``: two or more), its values over
    arrays, and the rows where it has none (argument arrays, value) → [(rows, message)]."""

    arity: int | None
    apply: Callable[..., np.ndarray]
    errors: Callable[[list[np.ndarray], np.ndarray], Checks] | None = None


_MATH = _math_errors()
FUNCTIONS: dict[str, Function] = {
    "sqrt": Function(1, np.sqrt, _MATH),
    "sin": Function(1, np.sin, _MATH),
    "cos": Function(1, np.cos, _MATH),
    "tan": Function(1, np.tan, _MATH),
    "asin": Function(1, np.arcsin, _MATH),
    "acos": Function(1, np.arccos, _MATH),
    "atan": Function(1, np.arctan, _MATH),
    "atan2": Function(2, np.arctan2, _MATH),
    "sind": Function(1, lambda d: np.sin(np.radians(d)), _MATH),
    "cosd": Function(1, lambda d: np.cos(np.radians(d)), _MATH),
    "tand": Function(1, lambda d: np.tan(np.radians(d)), _MATH),
    "asind": Function(1, lambda x: np.degrees(np.arcsin(x)), _MATH),
    "acosd": Function(1, lambda x: np.degrees(np.arccos(x)), _MATH),
    "atan2d": Function(2, lambda y, x: np.degrees(np.arctan2(y, x)), _MATH),
    "radians": Function(1, np.radians),
    "degrees": Function(1, np.degrees),
    "abs": Function(1, np.abs),
    "min": Function(None, _least),
    "max": Function(None, _greatest),
    "hypot": Function(None, _hypot),
    # half to even, as Python's round; + 0.0 turns rint's -0.0 into the 0 a whole number has
    "round": Function(1, lambda x: np.rint(x) + 0.0, _round_errors),
    "log10": Function(1, np.log10, _MATH),
    "exp": Function(1, np.exp, _math_errors("math range error")),
}
CONSTANTS = {"pi": math.pi}

_ARITHMETIC = (ast.Add, ast.Sub, ast.Mult, ast.Div, ast.Pow, ast.Mod)
_CMP = {
    ast.Lt: np.less,
    ast.LtE: np.less_equal,
    ast.Gt: np.greater,
    ast.GtE: np.greater_equal,
    ast.Eq: np.equal,
    ast.NotEq: np.not_equal,
}


def _shown(text: str) -> str:
    return repr(text) if len(text) <= 60 else repr(text[:57] + "...")


def _depth(node: ast.AST) -> int:
    """How deeply *node* nests (iteratively, so a hostile tree cannot exhaust the stack)."""
    deepest, stack = 0, [(node, 1)]
    while stack:
        n, d = stack.pop()
        deepest = max(deepest, d)
        if deepest > MAX_DEPTH:
            break
        stack.extend((child, d + 1) for child in ast.iter_child_nodes(n))
    return deepest


def _constant(node: ast.AST, text: str) -> float | None:
    """The value of a sub-expression made of numbers and arithmetic only (else None, or None when it
    has no value)."""
    for n in ast.walk(node):
        if isinstance(n, ast.Constant):
            if not isinstance(n.value, (int, float)) or isinstance(n.value, bool):
                return None
        elif isinstance(n, ast.UnaryOp):
            if not isinstance(n.op, (ast.USub, ast.UAdd)):
                return None
        elif isinstance(n, ast.BinOp):
            if not isinstance(n.op, _ARITHMETIC):
                return None
        elif not isinstance(n, (ast.operator, ast.unaryop)):
            return None
    rows = _Batch(text, {}, ()).run(node)
    return None if rows.undefined.any() else float(rows.value)


def _check_power(node: ast.BinOp, text: str) -> None:
    exponent = node.right
    while isinstance(exponent, ast.UnaryOp) and isinstance(exponent.op, (ast.USub, ast.UAdd)):
        exponent = exponent.operand
    if isinstance(exponent, ast.BinOp) and isinstance(exponent.op, ast.Pow):
        inner = _constant(exponent, text)
        if inner is None or abs(inner) > MAX_EXPONENT:
            raise ExprError(f"expected exponents of at most {MAX_EXPONENT:g}, got a power tower in {_shown(text)}")
    value = _constant(node.right, text)
    if value is not None and abs(value) > MAX_EXPONENT:
        raise ExprError(f"expected exponents of at most {MAX_EXPONENT:g}, got {value:g} in {_shown(text)}")


def _arguments(arity: int | None) -> str:
    return "two or more arguments" if arity is None else "1 argument" if arity == 1 else f"{arity} arguments"


@lru_cache(maxsize=2048)
def parse(text: str) -> ast.Expression:
    """Parse and check *text*; raise `ExprError` for anything outside the allowed grammar.

    Refused before anything is evaluated: text over `MAX_LENGTH` characters, nesting deeper than
    `MAX_DEPTH`, powers whose exponent is a constant over `MAX_EXPONENT` or a power tower
    (``9**9**9**9``), and a function given the wrong number of arguments.
    """
    if len(text) > MAX_LENGTH:
        raise ExprError(f"expected an expression of at most {MAX_LENGTH} characters, got {len(text):,}")
    try:
        tree = ast.parse(text, mode="eval")
    except SyntaxError as exc:
        raise ExprError(f"expected an arithmetic expression, got {_shown(text)} ({exc.msg})") from None
    except (RecursionError, MemoryError):
        raise ExprError(f"expected an expression nested at most {MAX_DEPTH} deep, got {_shown(text)}") from None
    if _depth(tree) > MAX_DEPTH:
        raise ExprError(f"expected an expression nested at most {MAX_DEPTH} deep, got {_shown(text)}")
    for node in ast.walk(tree):
        ok = isinstance(
            node,
            (
                ast.Expression,
                ast.Constant,
                ast.Name,
                ast.BinOp,
                ast.UnaryOp,
                ast.Compare,
                ast.BoolOp,
                ast.IfExp,
                ast.Call,
                ast.Load,
                *_ARITHMETIC,
                ast.USub,
                ast.UAdd,
                ast.Not,
                ast.cmpop,
                ast.boolop,
            ),
        )
        if isinstance(node, ast.Constant) and not isinstance(node.value, (int, float)):
            ok = False
        if isinstance(node, ast.Call) and not (
            isinstance(node.func, ast.Name) and node.func.id in FUNCTIONS and not node.keywords
        ):
            ok = False
        if not ok:
            raise ExprError(
                f"expected numbers, names, arithmetic and {', '.join(sorted(FUNCTIONS))}; "
                f"got {ast.unparse(node) if hasattr(node, 'lineno') else _operator(node)} "
                f"in {_shown(text)}"
            )
        if isinstance(node, ast.Call):
            arity = FUNCTIONS[node.func.id].arity
            given = len(node.args)
            if (given != arity) if arity is not None else given < 2:
                raise ExprError(
                    f"expected {node.func.id} with {_arguments(arity)}, got {given} in {_shown(text)}"
                )
        if isinstance(node, ast.BinOp) and isinstance(node.op, ast.Pow):
            _check_power(node, text)
    return tree


def _operator(node: ast.AST) -> str:
    symbols = {ast.FloorDiv: "//", ast.MatMult: "@", ast.LShift: "<<", ast.RShift: ">>", ast.BitOr: "|",
               ast.BitXor: "^", ast.BitAnd: "&", ast.Invert: "~"}
    return symbols.get(type(node), type(node).__name__)


def names(text: str) -> set[str]:
    """Parameter names an expression refers to (functions and constants excluded)."""
    tree = parse(text)
    called = {n.func.id for n in ast.walk(tree) if isinstance(n, ast.Call)}
    return {n.id for n in ast.walk(tree) if isinstance(n, ast.Name)} - called - set(CONSTANTS)


class Rows(NamedTuple):
    """An expression's values over a batch of variants.

    ``value`` has one entry per row (the broadcast shape of the values it reads): a number, or a
    truth value for a condition. A row has no value where Python's arithmetic or `math` would
    raise for it (a square root of a negative, a division by zero, an overflow, an exponent over
    `MAX_EXPONENT`); there ``undefined`` holds, ``value`` is NaN (False for a condition) and
    `reason` says why, as `evaluate` reports it.
    """

    value: np.ndarray
    undefined: np.ndarray
    checks: tuple[tuple[np.ndarray, Callable[[int], str]], ...]  # (rows, message); a row's first is its reason

    def reason(self, i: int = 0) -> str:
        """Why row *i* (of the flattened batch) has no value ("" when it has one)."""
        for rows, message in self.checks:
            if rows.reshape(-1)[i]:
                return message(i)
        return ""


def evaluate_rows(text: str, env: Mapping) -> Rows:
    """Evaluate *text* over arrays of parameter values (one entry per variant; floats are shared).

    Raises:
        ExprError: the expression is not allowed, or names a parameter *env* does not give.
    """
    tree = parse(text)
    used = [env[n.id] for n in ast.walk(tree) if isinstance(n, ast.Name) and n.id in env]
    shape = np.broadcast_shapes(*(np.shape(v) for v in used)) if used else ()
    return _Batch(text, env, shape).run(tree.body)


def evaluate_many(text: str, env: Mapping) -> np.ndarray:
    """`evaluate_rows`' values: NaN (False for a condition) where a row has no real value."""
    return evaluate_rows(text, env).value


def evaluate(text: str, env: Mapping[str, float]) -> float | bool:
    """Evaluate *text* for one variant: `evaluate_rows` on a batch of one.

    Raises:
        ExprError: the expression is not allowed or has no value at *env* (``cannot evaluate …``).
    """
    rows = evaluate_rows(text, {k: np.reshape(np.asarray(v, float), (1,)) for k, v in env.items()})
    if rows.undefined.reshape(-1)[0]:
        raise ExprError(rows.reason(0))
    value = rows.value.reshape(-1)[0]
    return bool(value) if value.dtype == bool else float(value)


def truth(value):
    """Elementwise truth of an `evaluate_many` result: a NaN (no real value) is False."""
    v = np.asarray(value)
    return (v != 0) & ~np.isnan(v) if v.dtype.kind == "f" else v.astype(bool)


def _number(v: np.ndarray) -> np.ndarray:
    return v if v.dtype == float else v.astype(float)


class _Batch:
    """One evaluation over a batch of *shape*.

    Every operand is a full float64 (or bool) array with one entry per row, never a shared scalar:
    numpy takes other loops for a scalar operand (``x ** 2`` with a scalar 2 is ``x * x``, which is
    not libm's ``pow`` bit for bit), and one row must give what many give. A row's operations are
    checked as Python checks them: only the branch of a conditional it takes, and the comparisons of
    a chain up to the first false one, can make it undefined.
    """

    def __init__(self, text: str, env: Mapping, shape: tuple[int, ...]) -> None:
        self.text, self.env, self.shape = text, env, shape
        self.n = math.prod(shape) if shape else 1
        self.checks: Checks = []

    def run(self, node: ast.AST) -> Rows:
        with np.errstate(all="ignore"):
            value = self.ev(node, np.ones(self.n, bool))
        undefined = np.logical_or.reduce([rows for rows, _ in self.checks]) if self.checks else np.zeros(self.n, bool)
        if undefined.any():
            value = np.where(undefined, False if value.dtype == bool else np.nan, value)
        shape = self.shape
        return Rows(value.reshape(shape), undefined.reshape(shape), tuple(self.checks))

    def full(self, v) -> np.ndarray:
        return np.array(np.broadcast_to(np.asarray(v, float), self.shape), dtype=float).reshape(self.n)

    def check(self, live: np.ndarray, found: Checks) -> None:
        for rows, message in found:
            rows = rows & live
            if rows.any():
                self.checks.append((rows, lambda i, m=message: f"cannot evaluate {_shown(self.text)}: {m(i)}"))

    def ev(self, node: ast.AST, live: np.ndarray) -> np.ndarray:
        if isinstance(node, ast.Constant):
            return np.full(self.n, float(node.value))
        if isinstance(node, ast.Name):
            if node.id in self.env:
                return self.full(self.env[node.id])
            if node.id in CONSTANTS:
                return np.full(self.n, CONSTANTS[node.id])
            raise ExprError(f"unknown name {node.id!r} in {_shown(self.text)}")
        if isinstance(node, ast.BinOp):
            a = _number(self.ev(node.left, live))
            b = _number(self.ev(node.right, live))
            return self.arithmetic(node.op, a, b, live)
        if isinstance(node, ast.UnaryOp):
            v = self.ev(node.operand, live)
            if isinstance(node.op, ast.Not):
                return ~truth(v)
            return -_number(v) if isinstance(node.op, ast.USub) else _number(v)
        if isinstance(node, ast.Compare):
            left, out = self.ev(node.left, live), np.ones(self.n, bool)
            for op, comp in zip(node.ops, node.comparators, strict=True):
                right = self.ev(comp, live & out)  # Python stops a chain at its first false comparison
                out = out & _CMP[type(op)](left, right)
                left = right
            return out
        if isinstance(node, ast.BoolOp):
            vals = [truth(self.ev(v, live)) for v in node.values]  # every operand, as `evaluate` always did
            return np.logical_and.reduce(vals) if isinstance(node.op, ast.And) else np.logical_or.reduce(vals)
        if isinstance(node, ast.IfExp):
            test = truth(self.ev(node.test, live))
            return np.where(test, self.ev(node.body, live & test), self.ev(node.orelse, live & ~test))
        if isinstance(node, ast.Call):
            fn = FUNCTIONS[node.func.id]
            args = [_number(self.ev(a, live)) for a in node.args]
            value = fn.apply(*args)
            if fn.errors:
                self.check(live, fn.errors(args, value))
            return value
        raise ExprError(f"not allowed in {_shown(self.text)}")  # parse refuses everything else

    def arithmetic(self, op: ast.operator, a: np.ndarray, b: np.ndarray, live: np.ndarray) -> np.ndarray:
        """One arithmetic operation, with the rows where Python's float arithmetic raises."""
        if isinstance(op, ast.Add):
            return a + b
        if isinstance(op, ast.Sub):
            return a - b
        if isinstance(op, ast.Mult):
            return a * b
        if isinstance(op, ast.Div):
            self.check(live, [(b == 0, lambda _i: "float division by zero")])
            return a / b
        if isinstance(op, ast.Mod):
            self.check(live, [(b == 0, lambda _i: "float modulo")])
            return np.remainder(a, b)
        value = np.power(a, b)
        too_big = np.abs(b) > MAX_EXPONENT
        fine = ~too_big & (b != 0) & ~np.isnan(a) & ~np.isnan(b)
        finite = np.isfinite(a) & np.isfinite(b)
        zero_negative = fine & (a == 0) & (b < 0)
        self.check(
            live,
            [
                (too_big, lambda i: f"expected exponents of at most {MAX_EXPONENT:g}, got {b[i]:g}"),
                (zero_negative, lambda _i: "0.0 cannot be raised to a negative power"),
                (fine & finite & (a < 0) & (b != np.floor(b)), lambda _i: "the result is not a real number"),
                (fine & finite & ~zero_negative & np.isinf(value), lambda _i: "(34, 'Numerical result out of range')"),
            ],
        )
        return value
