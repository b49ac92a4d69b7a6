"""The joint-limit term L: Euler split, zero inside the limits, LM back to a limit, Jacobian."""
from __future__ import annotations

import numpy as np
import pytest

from hand_tracker_ros.core.context import RoundContext
from hand_tracker_ros.core.observations import FrameObservations
from hand_tracker_ros.energies.joint_limits import (
    JointLimitsConfig,
    JointLimitsEnergy,
    fit_plane_normal,
    local_angles,
    local_rotation,
)
from hand_tracker_ros.errors import ConfigError
from hand_tracker_ros.geometry.rotations import rot_x, rot_y, rot_z
from hand_tracker_ros.model.layout import Layout, P
from hand_tracker_ros.model.skeleton import joint_limits
from hand_tracker_ros.optim.lm import LMConfig, levenberg_marquardt

DEG = np.pi / 180.0
# The tracker may run LM with bounds wider than the anatomical table: this term holds them.
WIDE_LO = np.concatenate([np.full(3, -5.0), np.full(P - 3, -np.pi)])
WIDE_HI = -WIDE_LO


@pytest.fixture(scope='module')
def energy(hand_model):
    return JointLimitsEnergy.from_model(JointLimitsConfig(), hand_model)


def inside_pose(hand_model, rng, shrink=0.05):
    """A random pose strictly inside the joint table, any global pose."""
    lo, hi = joint_limits()
    theta = lo + rng.uniform(shrink, 1.0 - shrink, P) * (hi - lo)
    theta[:3] = rng.normal(0.0, 0.2, 3)
    theta[3:6] = rng.uniform(-1.2, 1.2, 3)
    return theta


def numeric_jacobian(fn, theta, step=1e-6):
    """Central differences (M, P): the oracle."""
    cols = [(fn(theta + e) - fn(theta - e)) / (2.0 * step) for e in np.eye(theta.size) * step]
    return np.stack(cols, axis=-1)


def set_deg(theta, **angles):
    out = theta.copy()
    for name, value in angles.items():
        out[Layout.index(name)] = value * DEG
    return out


def solve(hand_model, energy, theta0, iterations=30):
    """LM on L alone, correspondences of the start pose held fixed (one round)."""
    corr = energy.targets(hand_model.pose(theta0))

    def fun(x, jacobian):
        posed = hand_model.pose(x, jacobian=jacobian)
        if jacobian:
            return energy.linearize(posed, corr)
        return energy.residuals(posed, corr), None
    result = levenberg_marquardt(fun, theta0, WIDE_LO, WIDE_HI,
                                 config=LMConfig(max_iterations=iterations))
    return corr, result


def test_local_angles_recover_known_angles_with_twist() -> None:
    rng = np.random.default_rng(3)
    for _ in range(20):
        flex, abd, twist = rng.uniform([-2.5, -1.4, -3.0], [2.5, 1.4, 3.0])
        q = local_rotation(flex, abd, twist)
        # The seed's x-z-y order, on Q^T, with the twist innermost.
        np.testing.assert_allclose(q.T, rot_x(-flex) @ rot_z(abd) @ rot_y(twist), atol=1e-12)
        np.testing.assert_allclose(local_angles(q), (flex, abd, twist), atol=1e-9)


def test_local_angles_of_the_model_joint_have_no_twist() -> None:
    # The model's base joint Rz(-abd) Rx(flex) reads back its own angles, twist 0.
    flex, abd = 70.0 * DEG, 60.0 * DEG
    np.testing.assert_allclose(local_angles(rot_z(-abd) @ rot_x(flex)), (flex, abd, 0.0),
                               atol=1e-12)


