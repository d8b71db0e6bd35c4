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


@lru_cache(maxsize=2048)
def parse(text: str) -> ast.Expression:
    """Parse and check *text*; raise `ExprError` for anything outside the allowed grammar."""
    try:
        tree = ast.parse(text, mode="eval")
    except SyntaxError as exc:
        raise ExprError(f"expected an arithmetic expression, got {text!r} ({exc.msg})") from None
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
                f"in {text!r}"
            )
    return tree


def names(text: str) -> set[str]:
    """Parameter names an expression refers to (functions and constants excluded)."""
    tree = parse(text)
    called = {n.func.id for n in ast.walk(tree) if isinstance(n, ast.Call)}
    return {n.id for n in ast.walk(tree) if isinstance(n, ast.Name)} - called - set(CONSTANTS)


def evaluate(text: str, env: Mapping[str, float]) -> float:
    """Evaluate *text* with parameter values *env*."""
    return _eval(parse(text).body, env, text)


def _eval(node: ast.AST, env: Mapping[str, float], text: str):
    if isinstance(node, ast.Constant):
        return node.value
    if isinstance(node, ast.Name):
        if node.id in env:
            return env[node.id]
        if node.id in CONSTANTS:
            return CONSTANTS[node.id]
        raise ExprError(f"unknown name {node.id!r} in {text!r}")
    if isinstance(node, ast.BinOp):
        try:
            return _BIN[type(node.op)](_eval(node.left, env, text), _eval(node.right, env, text))
        except (ZeroDivisionError, OverflowError, KeyError) as exc:
            raise ExprError(f"cannot evaluate {text!r}: {exc}") from None
    if isinstance(node, ast.UnaryOp):
        v = _eval(node.operand, env, text)
        if isinstance(node.op, ast.USub):
            return -v
        if isinstance(node.op, ast.UAdd):
            return v
        if isinstance(node.op, ast.Not):
            return not v
        raise ExprError(f"operator not allowed in {text!r}")
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
            raise ExprError(f"cannot evaluate {text!r}: {exc}") from None
    raise ExprError(f"not allowed in {text!r}")
