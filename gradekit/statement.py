"""Render a problem statement (jinja2) with one variant's values, formatted as printed.

A statement comes from a problem file, which is data: it renders in jinja2's immutable sandbox
(no ``__globals__``, ``__class__`` or other internals, nothing mutated), with only expressions,
``if`` and ``set`` allowed (no loops, macros, includes or imports) and bounded arithmetic, so a
statement can neither run code nor hang a run.
"""

from __future__ import annotations

import operator
import re

import jinja2
from jinja2 import nodes
from jinja2.compiler import CodeGenerator
from jinja2.sandbox import ImmutableSandboxedEnvironment

from gradekit import units
from gradekit.bank.model import Problem
from gradekit.errors import ProblemError
from gradekit.numbers import fmt

MAX_LENGTH = 20_000  # characters of statement source and of rendered text
MAX_BITS = 4_096  # integers in statement arithmetic
_ALLOWED = (nodes.Output, nodes.If, nodes.Assign)
_FILTERS = {"round", "abs", "upper", "lower", "title", "capitalize", "trim", "default", "float", "int", "string"}
_BINOPS = {  # jinja2 operator -> the function the sandbox calls after its checks
    "+": operator.add,
    "-": operator.sub,
    "*": operator.mul,
    "/": operator.truediv,
    "//": operator.floordiv,
    "%": operator.mod,
    "**": operator.pow,
}


class _CodeGenerator(CodeGenerator):
    """Jinja2's code generator with ``a ~ b`` (string concatenation) sent through `_Sandbox.concat`.

    The sandbox intercepts binary operators only; ``~`` compiles to a plain join, so that 30 doublings
    ``{% set s = s ~ s %}`` would build a 2 GB string before the rendered text could be measured.
    """

    def visit_Concat(self, node: nodes.Concat, frame) -> None:
        self.write("environment.concat((")
        for arg in node.nodes:
            self.visit(arg, frame)
            self.write(", ")
        self.write("))")


class _Sandbox(ImmutableSandboxedEnvironment):
    """The immutable sandbox with every arithmetic operator and ``~`` checked (no huge powers or strings)."""

    intercepted_binops = frozenset(_BINOPS)
    code_generator_class = _CodeGenerator

    def call_binop(self, context, operator: str, left, right):
        if _too_big(operator, left, right):
            raise jinja2.sandbox.SecurityError(f"{operator} gives a result too large to print")
        return _BINOPS[operator](left, right)

    def concat(self, parts: tuple) -> str:
        """``a ~ b ~ …``: the parts as text, refused when longer than `MAX_LENGTH` together."""
        texts = [str(p) for p in parts]
        if sum(map(len, texts)) > MAX_LENGTH:
            raise jinja2.sandbox.SecurityError(f"~ gives a text longer than {MAX_LENGTH:,} characters")
        return "".join(texts)


def _bits(x: object) -> int:
    return abs(x).bit_length() if isinstance(x, int) else 0


# a printf conversion of ``text % values``: its width and precision (``*`` takes them from the values)
_CONVERSION = re.compile(r"%(?:\([^)]*\))?[#0 +-]*(\*|\d+)?(?:\.(\*|\d+))?[hlL]?.")


def _formatted_too_long(text: str, values: object) -> bool:
    """Whether ``text % values`` could be longer than `MAX_LENGTH`: the text, the widths and precisions it
    asks for (``"%0900000000d" % 1`` is 900 MB of zeros) and every value as text, added up (``"%s%s" %
    (s, s)`` doubles s); a ``*`` width is refused outright."""
    asked = len(text)
    for width, precision in _CONVERSION.findall(text):
        if "*" in (width, precision):
            return True
        asked += int(width or 0) + int(precision or 0)
        if asked > MAX_LENGTH:
            return True
    items = values.values() if isinstance(values, dict) else values if isinstance(values, tuple) else (values,)
    for v in items:
        asked += len(v) if isinstance(v, str) else len(str(v)) if isinstance(v, (int, float)) else MAX_LENGTH + 1
        if asked > MAX_LENGTH:
            return True
    return False


def _too_big(op: str, left: object, right: object) -> bool:
    """Whether ``left op right`` would be a huge integer or a string/list over `MAX_LENGTH`."""
    if op == "%" and isinstance(left, str):
        return _formatted_too_long(left, right)
    if op == "**":
        if isinstance(right, (int, float)) and isinstance(left, (int, float)) and abs(left) > 1:
            bits = max(_bits(left), 1) if isinstance(left, int) else 0
            return abs(right) > 1_000 or (isinstance(right, int) and bits * right > MAX_BITS)
        return False
    if op == "*" and _bits(left) + _bits(right) > MAX_BITS:
        return True
    for a, b in ((left, right), (right, left)):
        if isinstance(a, (str, list, tuple)):
            if op == "*" and isinstance(b, int) and len(a) * b > MAX_LENGTH:
                return True
            if op == "+" and isinstance(b, (str, list, tuple)) and len(a) + len(b) > MAX_LENGTH:
                return True
    return False


