"""OpenDRIVE plan-view geometries: the road reference line as exact functions of ``s``.

Every geometry maps a distance ``ds`` from its start to a point ``(u, v)`` and a heading in its
own local frame (origin at the geometry start, ``u`` along the start heading); :class:`PlanView`
turns those into world coordinates. Lines and arcs are closed form, spirals use Fresnel
integrals, and the cubic curves (poly3, paramPoly3) invert their arc length numerically, since
``s`` in OpenDRIVE is always the distance travelled along the curve.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from scipy.special import fresnel

#: Gauss-Legendre nodes/weights on [0, 1], used for every arc-length integral of this package
GL_NODES, GL_WEIGHTS = np.polynomial.legendre.leggauss(8)
GL_NODES = (GL_NODES + 1.0) / 2.0
GL_WEIGHTS = GL_WEIGHTS / 2.0

#: below this rate of change of curvature (1/m^2) a spiral is evaluated as an arc
_FLAT_SPIRAL = 1e-12


@dataclass(frozen=True)
class LocalPose:
    """Points of a geometry in its local frame: ``u``, ``v``, heading ``theta``, curvature."""

    u: np.ndarray
    v: np.ndarray
    theta: np.ndarray
    curvature: np.ndarray


@dataclass(frozen=True)
class Geometry:
    """One ``<geometry>`` record: start pose and length shared by every kind."""

    s: float
    x: float
    y: float
    hdg: float
    length: float

    def local(self, ds: np.ndarray) -> LocalPose:
        """Local-frame pose at distances ``ds`` (0..length) from the geometry start."""
        raise NotImplementedError


@dataclass(frozen=True)
class Line(Geometry):
    """A straight line."""

    def local(self, ds: np.ndarray) -> LocalPose:
        zero = np.zeros_like(ds)
        return LocalPose(ds.copy(), zero, zero, zero)


@dataclass(frozen=True)
class Arc(Geometry):
    """A circular arc of constant ``curvature`` (1/m, positive = to the left)."""

    curvature: float = 0.0

    def local(self, ds: np.ndarray) -> LocalPose:
        return _arc_pose(ds, self.curvature)


def _arc_pose(ds: np.ndarray, k: float) -> LocalPose:
    theta = k * ds
    if k == 0.0:
        return LocalPose(ds.copy(), np.zeros_like(ds), theta, np.zeros_like(ds))
    u = np.sin(theta) / k
    v = 2.0 * np.sin(theta / 2.0) ** 2 / k  # = (1 - cos) / k without cancellation
    return LocalPose(u, v, theta, np.full_like(ds, k))


@dataclass(frozen=True)
class Spiral(Geometry):
    """A clothoid whose curvature changes linearly from ``curv_start`` to ``curv_end``."""

    curv_start: float = 0.0
    curv_end: float = 0.0

    def local(self, ds: np.ndarray) -> LocalPose:
        k0 = self.curv_start
        rate = (self.curv_end - k0) / self.length
        if abs(rate) < _FLAT_SPIRAL:
            return _arc_pose(ds, k0)
        # theta(ds) = k0 ds + rate ds^2 / 2 = rate/2 (ds + k0/rate)^2 + phi: a Fresnel integral
        sign = 1.0 if rate > 0 else -1.0
        scale = math.sqrt(math.pi / abs(rate))
        phi = -k0 * k0 / (2.0 * rate)
        sin_end, cos_end = fresnel((ds + k0 / rate) / scale)
        sin_start, cos_start = fresnel(np.array(k0 / rate / scale))
        d_cos, d_sin = cos_end - cos_start, sign * (sin_end - sin_start)
        u = scale * (math.cos(phi) * d_cos - math.sin(phi) * d_sin)
        v = scale * (math.sin(phi) * d_cos + math.cos(phi) * d_sin)
        theta = k0 * ds + rate * ds * ds / 2.0
        return LocalPose(u, v, theta, k0 + rate * ds)


@dataclass(frozen=True)
class ParametricCubic(Geometry):
    """``u(p)``, ``v(p)`` cubic polynomials (paramPoly3; poly3 is ``u = p``).

    ``p_end`` is the parameter at the geometry end; ``None`` means "find it" (poly3, where the
    end is wherever the curve's arc length reaches ``length``).
    """

    coeff_u: tuple[float, float, float, float] = (0.0, 1.0, 0.0, 0.0)
    coeff_v: tuple[float, float, float, float] = (0.0, 0.0, 0.0, 0.0)
    p_end: float | None = None
    _table: dict[str, np.ndarray] = field(default_factory=dict, init=False, compare=False,
                                          repr=False)

    def local(self, ds: np.ndarray) -> LocalPose:
        p = self._parameter_at(np.clip(ds, 0.0, self.length))
        u, du, ddu = _cubic(self.coeff_u, p)
        v, dv, ddv = _cubic(self.coeff_v, p)
        speed = np.hypot(du, dv)
        return LocalPose(u, v, np.arctan2(dv, du), (du * ddv - dv * ddu) / speed**3)

    def _speed(self, p: np.ndarray) -> np.ndarray:
        speed: np.ndarray = np.hypot(_cubic(self.coeff_u, p)[1], _cubic(self.coeff_v, p)[1])
        return speed

    def _arc_length(self, p_from: np.ndarray, p_to: np.ndarray) -> np.ndarray:
        span = p_to - p_from
        nodes = p_from[..., None] + span[..., None] * GL_NODES
        length: np.ndarray = span * (self._speed(nodes) @ GL_WEIGHTS)
        return length

    def _tabulate(self) -> tuple[np.ndarray, np.ndarray]:
        if "grid" not in self._table:
            p_end = self.p_end if self.p_end is not None else self._solve_p_end()
            grid = np.linspace(0.0, p_end, max(16, math.ceil(self.length)) + 1)
            lengths = np.concatenate([[0.0], np.cumsum(self._arc_length(grid[:-1], grid[1:]))])
            self._table.update(grid=grid, lengths=lengths)
        return self._table["grid"], self._table["lengths"]

    def _solve_p_end(self) -> float:
        p = self.length  # arc length >= chord along u, so p_end <= length: Newton from above
        for _ in range(50):
            pieces = np.linspace(0.0, p, max(16, math.ceil(p)) + 1)
            total = float(self._arc_length(pieces[:-1], pieces[1:]).sum())
            step = (total - self.length) / float(self._speed(np.array(p)))
            p -= step
            if abs(step) < 1e-12:
                break
        return p

    def _parameter_at(self, ds: np.ndarray) -> np.ndarray:
        grid, lengths = self._tabulate()
        i = np.clip(np.searchsorted(lengths, ds, side="right") - 1, 0, len(grid) - 2)
        start = grid[i]
        p = start + (ds - lengths[i]) / (lengths[i + 1] - lengths[i]) * (grid[i + 1] - start)
        for _ in range(4):  # Newton on the arc length from the table's linear guess
            p = p - (lengths[i] + self._arc_length(start, p) - ds) / self._speed(p)
        parameter: np.ndarray = p
        return parameter


def _cubic(coeff: tuple[float, float, float, float],
           p: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    a, b, c, d = coeff
    return (a + p * (b + p * (c + p * d)), b + p * (2 * c + 3 * d * p), 2 * c + 6 * d * p)


@dataclass(frozen=True)
class ReferencePose:
    """Reference-line points in world coordinates (OpenDRIVE frame)."""

    x: np.ndarray
    y: np.ndarray
    hdg: np.ndarray
    curvature: np.ndarray


class PlanView:
    """The chain of geometries of one road, evaluated at any ``s`` (vectorised)."""

    def __init__(self, geometries: list[Geometry]):
        self.geometries = sorted(geometries, key=lambda g: g.s)
        self.starts = np.array([g.s for g in self.geometries])

    def pose(self, s: np.ndarray | float) -> ReferencePose:
        """World pose of the reference line at ``s`` (clamped to the road)."""
        s = np.atleast_1d(np.asarray(s, dtype=float))
        index = np.clip(np.searchsorted(self.starts, s, side="right") - 1, 0, len(self.starts) - 1)
        x, y, hdg, curvature = (np.empty_like(s) for _ in range(4))
        for i in np.unique(index):
            geometry, mask = self.geometries[i], index == i
            ds = np.clip(s[mask] - geometry.s, 0.0, geometry.length)
            local = geometry.local(ds)
            cos_h, sin_h = math.cos(geometry.hdg), math.sin(geometry.hdg)
            x[mask] = geometry.x + local.u * cos_h - local.v * sin_h
            y[mask] = geometry.y + local.u * sin_h + local.v * cos_h
            hdg[mask] = geometry.hdg + local.theta
            curvature[mask] = local.curvature
        return ReferencePose(x, y, hdg, curvature)

    def constant_curvature_on(self, low: float, high: float) -> float | None:
        """The curvature if one line or arc covers ``[low, high]``, else ``None``."""
        first, last = np.clip(np.searchsorted(self.starts, [low, high], side="right") - 1,
                              0, len(self.starts) - 1)
        geometry = self.geometries[first]
        if first != last or type(geometry) not in (Line, Arc):
            return None
        return getattr(geometry, "curvature", 0.0)

    def breakpoints(self) -> list[float]:
        """The ``s`` where one geometry ends and the next starts (curvature may jump there)."""
        return [g.s for g in self.geometries]
