"""Unit parsing and conversion (pint), with the spellings engineers and students actually write.

pint is the one place units are understood: it knows N, kN, lbf, slug, in, ft, mm, kg and their
products, so the bank, the solver's boundary and the grader agree on every conversion. The
mechanics core never sees units: values cross into it in SI.
"""

from __future__ import annotations

import re
from functools import lru_cache

from gradekit.errors import GradekitError

_REG = None

# Spellings pint does not read as meant here. In a force-analysis course "lb" on a force, a weight
# or a torque means pound-force; pint reads "lb" as pound-mass, so a unit whose dimension does not
# match is retried with lb read as lbf (see `factor`).
MAX_LENGTH = 40  # characters of a unit string: "lbf*in/s**2" is 11; pint's parser is not linear

_SUBS = [
    (re.compile(r"(?<=\w)\.$"), ""),  # "Nm." at the end of a sentence
    (re.compile(r"(?<![A-Za-z])K(?=N)"), "k"),  # KN, KNm: kilo is a small k
    (re.compile(r"(?<![A-Za-z])([kMm]?)N(mm|cm|m|M)(?![A-Za-z])"), r"\1N*\2"),  # Nm, kNm, Nmm, NM
    (re.compile(r"(?<=N\*)M(?![A-Za-z])"), "m"),
    (re.compile(r"(?<![A-Za-z])(lbf|lbs|lb|ozf|oz|kips?)-?(in|ft)(?![A-Za-z])"), r"\1*\2"),  # lbin, lbft
    (re.compile(r"(?<![A-Za-z])(in|ft)-?(lbf|lbs|lb|ozf|oz|kips?)(?![A-Za-z])"), r"\1*\2"),  # inlb, ftlb
    (re.compile(r"[·⋅•×]"), "*"),
    (re.compile(r"²"), "**2"),
    (re.compile(r"³"), "**3"),
    (re.compile(r"\^"), "**"),
    (re.compile(r"(?<=[A-Za-z])\.(?=[A-Za-z])"), "*"),  # N.m -> N*m
    (re.compile(r"(?<=[A-Za-z])-(?=[A-Za-z])"), "*"),  # in-lb, lb-ft-s2 -> products
    (re.compile(r"(?<=[A-Za-z])(\d)\b"), r"**\1"),  # s2, mm2 -> s**2, mm**2
    (re.compile(r"\bsec\b"), "s"),
    (re.compile(r"\bIb\b|\bIbf\b"), "lbf"),  # OCR'd "Ib" in the course documents
    (re.compile(r"\bdeg\b|°"), "degree"),
    (re.compile(r"\brevs?\b"), "revolution"),  # rev/min, rev/s: a machine's speed as its drawings give it
    (re.compile(r"\bRPM\b|(?<![A-Za-z])r/min\b"), "rpm"),
]


def registry():
    """The process-wide pint registry, created on first use (importing pint costs ~0.2 s)."""
    global _REG
    if _REG is None:
        import pint

        _REG = pint.UnitRegistry(autoconvert_offset_to_baseunit=True)
    return _REG


def normalise(unit: str) -> str:
    """Rewrite common hand-written spellings (``N·mm``, ``in-lb``, ``rad/s^2``) into pint syntax."""
    text = unit.strip()
    for pattern, repl in _SUBS:
        text = pattern.sub(repl, text)
    return text or "dimensionless"


def _lbf(text: str) -> str:
    return re.sub(r"\boz\b", "ozf", re.sub(r"\blbs?\b", "lbf", text))


# A power in a unit: ** then one digit (a sign and a decimal part allowed), not raised again. pint
# evaluates powers as numbers, so "9^9^9" (9**387420489) would hang a grading batch.
_POWER = re.compile(r"\*\*\s*[-+]?\d(\.\d+)?(?![\d.])(?!\s*\*\*)")
MAX_POWERS = 3  # "kg*m**2/s**2" has 2


@lru_cache(maxsize=4096)
def _parse(text: str):
    if len(text) > MAX_LENGTH:
        raise GradekitError(f"expected a unit of at most {MAX_LENGTH} characters, got {len(text):,}")
    reg = registry()
    bad = GradekitError(f"expected a unit such as N, N*mm, lbf*in or rad/s**2, got {text!r}")
    pint_text = normalise(text)
    powers = pint_text.count("**")
    if powers > MAX_POWERS or len(_POWER.findall(pint_text)) != powers:
        raise bad
    try:
        return reg.parse_units(pint_text) if text.strip() else reg.dimensionless
    except Exception:  # pint raises several unrelated types for bad input
        raise bad from None


