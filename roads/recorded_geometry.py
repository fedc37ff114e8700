"""Plane geometry for writing a recorded lane network as OpenDRIVE: a smooth reference line
through a boundary polyline, and positions of other polylines measured along it.

Why these choices (docs/recorded-road.md):

- The reference line is a chain of cubic Hermite pieces through the boundary's vertices
  (tangent at a vertex: the mean direction of the two segments that meet there, magnitude the
  piece's chord). Each piece is written as one ``paramPoly3`` with ``pRange="normalized"``:
  the curve is C1 (no heading jumps for a simulator to trip on), passes through every kept
  vertex, and a straight run of vertices stays exactly straight. Vertices closer than
  :data:`MIN_SPACING_M` to the last kept one are dropped first (recorded maps repeat points),
  so no piece has zero length.
- Lateral positions (``t``, positive to the left) of a boundary are found by projecting its
  densified points on a dense sampling of the reference; ``t`` as a function of ``s`` is then
  simplified (Douglas-Peucker, :data:`WIDTH_TOLERANCE_M`) into linear pieces, which become
  ``laneOffset`` and ``width`` records: every lane follows its own borders within that
  tolerance, whatever its flare.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt
from scipy.spatial import cKDTree

Floats = npt.NDArray[np.float64]
Mask = npt.NDArray[np.bool_]

#: boundary vertices closer than this to the previous kept one are dropped (m)
MIN_SPACING_M = 0.5
#: a lateral profile is kept within this of the measured one (m)
WIDTH_TOLERANCE_M = 0.01
#: spacing of the dense sampling of the reference used for projections (m)
DENSE_STEP_M = 0.25
#: boundaries are densified to this spacing before they are projected (m)
BOUNDARY_STEP_M = 1.0
#: Gauss-Legendre nodes and weights on [0, 1] for arc lengths
_GL_X, _GL_W = np.polynomial.legendre.leggauss(8)
GL_NODES = (_GL_X + 1) / 2
GL_WEIGHTS = _GL_W / 2


@dataclass(frozen=True)
class Piece:
    """One cubic piece ``r(q) = a + b q + c q^2 + d q^3``, ``q`` in [0, 1], in world
    coordinates, with its start ``s`` and arc ``length`` along the reference."""

    s: float
    length: float
    a: Floats
    b: Floats
    c: Floats
    d: Floats

    @property
    def heading(self) -> float:
        return math.atan2(float(self.b[1]), float(self.b[0]))

    def local(self) -> tuple[tuple[float, float, float, float], tuple[float, float, float, float]]:
        """``(aU, bU, cU, dU), (aV, bV, cV, dV)``: the piece in its own frame (origin at its
        start, ``u`` along its start heading), as paramPoly3 writes it."""
        cos_h, sin_h = math.cos(self.heading), math.sin(self.heading)

        def rotate(v: Floats) -> tuple[float, float]:
            return (float(v[0] * cos_h + v[1] * sin_h), float(-v[0] * sin_h + v[1] * cos_h))

        (bu, _), (cu, cv), (du, dv) = rotate(self.b), rotate(self.c), rotate(self.d)
        return (0.0, bu, cu, du), (0.0, 0.0, cv, dv)

    def at(self, q: Floats) -> Floats:
        """Points at parameters ``q`` (n, 2)."""
        q = q[:, None]
        return self.a + self.b * q + self.c * q ** 2 + self.d * q ** 3


def thinned(points: Floats, min_spacing: float = MIN_SPACING_M) -> Floats:
    """``points`` without the vertices closer than ``min_spacing`` to the previous kept one;
    the last point is always kept (it replaces a kept one too close to it)."""
    kept = [points[0]]
    for point in points[1:-1]:
        if math.dist(point, kept[-1]) >= min_spacing:
            kept.append(point)
    if math.dist(points[-1], kept[-1]) < min_spacing and len(kept) > 1:
        kept.pop()
    kept.append(points[-1])
    return np.asarray(kept, dtype=float)


def tangents(points: Floats) -> Floats:
    """Unit tangent at each vertex: the mean of the unit directions of the segments meeting
    there; at an end, the neighbour's tangent mirrored about the end segment (a polyline
    sampled from an arc then starts along the arc, not along its first chord)."""
    seg = np.diff(points, axis=0)
    unit = seg / np.hypot(*seg.T)[:, None]
    summed = np.vstack([unit[:1], unit[:-1] + unit[1:], unit[-1:]])
    norm = np.hypot(*summed.T)
    bad = norm < 1e-9  # a reversal: fall back on the incoming segment
    summed[bad] = np.vstack([unit[:1], unit])[bad]
    norm[bad] = 1.0
    result: Floats = summed / norm[:, None]
    if len(points) > 2:  # at the ends, the next tangent mirrored about the end chord
        for end, chord, inner in ((0, unit[0], result[1]), (-1, unit[-1], result[-2])):
            result[end] = 2 * float(chord @ inner) * chord - inner
    return result


def _arc_length(b: Floats, c: Floats, d: Floats) -> float:
    """Arc length of ``a + b q + c q^2 + d q^3`` over [0, 1] (Gauss-Legendre)."""
    q = GL_NODES[:, None]
    speed = np.hypot(*(b + 2 * c * q + 3 * d * q ** 2).T)
    return float(speed @ GL_WEIGHTS)


def reference_pieces(boundary: Floats) -> list[Piece]:
    """The smooth reference line through a boundary polyline (see the module docstring).
    ``boundary`` must have two points at least :data:`MIN_SPACING_M` apart."""
    points = thinned(np.asarray(boundary, dtype=float))
    directions = tangents(points)
    pieces, s = [], 0.0
    for k in range(len(points) - 1):
        p0, p1 = points[k], points[k + 1]
        chord = float(math.dist(p0, p1))
        m0, m1 = directions[k] * chord, directions[k + 1] * chord
        delta = p1 - p0
        c = 3 * delta - 2 * m0 - m1
        d = -2 * delta + m0 + m1
        length = _arc_length(m0, c, d)
        pieces.append(Piece(s, length, p0.copy(), m0, c, d))
        s += length
    return pieces


@dataclass(frozen=True)
class DenseLine:
    """The reference sampled densely: points, their ``s`` and unit tangents."""

    xy: Floats
    s: Floats
    tangent: Floats
    tree: cKDTree

    @classmethod
    def of(cls, pieces: list[Piece]) -> DenseLine:
        """The pieces sampled every :data:`DENSE_STEP_M` or closer, ``s`` scaled so each
        piece's samples span its exact arc length."""
        xys, ss = [], []
        for piece in pieces:
            n = max(2, int(math.ceil(piece.length / DENSE_STEP_M)) + 1)
            q = np.linspace(0.0, 1.0, n)
            xy = piece.at(q)
            chord = np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(xy, axis=0).T))])
            scale = piece.length / chord[-1] if chord[-1] > 0 else 0.0
            xys.append(xy[:-1])
            ss.append(piece.s + chord[:-1] * scale)
        last = pieces[-1]
        xys.append(last.at(np.array([1.0])))
        ss.append(np.array([last.s + last.length]))
        xy, s = np.vstack(xys), np.concatenate(ss)
        seg = np.diff(xy, axis=0)
        unit = seg / np.maximum(np.hypot(*seg.T), 1e-12)[:, None]
        return cls(xy, s, np.vstack([unit, unit[-1:]]), cKDTree(xy))

    @property
    def length(self) -> float:
        return float(self.s[-1])

    def project(self, points: Floats) -> tuple[Floats, Floats, npt.NDArray[np.bool_]]:
        """``s``, ``t`` (positive to the left) of each point's nearest point on the line, and
        whether that point lies inside the line (not beyond one of its ends). The nearest
        vertex is found in a k-d tree and the two segments meeting there are tried: exact
        while a point is nearer the line than the line's radius of curvature."""
        _, nearest = self.tree.query(points)
        last = len(self.xy) - 2  # the last segment's index
        candidates = np.stack([np.clip(nearest - 1, 0, last), np.clip(nearest, 0, last)], axis=1)
        a, b = self.xy[candidates], self.xy[candidates + 1]
        seg = b - a
        rel = points[:, None, :] - a
        u = (rel * seg).sum(axis=2) / np.maximum((seg ** 2).sum(axis=2), 1e-12)
        u_clipped = np.clip(u, 0.0, 1.0)
        gap = rel - u_clipped[..., None] * seg
        dist2 = (gap ** 2).sum(axis=2)
        pick = np.argmin(dist2, axis=1)
        rows = np.arange(len(points))
        best, ub = candidates[rows, pick], u_clipped[rows, pick]
        s = self.s[best] + ub * (self.s[best + 1] - self.s[best])
        cross = seg[rows, pick, 0] * rel[rows, pick, 1] - seg[rows, pick, 1] * rel[rows, pick, 0]
        t = np.sign(cross) * np.sqrt(dist2[rows, pick])
        beyond = ((best == 0) & (u[rows, pick] < 0)) | ((best == last) & (u[rows, pick] > 1))
        return s, t, ~beyond


