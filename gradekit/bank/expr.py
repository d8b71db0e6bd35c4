"""A safe arithmetic evaluator for derived parameters and constraints (never `eval`).

Expressions are parsed with `ast` and only numbers, parameter names, arithmetic, comparisons,
``and``/``or``/``not``, conditional expressions and a fixed set of math functions are allowed.
"""

from __future__ import annotations

import ast
import math
import operator
from collections.abc import Mapping
from functools import lru_cache

FUNCTIONS = {
    "sqrt": math.sqrt,
    "sin": math.sin,
    "cos": math.cos,
    "tan": math.tan,
    "asin": math.asin,
    "acos": math.acos,
    "atan": math.atan,
    "atan2": math.atan2,
    "sind": lambda d: math.sin(math.radians(d)),
    "cosd": lambda d: math.cos(math.radians(d)),
    "tand": lambda d: math.tan(math.radians(d)),
    "asind": lambda x: math.degrees(math.asin(x)),
    "acosd": lambda x: math.degrees(math.acos(x)),
    "atan2d": lambda y, x: math.degrees(math.atan2(y, x)),
    "radians": math.radians,
    "degrees": math.degrees,
    "abs": abs,
    "min": min,
    "max": max,
    "hypot": math.hypot,
    "round": round,
    "log10": math.log10,
    "exp": math.exp,
}
CONSTANTS = {"pi": math.pi}

_BIN = {
    ast.Add: operator.add,
    ast.Sub: operator.sub,
    ast.Mult: operator.mul,
    ast.Div: operator.truediv,
    ast.Pow: operator.pow,
    ast.Mod: operator.mod,
}
_CMP = {
    ast.Lt: operator.lt,
    ast.LtE: operator.le,
    ast.Gt: operator.gt,
    ast.GtE: operator.ge,
    ast.Eq: operator.eq,
    ast.NotEq: operator.ne,
}


class ExprError(ValueError):
    """An expression that is not allowed or cannot be evaluated."""


MAX_LENGTH = 500  # characters: the longest bank expression is under 100
MAX_DEPTH = 40  # nesting of operators, calls and parentheses
MAX_EXPONENT = 1000.0  # |b| in a**b: physics never needs more, and larger towers are refused unevaluated


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


def _constant(node: ast.AST) -> float | None:
    """The value of a sub-expression made of numbers and arithmetic only (else None)."""
    if isinstance(node, ast.Constant) and isinstance(node.value, (int, float)) and not isinstance(node.value, bool):
        return float(node.value)
    if isinstance(node, ast.UnaryOp) and isinstance(node.op, (ast.USub, ast.UAdd)):
        v = _constant(node.operand)
        return None if v is None else (-v if isinstance(node.op, ast.USub) else v)
    if isinstance(node, ast.BinOp) and type(node.op) in _BIN:
        a, b = _constant(node.left), _constant(node.right)
        if a is None or b is None:
            return None
        try:
            return float(_arith(node.op, a, b))
        except (ZeroDivisionError, OverflowError, ValueError, ExprError):
            return None
    return None


def _check_power(node: ast.BinOp, text: str) -> None:
    exponent = node.right
    while isinstance(exponent, ast.UnaryOp) and isinstance(exponent.op, (ast.USub, ast.UAdd)):
        exponent = exponent.operand
    if isinstance(exponent, ast.BinOp) and isinstance(exponent.op, ast.Pow):
        inner = _constant(exponent)
        if inner is None or abs(inner) > MAX_EXPONENT:
            raise ExprError(f"expected exponents of at most {MAX_EXPONENT:g}, got a power tower in {_shown(text)}")
    value = _constant(node.right)
    if value is not None and abs(value) > MAX_EXPONENT:
        raise ExprError(f"expected exponents of at most {MAX_EXPONENT:g}, got {value:g} in {_shown(text)}")