def test_measure_reads_the_pose_angles(hand_model, energy) -> None:
    theta = inside_pose(hand_model, np.random.default_rng(0))
    angles = energy.measure(hand_model.pose(theta, jacobian=False))
    k0 = 6 + 4 * np.arange(5)
    np.testing.assert_allclose(angles.base_flex, theta[k0], atol=1e-9)
    np.testing.assert_allclose(angles.base_abd, theta[k0 + 1], atol=1e-9)
    np.testing.assert_allclose(angles.base_twist, 0.0, atol=1e-9)
    np.testing.assert_allclose(angles.upper, np.stack([theta[k0 + 2], theta[k0 + 3]], 1),
                               atol=1e-9)


def test_no_residuals_inside_the_limits(hand_model, energy) -> None:
    rng = np.random.default_rng(1)
    for _ in range(10):
        posed = hand_model.pose(inside_pose(hand_model, rng, shrink=0.01))
        corr = energy.correspond(RoundContext(posed, (), FrameObservations(0, ()), None))
        r, J = energy.linearize(posed, corr)
        assert corr.n_residuals == 0 and corr.labels == ()
        assert r.shape == (0,) and J.shape == (0, P)
        assert energy.residuals(posed, corr).shape == (0,)


def test_straight_finger_at_its_lower_limit_is_inside(hand_model, energy) -> None:
    # PIP = 0 is the lower limit; a straight finger (collinear joints) must not activate.
    posed = hand_model.pose(np.zeros(P), jacobian=False)
    assert energy.targets(posed).n_residuals == 0


@pytest.mark.parametrize(('name', 'value_deg', 'limit_deg', 'label'), [
    ('index_mcp_flex', 120.0, 90.0, 'index_mcp'),
    ('ring_mcp_abd', -35.0, -15.0, 'ring_mcp'),
    ('thumb_cmc_flex', -55.0, -30.0, 'thumb_cmc'),
    ('middle_pip_flex', 140.0, 110.0, 'middle_pip'),
    ('pinky_dip_flex', -30.0, -10.0, 'pinky_dip'),
    ('thumb_ip_flex', 100.0, 80.0, 'thumb_ip'),
])
def test_lm_brings_a_violated_joint_back_to_its_limit(hand_model, energy, name, value_deg,
                                                      limit_deg, label) -> None:
    theta0 = set_deg(hand_model.neutral_theta((0.1, -0.05, 0.5)), **{name: value_deg})
    theta0[3:6] = (0.4, -0.7, 0.9)
    corr, result = solve(hand_model, energy, theta0)
    assert corr.labels == (label,)
    r0 = energy.residuals(hand_model.pose(theta0, jacobian=False), corr)
    assert np.linalg.norm(r0) > 1e-3                     # metres: several mm off the limit
    assert result.cost < 1e-6 * result.initial_cost
    k = Layout.index(name)
    assert result.x[k] == pytest.approx(limit_deg * DEG, abs=0.2 * DEG)
    # The residual depends on the joint angles only: the global pose and the other fingers
    # have zero Jacobian columns (up to rounding) and stay put.
    others = np.ones(P, dtype=bool)
    others[Layout.per_finger[label.split('_')[0]]] = False
    np.testing.assert_allclose(result.x[others], theta0[others], atol=1e-4)


def test_cost_decreases_monotonically_under_lm(hand_model, energy) -> None:
    theta0 = set_deg(hand_model.neutral_theta(), index_mcp_flex=60.0, index_mcp_abd=25.0)
    corr = energy.targets(hand_model.pose(theta0))
    costs, theta = [], theta0
    for iterations in (1, 2, 4, 8):
        _, result = solve(hand_model, energy, theta0, iterations)
        costs.append(result.cost)
        theta = result.x
    assert corr.labels == ('index_mcp',)
    assert costs[0] > 0.0
    assert all(b <= a for a, b in zip(costs, costs[1:])) and costs[-1] < 1e-6 * costs[0]
    assert theta[Layout.index('index_mcp_flex')] == pytest.approx(60.0 * DEG, abs=0.2 * DEG)
    assert theta[Layout.index('index_mcp_abd')] == pytest.approx(15.0 * DEG, abs=0.2 * DEG)


