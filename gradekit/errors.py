"""One exception family: every error a user can cause, with where, what was expected and what was found."""

from __future__ import annotations

import click

from gradekit.mechanics import errors as core


class GradekitError(click.ClickException):
    """A data error the user can fix. Printed as one line by the CLI, exit code 1.

    Args:
        message: what is wrong, with what was expected and what was found.
        path: the file concerned, if any.
        line: the 1-based line (or CSV row) in that file, if known.
        field: the dotted field name or column, if any.
    """

    exit_code = 1

    def __init__(
        self,
        message: str,
        *,
        path: str | None = None,
        line: int | None = None,
        field: str | None = None,
    ) -> None:
        self.path = path
        self.line = line
        self.field = field
        self.detail = message
        super().__init__(self._render())

    def _render(self) -> str:
        where = ""
        if self.path:
            where = str(self.path) + (f":{self.line}" if self.line else "") + ": "
        elif self.line:
            where = f"line {self.line}: "
        field = f"{self.field}: " if self.field else ""
        return f"{where}{field}{self.detail}"

    def format_message(self) -> str:
        return self._render()


class GeometryError(GradekitError, core.GeometryError):
    """A mechanism that cannot be assembled or is too close to a singular position.

    The numeric core raises the plain `gradekit.mechanics.errors.GeometryError`; the pipeline
    translates it into this one, with the problem file and field. Catching the core class
    catches both.
    """


class ConditioningError(GeometryError, core.ConditioningError):
    """The equilibrium system is too ill-conditioned to give trustworthy forces."""


class ProblemError(GradekitError):
    """A problem or assignment file that does not validate."""


class SamplingError(GradekitError):
    """No acceptable variant could be drawn under the problem's constraints."""


class ErrorList(GradekitError):
    """Several errors collected (e.g. a whole bank); printed one per line."""

    def __init__(self, errors: list[GradekitError]) -> None:
        self.errors = errors
        super().__init__("\n".join(e.format_message() for e in errors))

    def _render(self) -> str:  # the joined messages already carry their locations
        return self.detail