@lru_cache(maxsize=2048)
def parse(text: str) -> ast.Expression:
    """Parse and check *text*; raise `ExprError` for anything outside the allowed grammar.

    Refused before anything is evaluated: text over `MAX_LENGTH` characters, nesting deeper than
    `MAX_DEPTH`, and powers whose exponent is a constant over `MAX_EXPONENT` or a power tower
    (``9**9**9**9``).
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
        if isinstance(node, ast.BinOp) and isinstance(node.op, ast.Pow):
            _check_power(node, text)
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
                ast.operator,
                ast.unaryop,
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
                f"got {ast.unparse(node) if hasattr(node, 'lineno') else type(node).__name__!s} "
                f"in {_shown(text)}"
            )
    return tree


def names(text: str) -> set[str]:
    """Parameter names an expression refers to (functions and constants excluded)."""
    tree = parse(text)
    called = {n.func.id for n in ast.walk(tree) if isinstance(n, ast.Call)}
    return {n.id for n in ast.walk(tree) if isinstance(n, ast.Name)} - called - set(CONSTANTS)


def evaluate(text: str, env: Mapping[str, float]) -> float:
    """Evaluate *text* with parameter values *env* (numbers as floats, so no result is unbounded)."""
    return _eval(parse(text).body, env, text)


def _arith(op: ast.operator, a, b):
    """One arithmetic operation on floats; a power's exponent is bounded (`MAX_EXPONENT`)."""
    if isinstance(op, ast.Pow) and isinstance(b, (int, float)) and abs(b) > MAX_EXPONENT:
        raise ExprError(f"expected exponents of at most {MAX_EXPONENT:g}, got {b:g}")
    a = float(a) if isinstance(a, int) else a
    b = float(b) if isinstance(b, int) else b
    value = _BIN[type(op)](a, b)
    if isinstance(value, complex):
        raise ExprError("the result is not a real number")
    return value


def _eval(node: ast.AST, env: Mapping[str, float], text: str):
    if isinstance(node, ast.Constant):
        return float(node.value) if isinstance(node.value, int) and not isinstance(node.value, bool) else node.value
    if isinstance(node, ast.Name):
        if node.id in env:
            return env[node.id]
        if node.id in CONSTANTS:
            return CONSTANTS[node.id]
        raise ExprError(f"unknown name {node.id!r} in {_shown(text)}")
    if isinstance(node, ast.BinOp):
        try:
            return _arith(node.op, _eval(node.left, env, text), _eval(node.right, env, text))
        except (ZeroDivisionError, OverflowError, KeyError, TypeError) as exc:
            raise ExprError(f"cannot evaluate {_shown(text)}: {exc}") from None
        except ExprError as exc:
            raise ExprError(f"cannot evaluate {_shown(text)}: {exc}") from None
    if isinstance(node, ast.UnaryOp):
        v = _eval(node.operand, env, text)
        if isinstance(node.op, ast.USub):
            return -v
        if isinstance(node.op, ast.UAdd):
            return v
        if isinstance(node.op, ast.Not):
            return not v
        raise ExprError(f"operator not allowed in {_shown(text)}")
    if isinstance(node, ast.Compare):
        left = _eval(node.left, env, text)
        for op, comp in zip(node.ops, node.comparators, strict=True):
            right = _eval(comp, env, text)
            if not _CMP[type(op)](left, right):
                return False
            left = right
        return True
    if isinstance(node, ast.BoolOp):
        vals = [_eval(v, env, text) for v in node.values]
        return all(vals) if isinstance(node.op, ast.And) else any(vals)
    if isinstance(node, ast.IfExp):
        return _eval(node.body if _eval(node.test, env, text) else node.orelse, env, text)
    if isinstance(node, ast.Call):
        args = [_eval(a, env, text) for a in node.args]
        try:
            return FUNCTIONS[node.func.id](*args)
        except (ValueError, TypeError, OverflowError, ZeroDivisionError) as exc:
            raise ExprError(f"cannot evaluate {_shown(text)}: {exc}") from None
    raise ExprError(f"not allowed in {_shown(text)}")