def check(unit: str) -> None:
    """Raise `GradekitError` unless *unit* is a unit pint understands."""
    _parse(unit)


@lru_cache(maxsize=8192)
def factor(from_unit: str, to_unit: str) -> float:
    """The number to multiply a value in *from_unit* by to express it in *to_unit*.

    A bare ``lb`` is read as pound-force when pound-mass would not fit the target's dimension. Hertz
    and a unit that names an angle are not converted into each other: pint takes 1 Hz for 1 rad/s, a
    student writing "2 Hz" for a shaft's speed may mean 2 rev/s or 2 rad/s, so the answer is refused
    with a message saying how to write it, never graded on a guess.

    Raises:
        GradekitError: a unit is unreadable or the two measure different things.
    """
    src, dst = _parse(from_unit), _parse(to_unit)
    if _cycles(src) != _cycles(dst) and (_turning(src) or _turning(dst)):
        raise GradekitError(
            f"expected {to_unit!r} or a unit that converts to it without doubt, got {from_unit!r} (hertz counts "
            "cycles: write rev/s for turns a second, rad/s for radians a second)"
        )
    reg = registry()
    for candidate in (src, None):
        if candidate is None:
            try:
                candidate = _parse(_lbf(normalise(from_unit)))
            except GradekitError:
                break
        try:
            return float(reg.Quantity(1.0, candidate).to(dst).magnitude)
        except Exception:  # DimensionalityError
            continue
    raise GradekitError(f"expected a unit of the same kind as {to_unit!r}, got {from_unit!r}")


def _cycles(unit) -> bool:
    """A frequency (Hz, kHz): cycles a second."""
    return "hertz" in str(unit)


_ANGLES = ("radian", "degree", "turn", "revolution", "arcminute", "arcsecond", "gradian")


def _turning(unit) -> bool:
    """A unit that names an angle (rad/s, rpm, deg, rev/min)."""
    return any(name in str(unit) for name in _ANGLES)


@lru_cache(maxsize=1024)
def is_angular(unit: str) -> bool:
    """Whether *unit* measures an angle or an angle per unit of time (``deg``, ``rad``, ``rad/s``,
    ``rad/s**2``, ``rpm``): pint counts the radian as dimensionless, so these are the units whose only
    dimension is time to a negative power, or none. A unit pint cannot read is not one."""
    try:
        dims = dict(_parse(unit).dimensionality)
    except GradekitError:
        return False
    return not dims or (dims.keys() == {"[time]"} and dims["[time]"] < 0)


def convert(value: float, from_unit: str, to_unit: str) -> float:
    """Convert *value* from one unit to another (see `factor`)."""
    if from_unit == to_unit:
        return value
    return value * factor(from_unit, to_unit)


@lru_cache(maxsize=4096)
def si_unit(unit: str) -> str:
    """The SI base unit string with the dimension of *unit* (``N*mm`` -> ``kilogram * meter ** 2 / ...``)."""
    reg = registry()
    try:
        q = reg.Quantity(1.0, _parse(unit)).to_base_units()
    except Exception as exc:
        raise GradekitError(f"expected a convertible unit, got {unit!r}") from exc
    return str(q.units)


def to_si(value: float, unit: str) -> float:
    """Express *value* in *unit* in SI base units (metre, kilogram, second, radian)."""
    return value * factor(unit, si_unit(unit)) if unit else value


_PRETTY = [("**2", "²"), ("**3", "³"), ("*", "·"), ("degree", "°")]


def pretty(unit: str) -> str:
    """Display form of a unit string: ``N*mm`` -> ``N·mm``, ``mm/s**2`` -> ``mm/s²``, ``deg`` -> ``°``."""
    if unit.strip() in ("deg", "degree", "degrees"):
        return "°"
    text = unit
    for a, b in _PRETTY:
        text = text.replace(a, b)
    return text


def with_unit(number: str, unit: str) -> str:
    """``30 mm``, ``45°``: a formatted number followed by its display unit."""
    return spaced(number, pretty(unit))


def spaced(number: str, shown: str) -> str:
    """A formatted number followed by a unit already as printed (`pretty`): a space between them, none
    before ``°``; a number alone without one."""
    if not shown or shown == "dimensionless":
        return number
    return f"{number}{shown}" if shown == "°" else f"{number} {shown}"