def densified(polyline: Floats, step: float = BOUNDARY_STEP_M) -> Floats:
    """The polyline with points inserted so no segment is longer than ``step``."""
    seg = np.diff(polyline, axis=0)
    count = np.maximum(1, np.ceil(np.hypot(*seg.T) / step)).astype(int)
    owner = np.repeat(np.arange(len(seg)), count)
    first = np.cumsum(count) - count
    fraction = (np.arange(len(owner)) - first[owner]) / count[owner]
    inner = polyline[owner] + seg[owner] * fraction[:, None]
    return np.vstack([inner, polyline[-1:]])


def lateral_profiles(line: DenseLine, polylines: list[Floats], stations: Floats
                     ) -> list[Floats]:
    """``t`` of each polyline at each of ``stations`` (``s`` along ``line``): the polyline's
    densified points projected on the line (all polylines in one query), interpolated in
    ``s``; held at the ends where a polyline starts after or ends before the line."""
    dense = [densified(np.asarray(p, dtype=float)) for p in polylines]
    s_all, t_all, within_all = line.project(np.vstack(dense))
    bounds = np.cumsum([len(d) for d in dense])[:-1]
    profiles = []
    for s, t, within in zip(np.split(s_all, bounds), np.split(t_all, bounds),
                            np.split(within_all, bounds), strict=True):
        keep = within
        if keep.sum() < 2:
            keep = np.ones(len(s), dtype=bool)
        order = np.argsort(s[keep], kind="stable")
        profiles.append(np.interp(stations, s[keep][order], t[keep][order]))
    return profiles


