"""The temporal prior T: prediction, empty without history, Jacobian, LM reaches the prediction."""
from __future__ import annotations

import numpy as np
import pytest

from hand_tracker_ros.config import from_mapping
from hand_tracker_ros.core.context import PreviousFrame, RoundContext
from hand_tracker_ros.core.observations import FrameObservations
from hand_tracker_ros.energies.temporal import TemporalConfig, TemporalEnergy
from hand_tracker_ros.errors import ConfigError, ShapeError
from hand_tracker_ros.model.layout import P
from hand_tracker_ros.optim.lm import LMConfig, levenberg_marquardt


@pytest.fixture(scope='module')
def energy(hand_model):
    return TemporalEnergy.from_model(TemporalConfig(), hand_model)


def context(hand_model, theta, thetas):
    previous = None if thetas is None else PreviousFrame(
        hand_model.pose(thetas[-1], jacobian=False), (), np.asarray(thetas))
    return RoundContext(hand_model.pose(theta), (), FrameObservations(0, ()), previous)


def history(hand_model, rng):
    """Two consecutive estimates: a random pose and a small motion of it."""
    older = hand_model.neutral_theta((0.02, -0.01, 0.45))
    older[3:6] = rng.uniform(-1.0, 1.0, 3)
    newer = older + rng.normal(0.0, 0.03, P)
    return np.stack([older, newer])


def test_no_previous_frame_gives_no_residuals(hand_model, energy) -> None:
    ctx = context(hand_model, hand_model.neutral_theta(), None)
    corr = energy.correspond(ctx)
    r, J = energy.linearize(ctx.posed, corr)
    assert corr.n_residuals == 0 and r.shape == (0,) and J.shape == (0, P)
    assert energy.residuals(ctx.posed, corr).shape == (0,)


def test_predictions(hand_model, energy) -> None:
    thetas = history(hand_model, np.random.default_rng(0))
    k_old, k_new = (hand_model.pose(t, jacobian=False).keypoints_m for t in thetas)
    velocity = energy.correspond(context(hand_model, thetas[-1], thetas)).keypoints_m
    np.testing.assert_allclose(velocity, 2.0 * k_new - k_old, atol=1e-12)
    single = energy.correspond(context(hand_model, thetas[-1], thetas[-1:])).keypoints_m
    np.testing.assert_allclose(single, k_new, atol=1e-12)
    damping = TemporalEnergy.from_model(TemporalConfig(mode='damping'), hand_model)
    np.testing.assert_allclose(damping.predict(thetas).keypoints_m, k_new, atol=1e-12)
    assert np.abs(k_new - k_old).max() > 1e-3              # the two modes really differ


def test_residuals_are_keypoint_offsets_in_metres(hand_model, energy) -> None:
    thetas = history(hand_model, np.random.default_rng(1))
    ctx = context(hand_model, thetas[-1], thetas[-1:])
    shifted = thetas[-1].copy()
    shifted[0] += 0.01                                       # 1 cm along x
    r = energy.residuals(hand_model.pose(shifted, jacobian=False), energy.correspond(ctx))
    np.testing.assert_allclose(r.reshape(21, 3), np.tile([0.01, 0.0, 0.0], (21, 1)),
                               atol=1e-12)


def test_jacobian_matches_central_differences(hand_model, energy) -> None:
    rng = np.random.default_rng(2)
    thetas = history(hand_model, rng)
    corr = energy.correspond(context(hand_model, thetas[-1], thetas))
    theta = thetas[-1] + rng.normal(0.0, 0.05, P)
    r, J = energy.linearize(hand_model.pose(theta), corr)
    assert r.shape == (63,) and J.shape == (63, P)

    def fun(x):
        return energy.residuals(hand_model.pose(x, jacobian=False), corr)
    step = 1e-6
    numeric = np.stack([(fun(theta + e) - fun(theta - e)) / (2.0 * step)
                        for e in np.eye(P) * step], axis=-1)
    np.testing.assert_allclose(r, fun(theta), atol=1e-15)
    np.testing.assert_allclose(J, numeric, rtol=1e-5, atol=1e-9)


@pytest.mark.parametrize('mode', ['constant_velocity', 'damping'])
def test_minimiser_of_the_prior_alone_is_the_prediction(hand_model, mode) -> None:
    energy = TemporalEnergy.from_model(TemporalConfig(mode=mode), hand_model)
    rng = np.random.default_rng(3)
    thetas = history(hand_model, rng)
    # A pure translation between the frames makes the extrapolation reachable by a pose.
    thetas[-1] = thetas[0]
    thetas[-1, :3] += (0.01, -0.005, 0.02)
    expected = thetas[-1].copy()
    if mode == 'constant_velocity':
        expected[:3] += thetas[-1, :3] - thetas[0, :3]
    corr = energy.correspond(context(hand_model, thetas[-1], thetas))
    start = thetas[-1] + rng.normal(0.0, 0.1, P)

    def fun(x, jacobian):
        posed = hand_model.pose(x, jacobian=jacobian)
        if jacobian:
            return energy.linearize(posed, corr)
        return energy.residuals(posed, corr), None
    result = levenberg_marquardt(fun, start, np.full(P, -10.0), np.full(P, 10.0),
                                 config=LMConfig(max_iterations=50, ftol=0.0, xtol=1e-12))
    np.testing.assert_allclose(hand_model.pose(result.x, jacobian=False).keypoints_m,
                               corr.keypoints_m, atol=1e-7)
    np.testing.assert_allclose(result.x, expected, atol=1e-5)
    assert result.initial_cost > 1e-4


def test_bad_history_and_mode(energy) -> None:
    with pytest.raises(ShapeError):
        energy.predict(np.zeros((2, P - 1)))
    with pytest.raises(ConfigError, match='mode'):
        from_mapping(TemporalConfig, {'mode': 'linear'})
    assert energy.predict(np.zeros((0, P))).n_residuals == 0