def test_plane_to_palm_limit(hand_model) -> None:
    config = JointLimitsConfig(bases=False, thumb_plane_palm_deg=(30.0, 85.0))
    energy = JointLimitsEnergy.from_model(config, hand_model)
    theta0 = set_deg(hand_model.neutral_theta(), thumb_cmc_abd=60.0)
    before = energy.measure(hand_model.pose(theta0, jacobian=False)).elevation[0]
    corr, result = solve(hand_model, energy, theta0)
    assert before < 30.0 * DEG
    assert corr.labels == ('thumb_plane_metacarpal', 'thumb_plane_proximal',
                           'thumb_plane_distal')
    after = energy.measure(hand_model.pose(result.x, jacobian=False)).elevation[0]
    assert after == pytest.approx(30.0 * DEG, abs=0.3 * DEG)


def test_margin_widens_or_narrows_the_limits(hand_model, energy) -> None:
    beyond = hand_model.pose(set_deg(hand_model.neutral_theta(), index_mcp_flex=120.0),
                             jacobian=False)
    near = hand_model.pose(set_deg(hand_model.neutral_theta(), index_mcp_flex=87.0),
                           jacobian=False)
    wide = JointLimitsEnergy.from_model(JointLimitsConfig(margin_deg=35.0), hand_model)
    narrow = JointLimitsEnergy.from_model(JointLimitsConfig(margin_deg=-5.0), hand_model)
    assert energy.targets(beyond).labels == ('index_mcp',)
    assert wide.targets(beyond).n_residuals == 0
    assert energy.targets(near).n_residuals == 0
    assert narrow.targets(near).labels == ('index_mcp',)


def test_jacobian_matches_central_differences(hand_model, energy) -> None:
    theta = set_deg(inside_pose(hand_model, np.random.default_rng(7)), index_mcp_flex=115.0,
                    middle_mcp_abd=22.0, ring_pip_flex=125.0, pinky_dip_flex=-25.0,
                    thumb_cmc_abd=88.0, thumb_mcp_flex=70.0)
    corr = energy.targets(hand_model.pose(theta))
    assert {'index_mcp', 'middle_mcp', 'ring_pip', 'pinky_dip', 'thumb_cmc', 'thumb_mcp',
            'thumb_plane_distal'} <= set(corr.labels)
    # Evaluate away from the start pose so that the residuals are not zero-mean noise.
    theta = theta + np.random.default_rng(8).normal(0.0, 0.05, P)
    r, J = energy.linearize(hand_model.pose(theta), corr)
    np.testing.assert_allclose(r, energy.residuals(hand_model.pose(theta, jacobian=False),
                                                   corr), atol=1e-15)
    numeric = numeric_jacobian(
        lambda x: energy.residuals(hand_model.pose(x, jacobian=False), corr), theta)
    assert r.shape == (corr.n_residuals,) and np.abs(J).max() > 1e-2
    assert np.abs(J[:, :6]).max() < 1e-12            # residuals in the parent frames
    np.testing.assert_allclose(J, numeric, rtol=1e-5, atol=1e-9)


def test_fit_plane_normal() -> None:
    rng = np.random.default_rng(4)
    normal = rng.normal(size=3)
    normal /= np.linalg.norm(normal)
    basis = np.linalg.svd(normal[None])[2][1:]                  # two in-plane directions
    points = rng.normal(size=(4, 2)) @ basis + 0.3
    fit = fit_plane_normal(points, -normal, 1e-3)
    np.testing.assert_allclose(fit, -normal, atol=1e-12)        # oriented like the fallback
    line = np.outer(np.arange(4.0), basis[0])
    np.testing.assert_array_equal(fit_plane_normal(line, normal, 1e-3), normal)


def test_inverted_plane_range_is_rejected(hand_model) -> None:
    with pytest.raises(ConfigError, match='plane_palm_deg'):
        JointLimitsEnergy.from_model(JointLimitsConfig(plane_palm_deg=(10.0, -10.0)),
                                     hand_model)