def _printable(value: object) -> object:
    """Every ``{{ }}`` output: a method or function is refused (``{{ r.split }}`` would print its repr)."""
    if callable(value):
        raise TypeError(f"the method {getattr(value, '__name__', '?')!r} printed as it is (call it, or print a value)")
    return value


_ENV = _Sandbox(undefined=jinja2.StrictUndefined, autoescape=False, keep_trailing_newline=False,
                finalize=_printable)
_ENV.globals.clear()  # no range, lipsum, dict, cycler, joiner or namespace


class Shown(str):
    """A parameter as printed (``30 mm``), with ``.value`` and ``.unit`` for templates."""

    value: float
    unit: str


def shown(problem: Problem, name: str, value: float) -> Shown:
    par = problem.parameters[name]
    text = units.with_unit(fmt(value, 6), par.unit)
    s = Shown(text)
    s.value, s.unit = value, par.unit
    return s


def _refuse(problem: Problem, message: str) -> ProblemError:
    line = problem.lines.get("statement")
    return ProblemError(message, path=problem.path, line=line, field="statement")


def _check(problem: Problem, source: str) -> None:
    """Refuse statements that are longer than `MAX_LENGTH` or use more than expressions and ``if``."""
    if len(source) > MAX_LENGTH:
        raise _refuse(problem, f"expected a statement of at most {MAX_LENGTH:,} characters, got {len(source):,}")
    try:
        tree = _ENV.parse(source)
    except jinja2.TemplateSyntaxError as exc:
        raise _refuse(problem, f"expected a statement using the problem's parameters, got {exc}") from None
    for node in tree.find_all((nodes.Stmt, nodes.Call, nodes.Filter, nodes.Test)):
        if isinstance(node, _ALLOWED) or (isinstance(node, nodes.Filter) and node.name in _FILTERS):
            continue
        if isinstance(node, nodes.Test) and node.name in ("defined", "undefined", "number", "string"):
            continue
        if isinstance(node, nodes.Call):
            what = "a function call"
        elif isinstance(node, (nodes.Filter, nodes.Test)):
            what = f"the {type(node).__name__.lower()} {node.name!r}"
        else:
            what = f"a {type(node).__name__.lower()} block"
        raise _refuse(
            problem,
            f"expected {{{{ parameter }}}}, {{% if %}} and {{% set %}} only, got {what} "
            f"on line {node.lineno} of the statement",
        )


_TEMPLATES: dict[str, jinja2.Template] = {}


def _template(problem: Problem, source: str) -> jinja2.Template:
    """The checked, compiled statement *source* (compiled once per process, not once per student)."""
    template = _TEMPLATES.get(source)
    if template is None:
        _check(problem, source)
        if len(_TEMPLATES) >= 512:
            _TEMPLATES.clear()
        template = _TEMPLATES[source] = _ENV.from_string(source)
    return template


def render_statement(problem: Problem, values: dict[str, float]) -> str:
    """The statement with each parameter name replaced by its value and unit."""
    template = _template(problem, problem.statement)
    ctx = {n: shown(problem, n, v) for n, v in values.items() if n in problem.parameters}
    try:
        text = _rendered(template, ctx)
    except jinja2.sandbox.SecurityError as exc:
        raise _refuse(
            problem, f"expected a statement using the problem's parameters, got an unsafe use: {exc}"
        ) from None
    except jinja2.TemplateError as exc:
        raise _refuse(problem, f"expected a statement using the problem's parameters, got {exc}") from None
    except (TypeError, ValueError, ArithmeticError) as exc:
        raise _refuse(problem, f"expected a statement using the problem's parameters, got {exc}") from None
    if text is None:
        raise _refuse(problem, f"expected a rendered statement of at most {MAX_LENGTH:,} characters, got more")
    return text


def _rendered(template: jinja2.Template, ctx: dict) -> str | None:
    """The rendered text, or None once it grows past `MAX_LENGTH` (measured piece by piece: many
    outputs of a long string must not add up to megabytes first)."""
    pieces, size = [], 0
    for piece in template.generate(**ctx):
        size += len(piece)
        if size > MAX_LENGTH:
            return None
        pieces.append(piece)
    return "".join(pieces).strip()
