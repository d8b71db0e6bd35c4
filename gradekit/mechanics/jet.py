"""Second-order Taylor jets: exact velocities and accelerations through closed-form positions.

A `Jet` carries a value with its first and second time derivatives. Evaluating a mechanism's
closed-form position solution on jets (crank angle θ with θ̇ = ω, θ̈ = α) yields every point's
velocity and acceleration exactly by the chain rule; no finite differences are involved.
Components may be floats or numpy arrays (for batched positions).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class Jet:
    """Value ``v``, first derivative ``d`` and second derivative ``dd`` with respect to time."""

    v: float
    d: float = 0.0
    dd: float = 0.0

    @staticmethod
    def lift(x: Jet | float) -> Jet:
        return x if isinstance(x, Jet) else Jet(x, 0.0, 0.0)

    def __add__(self, o: Jet | float) -> Jet:
        o = Jet.lift(o)
        return Jet(self.v + o.v, self.d + o.d, self.dd + o.dd)

    __radd__ = __add__

    def __neg__(self) -> Jet:
        return Jet(-self.v, -self.d, -self.dd)

    def __sub__(self, o: Jet | float) -> Jet:
        return self + (-Jet.lift(o))

    def __rsub__(self, o: Jet | float) -> Jet:
        return Jet.lift(o) - self

    def __mul__(self, o: Jet | float) -> Jet:
        if not isinstance(o, Jet):
            return Jet(self.v * o, self.d * o, self.dd * o)
        return Jet(
            self.v * o.v,
            self.d * o.v + self.v * o.d,
            self.dd * o.v + 2 * self.d * o.d + self.v * o.dd,
        )

    __rmul__ = __mul__

    def reciprocal(self) -> Jet:
        inv = 1.0 / self.v
        return Jet(inv, -self.d * inv**2, (2 * self.d**2 * inv - self.dd) * inv**2)

    def __truediv__(self, o: Jet | float) -> Jet:
        if not isinstance(o, Jet):
            return self * (1.0 / o)
        return self * o.reciprocal()

    def __rtruediv__(self, o: float) -> Jet:
        return self.reciprocal() * o

    def _chain(self, f0, f1, f2) -> Jet:
        """Apply a scalar function with derivatives f0, f1, f2 at ``v``."""
        return Jet(f0, f1 * self.d, f2 * self.d**2 + f1 * self.dd)


def where(mask, a: Jet, b: Jet) -> Jet:
    """Elementwise choice between two jets (batched branches): *a* where *mask*, else *b*."""
    return Jet(np.where(mask, a.v, b.v), np.where(mask, a.d, b.d), np.where(mask, a.dd, b.dd))


def _take(x, i: int) -> float:
    return float(x[i]) if np.ndim(x) else float(x)


def take(x: Jet, i: int) -> Jet:
    """Variant *i* of a batched jet, as a scalar jet."""
    return Jet(_take(x.v, i), _take(x.d, i), _take(x.dd, i))


def sin(x: Jet | float) -> Jet:
    x = Jet.lift(x)
    s, c = np.sin(x.v), np.cos(x.v)
    return x._chain(s, c, -s)


def cos(x: Jet | float) -> Jet:
    x = Jet.lift(x)
    s, c = np.sin(x.v), np.cos(x.v)
    return x._chain(c, -s, -c)


def sqrt(x: Jet | float) -> Jet:
    x = Jet.lift(x)
    r = np.sqrt(x.v)
    return x._chain(r, 0.5 / r, -0.25 / (r * x.v))


def atan2(y: Jet | float, x: Jet | float) -> Jet:
    """Angle of the vector (x, y), with exact derivatives."""
    y, x = Jet.lift(y), Jet.lift(x)
    r2 = x.v**2 + y.v**2
    v = np.arctan2(y.v, x.v)
    # dθ = (x dy - y dx) / r²
    num = x.v * y.d - y.v * x.d
    d = num / r2
    dnum = x.d * y.d + x.v * y.dd - y.d * x.d - y.v * x.dd
    dr2 = 2 * (x.v * x.d + y.v * y.d)
    dd = (dnum * r2 - num * dr2) / r2**2
    return Jet(v, d, dd)


@dataclass(frozen=True)
class P:
    """A planar point (or vector) whose coordinates are jets."""

    x: Jet
    y: Jet

    def __add__(self, o: P) -> P:
        return P(self.x + o.x, self.y + o.y)

    def __sub__(self, o: P) -> P:
        return P(self.x - o.x, self.y - o.y)

    def __mul__(self, k: Jet | float) -> P:
        return P(self.x * k, self.y * k)

    __rmul__ = __mul__

    @staticmethod
    def fixed(x: float, y: float) -> P:
        return P(Jet(x), Jet(y))

    @staticmethod
    def polar(r: Jet | float, angle: Jet | float) -> P:
        return P(cos(angle) * r, sin(angle) * r)

    def dot(self, o: P) -> Jet:
        return self.x * o.x + self.y * o.y

    def cross(self, o: P) -> Jet:
        return self.x * o.y - self.y * o.x

    def norm(self) -> Jet:
        return sqrt(self.dot(self))

    def angle(self) -> Jet:
        return atan2(self.y, self.x)

    def rotate(self, angle: Jet | float) -> P:
        c, s = cos(angle), sin(angle)
        return P(self.x * c - self.y * s, self.x * s + self.y * c)

    def take(self, i: int) -> P:
        """Variant *i* of a batched point."""
        return P(take(self.x, i), take(self.y, i))

    def pos(self) -> np.ndarray:
        return np.array([self.x.v, self.y.v], dtype=float)

    def vel(self) -> np.ndarray:
        return np.array([self.x.d, self.y.d], dtype=float)

    def acc(self) -> np.ndarray:
        return np.array([self.x.dd, self.y.dd], dtype=float)


def along(origin: P, angle: Jet, u: float, w: float = 0.0) -> P:
    """The point at distance *u* along and *w* across (to the left of) a line at *angle* from *origin*."""
    return origin + P.polar(1.0, angle) * u + P.polar(1.0, angle + np.pi / 2) * w
