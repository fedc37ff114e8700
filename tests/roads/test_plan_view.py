"""Plan-view geometries against independent closed forms and numerical integration."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.integrate import quad

from scenweave.roads.plan_view import Arc, Line, ParametricCubic, PlanView, Spiral


def _integrated_clothoid(k0: float, rate: float, ds: float) -> tuple[float, float]:
    def heading(s: float) -> float:
        return k0 * s + rate * s * s / 2

    x, _ = quad(lambda s: math.cos(heading(s)), 0, ds, epsabs=1e-13, epsrel=1e-13, limit=200)
    y, _ = quad(lambda s: math.sin(heading(s)), 0, ds, epsabs=1e-13, epsrel=1e-13, limit=200)
    return x, y


def test_line_moves_along_its_heading():
    view = PlanView([Line(s=0, x=1.0, y=2.0, hdg=math.pi / 6, length=10)])
    pose = view.pose(10.0)
    assert pose.x[0] == pytest.approx(1.0 + 10 * math.cos(math.pi / 6), abs=1e-12)
    assert pose.y[0] == pytest.approx(2.0 + 10 * math.sin(math.pi / 6), abs=1e-12)


@pytest.mark.parametrize("curvature", [0.01, -0.05])
def test_arc_stays_on_its_circle(curvature):
    view = PlanView([Arc(s=0, x=3.0, y=-4.0, hdg=0.3, length=40, curvature=curvature)])
    radius = 1 / curvature
    centre = (3.0 - radius * math.sin(0.3), -4.0 + radius * math.cos(0.3))
    pose = view.pose(np.linspace(0, 40, 9))
    assert np.hypot(pose.x - centre[0], pose.y - centre[1]) == pytest.approx(abs(radius), abs=1e-9)
    assert pose.hdg[-1] == pytest.approx(0.3 + 40 * curvature, abs=1e-12)


@pytest.mark.parametrize(("k0", "k1", "length"), [
    (0.0, 0.02, 60.0), (0.01, -0.03, 80.0), (-0.004, -0.001, 150.0), (0.02, 0.02 + 1e-9, 30.0),
])
def test_spiral_matches_numerical_integration(k0, k1, length):
    spiral = Spiral(s=0, x=0, y=0, hdg=0, length=length, curv_start=k0, curv_end=k1)
    for ds in (length / 3, length):
        local = spiral.local(np.array([ds]))
        x, y = _integrated_clothoid(k0, (k1 - k0) / length, ds)
        assert local.u[0] == pytest.approx(x, abs=1e-7)
        assert local.v[0] == pytest.approx(y, abs=1e-7)
        assert local.curvature[0] == pytest.approx(k0 + (k1 - k0) * ds / length, abs=1e-12)


def test_poly3_straight_line_at_an_angle_is_measured_along_the_curve():
    # v = 0.5 u: a straight line at atan(0.5); s is distance along it, not along u
    curve = ParametricCubic(s=0, x=0, y=0, hdg=0, length=20, coeff_u=(0, 1, 0, 0),
                            coeff_v=(0, 0.5, 0, 0))
    local = curve.local(np.array([20.0]))
    angle = math.atan(0.5)
    assert local.u[0] == pytest.approx(20 * math.cos(angle), abs=1e-9)
    assert local.v[0] == pytest.approx(20 * math.sin(angle), abs=1e-9)
    assert local.theta[0] == pytest.approx(angle, abs=1e-12)


@pytest.mark.parametrize("normalized", [True, False])
def test_param_poly3_points_are_arc_length_apart(normalized):
    length = 30.0
    scale = 1.0 if normalized else 1.0 / length  # same shape in both parametrisations
    coeff_u = (0.0, 30.0 * scale, 0.0, 0.0)
    coeff_v = (0.0, 0.0, 8.0 * scale**2, -2.0 * scale**3)
    # the curve's true length, measured on a fine polyline of the parameter
    p = np.linspace(0, 1.0 if normalized else length, 200001)
    u = coeff_u[1] * p
    v = coeff_v[2] * p**2 + coeff_v[3] * p**3
    true_length = float(np.hypot(np.diff(u), np.diff(v)).sum())
    curve = ParametricCubic(s=0, x=0, y=0, hdg=0, length=true_length, coeff_u=coeff_u,
                            coeff_v=coeff_v, p_end=1.0 if normalized else length)
    ds = np.linspace(0, true_length, 301)
    local = curve.local(ds)
    steps = np.hypot(np.diff(local.u), np.diff(local.v))
    assert steps.sum() == pytest.approx(true_length, abs=1e-3)
    assert local.u[-1] == pytest.approx(u[-1], abs=1e-6)
    assert local.v[-1] == pytest.approx(v[-1], abs=1e-6)


def test_geometry_chain_picks_the_geometry_holding_s():
    view = PlanView([Line(s=0, x=0, y=0, hdg=0, length=10),
                     Arc(s=10, x=10, y=0, hdg=0, length=5, curvature=0.1)])
    pose = view.pose(np.array([5.0, 12.0]))
    assert pose.curvature.tolist() == [0.0, 0.1]
    assert pose.x[0] == pytest.approx(5.0)
