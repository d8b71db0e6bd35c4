"""Where the bundled templates and problem bank are: the checkout's top-level folders, else the
copies installed inside the package (a wheel ships them as gradekit/templates, gradekit/problem_bank)."""

from __future__ import annotations

from pathlib import Path

_HERE = Path(__file__).resolve().parent


def resource_dir(name: str) -> Path:
    """The folder *name* (``templates`` or ``problem_bank``) of this checkout or installation."""
    for candidate in (_HERE.parent / name, _HERE / name):
        if candidate.is_dir():
            return candidate
    return _HERE.parent / name
