"""The numeric core's own errors: plain exceptions, translated into user messages at the edge."""

from __future__ import annotations


class MechanicsError(Exception):
    """A mechanism position the core cannot analyse; ``detail`` is the message."""

    @property
    def detail(self) -> str:
        return self.__dict__.get("_detail", self.args[0] if self.args else "")

    @detail.setter
    def detail(self, text: str) -> None:
        self.__dict__["_detail"] = text


class GeometryError(MechanicsError):
    """A mechanism that cannot be assembled, or whose motion is undefined at this position."""


class ConditioningError(GeometryError):
    """The equilibrium system is too ill-conditioned to give trustworthy forces."""
