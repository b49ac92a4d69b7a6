"""Cone distance field (Ballan 2012 supplementary Eqs. 1-3): branch values and gradients."""
from __future__ import annotations

import numpy as np
import pytest

from hand_tracker_ros.energies import cone_field as cf

# Equilateral triangle in z = 0 centred at the origin, circumradius 1, normal +z.
_TRI = np.array([[1.0, 0.0, 0.0], [-0.5, np.sqrt(3) / 2, 0.0], [-0.5, -np.sqrt(3) / 2, 0.0]])


def _eval(points: list[list[float]], sigma: float
          ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    pts = np.asarray(points, dtype=float)
    geom = cf.cone_geometry(pts, np.repeat(_TRI[None], len(pts), axis=0))
    return (cf.phi(geom, sigma), cf.upsilon(geom.height, sigma), cf.psi(geom, sigma),
            cf.residual(geom, sigma))


def test_cone_frame_of_equilateral_triangle() -> None:
    geom = cf.cone_geometry(np.zeros((1, 3)), _TRI[None])
    np.testing.assert_allclose(geom.origin[0], [0, 0, 0], atol=1e-15)
    np.testing.assert_allclose(geom.normal[0], [0, 0, 1])
    np.testing.assert_allclose(geom.radius[0], 1.0)


def test_inside_cone_middle_branch_hand_computed() -> None:
    # x = -0.2, s = 0.3, D = 1 * (1 + 0.4) = 1.4; sigma = 0.5 -> Upsilon = 0.2 + 0.5 = 0.7.
    ph, up, ps, rho = _eval([[0.3, 0.0, -0.2]], 0.5)
    np.testing.assert_allclose(ph, [0.3 / 1.4])
    np.testing.assert_allclose(up, [0.7])
    np.testing.assert_allclose(rho, [(1 - 0.3 / 1.4) * 0.7])
    np.testing.assert_allclose(ps, [0.55 ** 2])


def test_deep_inside_linear_branch_hand_computed() -> None:
    # x = -1 <= -sigma, s = 0.5, D = 3, Phi = 1/6, Upsilon = 1 + 1 - 0.5 = 1.5.
    ph, up, ps, _ = _eval([[0.0, 0.5, -1.0]], 0.5)
    np.testing.assert_allclose(ph, [1 / 6])
    np.testing.assert_allclose(up, [1.5])
    np.testing.assert_allclose(ps, [(5 / 6 * 1.5) ** 2])


def test_apex_and_beyond_are_outside() -> None:
    # x = sigma: denominator 0 (apex); x > sigma: negative denominator. Both Psi = 0.
    ph, up, ps, rho = _eval([[0.0, 0.0, 0.5], [0.0, 0.0, 0.7], [0.01, 0.0, 0.9]], 0.5)
    assert np.all(np.isinf(ph))
    np.testing.assert_array_equal(up, [0.0, 0.0, 0.0])
    np.testing.assert_array_equal(ps, [0.0, 0.0, 0.0])
    np.testing.assert_array_equal(rho, [0.0, 0.0, 0.0])


def test_cone_boundary_is_continuous() -> None:
    # x = 0.25: D = 0.5; s = 0.5 is exactly on the mantle (Phi = 1).
    eps = 1e-9
    ph, _, ps, _ = _eval([[0.5, 0.0, 0.25], [0.5 - eps, 0.0, 0.25], [0.5 + eps, 0.0, 0.25]],
                         0.5)
    np.testing.assert_allclose(ph[0], 1.0)
    assert ps[0] == 0.0
    assert 0.0 < ps[1] < 1e-15
    assert ps[2] == 0.0


def test_outside_laterally_is_zero() -> None:
    # x = -0.2: D = 1.4 < s = 1.5.
    ph, up, ps, _ = _eval([[0.0, 1.5, -0.2]], 0.5)
    np.testing.assert_allclose(ph, [1.5 / 1.4])
    assert up[0] > 0.0
    assert ps[0] == 0.0


def test_upsilon_branches_hand_computed_sigma_03() -> None:
    # sigma = 0.3: quadratic -10/9 x^2 - 5/3 x + 0.6 on [-0.3, 0.3].
    x = np.array([-0.5, -0.3, 0.1, 0.3, 0.6])
    expected = [1.2, 1.0, -10 / 9 * 0.01 - 5 / 3 * 0.1 + 0.6, 0.0, 0.0]
    np.testing.assert_allclose(cf.upsilon(x, 0.3), expected, atol=1e-15)


@pytest.mark.parametrize('sigma', [0.2, 0.3, 0.5, 0.8])
def test_upsilon_continuity_and_values_at_pm_sigma(sigma: float) -> None:
    eps = 1e-9
    x = np.array([-sigma - eps, -sigma, -sigma + eps, sigma - eps, sigma, sigma + eps])
    u = cf.upsilon(x, sigma)
    np.testing.assert_allclose(u[:3], 1.0, atol=1e-8)
    np.testing.assert_allclose(u[3:], 0.0, atol=1e-8)
    # C1 at -sigma: both branches have slope -1 there.
    np.testing.assert_allclose(cf.upsilon_derivative(np.array([-sigma - eps, -sigma + eps]),
                                                     sigma), [-1.0, -1.0], atol=1e-7)


@pytest.mark.parametrize('sigma', [0.3, 0.5])
def test_upsilon_derivative_matches_central_difference(sigma: float) -> None:
    x = np.array([-1.3, -0.7, -0.2, 0.0, 0.1, 0.25, 0.9])
    h = 1e-6
    numeric = (cf.upsilon(x + h, sigma) - cf.upsilon(x - h, sigma)) / (2 * h)
    np.testing.assert_allclose(cf.upsilon_derivative(x, sigma), numeric, atol=1e-8)


def _random_inside_cases(rng: np.random.Generator, n: int, sigma: float
                         ) -> tuple[np.ndarray, np.ndarray]:
    """Random triangles and points strictly inside their cones, away from every kink."""
    tris, pts = [], []
    while len(pts) < n:
        tri = rng.normal(size=(3, 3))
        pt = tri.mean(axis=0) + rng.normal(scale=0.8, size=3)
        geom = cf.cone_geometry(pt[None], tri[None])
        ph = cf.phi(geom, sigma)[0]
        x = geom.height[0]
        ok = (ph < 0.95 and geom.axial[0] > 1e-3 and min(abs(x - sigma), abs(x + sigma)) > 1e-3
              and geom.cross_norm[0] > 0.1)
        spokes = np.sort(np.linalg.norm(tri - tri.mean(axis=0), axis=1))
        if ok and spokes[2] - spokes[1] > 1e-3:
            tris.append(tri)
            pts.append(pt)
    return np.array(pts), np.array(tris)


@pytest.mark.parametrize('sigma', [0.3, 0.5])
def test_gradients_match_central_differences(sigma: float) -> None:
    pts, tris = _random_inside_cases(np.random.default_rng(7), 40, sigma)
    rho, d_pt, d_tri = cf.residual_and_gradients(pts, tris, sigma)
    assert np.all(rho > 0.0)
    h = 1e-6
    num_pt = np.zeros_like(d_pt)
    num_tri = np.zeros_like(d_tri)
    for a in range(3):
        step = np.zeros(3)
        step[a] = h
        plus = cf.residual(cf.cone_geometry(pts + step, tris), sigma)
        minus = cf.residual(cf.cone_geometry(pts - step, tris), sigma)
        num_pt[:, a] = (plus - minus) / (2 * h)
        for k in range(3):
            t_plus, t_minus = tris.copy(), tris.copy()
            t_plus[:, k, a] += h
            t_minus[:, k, a] -= h
            plus = cf.residual(cf.cone_geometry(pts, t_plus), sigma)
            minus = cf.residual(cf.cone_geometry(pts, t_minus), sigma)
            num_tri[:, k, a] = (plus - minus) / (2 * h)
    np.testing.assert_allclose(d_pt, num_pt, rtol=1e-5, atol=1e-7)
    np.testing.assert_allclose(d_tri, num_tri, rtol=1e-5, atol=1e-7)


def test_gradients_vanish_outside_and_rho_matches_residual() -> None:
    pts = np.array([[0.0, 0.0, 0.9], [0.0, 2.0, -0.1], [0.2, 0.1, -0.3]])
    tris = np.repeat(_TRI[None], 3, axis=0)
    rho, d_pt, d_tri = cf.residual_and_gradients(pts, tris, 0.5)
    np.testing.assert_allclose(rho, cf.residual(cf.cone_geometry(pts, tris), 0.5))
    np.testing.assert_array_equal(d_pt[:2], 0.0)
    np.testing.assert_array_equal(d_tri[:2], 0.0)
    assert np.abs(d_pt[2]).sum() > 0.0


def test_zero_area_receiver_has_no_cone() -> None:
    flat = np.array([[[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [2.0, 0.0, 0.0]]])
    pts = np.array([[1.0, 0.1, -0.1]])
    geom = cf.cone_geometry(pts, flat)
    assert np.isinf(cf.phi(geom, 0.5)[0]) and cf.psi(geom, 0.5)[0] == 0.0
    rho, d_pt, d_tri = cf.residual_and_gradients(pts, flat, 0.5)
    assert rho[0] == 0.0 and not d_pt.any() and not d_tri.any()