def _np_functions():
    import numpy as np

    deg = np.degrees
    return {
        "sqrt": np.sqrt,
        "sin": np.sin,
        "cos": np.cos,
        "tan": np.tan,
        "asin": np.arcsin,
        "acos": np.arccos,
        "atan": np.arctan,
        "atan2": np.arctan2,
        "sind": lambda d: np.sin(np.radians(d)),
        "cosd": lambda d: np.cos(np.radians(d)),
        "tand": lambda d: np.tan(np.radians(d)),
        "asind": lambda x: deg(np.arcsin(x)),
        "acosd": lambda x: deg(np.arccos(x)),
        "atan2d": lambda y, x: deg(np.arctan2(y, x)),
        "radians": np.radians,
        "degrees": np.degrees,
        "abs": np.abs,
        "min": np.minimum,
        "max": np.maximum,
        "hypot": np.hypot,
        "round": np.round,
        "log10": np.log10,
        "exp": np.exp,
    }


def evaluate_many(text: str, env: Mapping):
    """Evaluate *text* elementwise over arrays of parameter values (one entry per variant).

    The same grammar and limits as `evaluate`; where a row has no real value (a square root of a
    negative, a division by zero) its result is NaN and its comparisons are False, where
    `evaluate` would raise for that row.
    """
    import numpy as np

    tree = parse(text)
    fns = _np_functions()
    cmp = {
        ast.Lt: np.less,
        ast.LtE: np.less_equal,
        ast.Gt: np.greater,
        ast.GtE: np.greater_equal,
        ast.Eq: np.equal,
        ast.NotEq: np.not_equal,
    }

    def ev(node: ast.AST):
        if isinstance(node, ast.Constant):
            return float(node.value) if isinstance(node.value, int) and not isinstance(node.value, bool) else node.value
        if isinstance(node, ast.Name):
            if node.id in env:
                return np.asarray(env[node.id], dtype=float)
            if node.id in CONSTANTS:
                return CONSTANTS[node.id]
            raise ExprError(f"unknown name {node.id!r} in {_shown(text)}")
        if isinstance(node, ast.BinOp):
            b = ev(node.right)
            if isinstance(node.op, ast.Pow) and np.any(np.abs(b) > MAX_EXPONENT):
                raise ExprError(f"cannot evaluate {_shown(text)}: expected exponents of at most {MAX_EXPONENT:g}")
            return _BIN[type(node.op)](ev(node.left), b)
        if isinstance(node, ast.UnaryOp):
            v = ev(node.operand)
            if isinstance(node.op, ast.USub):
                return -v
            if isinstance(node.op, ast.UAdd):
                return v
            if isinstance(node.op, ast.Not):
                return np.logical_not(truth(v))
        if isinstance(node, ast.Compare):
            left, out = ev(node.left), True
            for op, comp in zip(node.ops, node.comparators, strict=True):
                right = ev(comp)
                out = np.logical_and(out, cmp[type(op)](left, right))
                left = right
            return out
        if isinstance(node, ast.BoolOp):
            vals = [truth(ev(v)) for v in node.values]
            return np.logical_and.reduce(vals) if isinstance(node.op, ast.And) else np.logical_or.reduce(vals)
        if isinstance(node, ast.IfExp):
            return np.where(truth(ev(node.test)), ev(node.body), ev(node.orelse))
        if isinstance(node, ast.Call):
            return fns[node.func.id](*[ev(a) for a in node.args])
        raise ExprError(f"not allowed in {_shown(text)}")

    with np.errstate(all="ignore"):
        return ev(tree.body)


def truth(value):
    """Elementwise truth of an `evaluate_many` result: a NaN (no real value) is False."""
    import numpy as np

    v = np.asarray(value)
    return (v != 0) & ~np.isnan(v) if v.dtype.kind == "f" else v.astype(bool)
