"""The one number formatter: reports, statements, documents, keys and feedback print numbers through it."""

from __future__ import annotations

import math


def fmt(value: float, sig: int = 5) -> str:
    """The one number formatter shared by reports, documents and feedback.

    Rounds to *sig* significant figures and prints without exponent or trailing zeros
    (``235150``, ``1.1184``, ``-0.0043``); ``-0`` prints as ``0``.
    """
    if not math.isfinite(value):
        return str(value)
    if value == 0:
        return "0"
    text = f"{value:.{sig}g}"  # correctly rounded to *sig* figures; without an exponent for most values
    if "e" not in text:
        return text.rstrip("0").rstrip(".") if "." in text else text
    digits = sig - 1 - int(math.floor(math.log10(abs(value))))
    rounded = round(value, digits)
    text = f"{rounded:.{max(digits, 0)}f}"
    if "." in text:
        text = text.rstrip("0").rstrip(".")
    return "0" if float(text) == 0 else text