def simplified(s: Floats, values: Floats, tolerance: float = WIDTH_TOLERANCE_M) -> Floats:
    """Indexes of the stations a piecewise-linear profile needs to stay within ``tolerance``
    of ``values`` (Douglas-Peucker on the vertical distance); first and last always."""
    keep = np.zeros(len(s), dtype=bool)
    keep[[0, -1]] = True
    stack = [(0, len(s) - 1)]
    while stack:
        i, j = stack.pop()
        if j - i < 2:
            continue
        inner = np.arange(i + 1, j)
        line = values[i] + (values[j] - values[i]) * (s[inner] - s[i]) / max(s[j] - s[i], 1e-12)
        miss = np.abs(values[inner] - line)
        k = int(np.argmax(miss))
        if miss[k] > tolerance:
            keep[inner[k]] = True
            stack += [(i, int(inner[k])), (int(inner[k]), j)]
    return np.flatnonzero(keep).astype(float)


def linear_records(s: Floats, values: Floats) -> list[tuple[float, float, float]]:
    """``(s, a, b)`` of the linear pieces of a profile sampled at stations ``s``, simplified
    to :data:`WIDTH_TOLERANCE_M`: ``value = a + b (s' - s)`` from each ``s`` on."""
    keep = simplified(s, values).astype(int)
    records = []
    for i, j in zip(keep[:-1], keep[1:], strict=True):
        slope = (values[j] - values[i]) / max(s[j] - s[i], 1e-12)
        records.append((float(s[i]), float(values[i]), float(slope)))
    return records or [(0.0, float(values[0]), 0.0)]


def stations(length: float, step: float = BOUNDARY_STEP_M / 2) -> Floats:
    """Evenly spaced ``s`` from 0 to ``length`` inclusive, no further apart than ``step``."""
    n = max(2, int(math.ceil(length / step)) + 1)
    return np.linspace(0.0, length, n)
