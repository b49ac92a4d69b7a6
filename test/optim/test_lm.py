"""Levenberg-Marquardt on classic problems with known solutions."""
from __future__ import annotations

import numpy as np
import pytest

from hand_tracker_ros.errors import ShapeError
from hand_tracker_ros.optim.lm import FitStatus, LMConfig, levenberg_marquardt


def rosenbrock(x, jacobian):
    r = np.array([10.0 * (x[1] - x[0] ** 2), 1.0 - x[0]])
    J = np.array([[-20.0 * x[0], 10.0], [-1.0, 0.0]]) if jacobian else None
    return r, J


def exponential_fit_problem(rng):
    t = np.linspace(0.0, 3.0, 40)
    truth = np.array([2.5, -1.3, 0.4])
    y = truth[0] * np.exp(truth[1] * t) + truth[2] + 1e-3 * rng.standard_normal(t.size)

    def fun(x, jacobian):
        e = np.exp(x[1] * t)
        r = x[0] * e + x[2] - y
        J = np.stack([e, x[0] * t * e, np.ones_like(t)], axis=1) if jacobian else None
        return r, J
    return fun, truth


UNBOUNDED = (np.full(3, -np.inf), np.full(3, np.inf))


def test_rosenbrock_reaches_the_minimum() -> None:
    res = levenberg_marquardt(rosenbrock, np.array([-1.2, 1.0]), np.full(2, -np.inf),
                              np.full(2, np.inf), config=LMConfig(max_iterations=200))
    assert res.success
    np.testing.assert_allclose(res.x, [1.0, 1.0], atol=1e-5)
    assert res.cost < 1e-10 < res.initial_cost


def test_exponential_fit_recovers_parameters() -> None:
    fun, truth = exponential_fit_problem(np.random.default_rng(0))
    res = levenberg_marquardt(fun, np.array([1.0, -0.5, 0.0]), *UNBOUNDED,
                              config=LMConfig(max_iterations=100))
    np.testing.assert_allclose(res.x, truth, atol=5e-3)


def test_bounds_hold_and_active_bound_is_found() -> None:
    fun, _ = exponential_fit_problem(np.random.default_rng(1))
    lower, upper = np.array([-10.0, -10.0, 0.5]), np.array([10.0, 10.0, 10.0])
    res = levenberg_marquardt(fun, np.array([1.0, -0.5, 1.0]), lower, upper,
                              config=LMConfig(max_iterations=100))
    assert np.all(res.x >= lower) and np.all(res.x <= upper)
    assert res.x[2] == pytest.approx(0.5)


def test_frozen_parameters_do_not_move() -> None:
    fun, _ = exponential_fit_problem(np.random.default_rng(2))
    x0 = np.array([1.0, -0.5, 0.0])
    res = levenberg_marquardt(fun, x0, *UNBOUNDED, free=np.array([True, True, False]))
    assert res.x[2] == 0.0 and res.cost < res.initial_cost


def test_divergence_guard_rejects_large_angular_steps() -> None:
    def far(x, jacobian):
        return x - 3.0, np.eye(2) if jacobian else None
    cfg = LMConfig(max_iterations=5, tau=1e-9, max_mean_step_rad=0.1)
    res = levenberg_marquardt(far, np.zeros(2), np.full(2, -9.0), np.full(2, 9.0), config=cfg,
                              angular=np.ones(2, bool))
    assert np.all(np.abs(res.x) <= 0.1 * 5 + 1e-9)
    free_run = levenberg_marquardt(far, np.zeros(2), np.full(2, -9.0), np.full(2, 9.0),
                                   config=cfg)
    np.testing.assert_allclose(free_run.x, [3.0, 3.0], atol=1e-6)


def test_non_finite_start_is_reported() -> None:
    def bad(x, jacobian):
        return np.array([np.nan]), np.ones((1, 1))
    res = levenberg_marquardt(bad, np.zeros(1), np.full(1, -1.0), np.full(1, 1.0))
    assert res.status == FitStatus.NON_FINITE and not res.success


def test_bad_bounds_are_rejected() -> None:
    with pytest.raises(ShapeError, match='`lower` must be'):
        levenberg_marquardt(rosenbrock, np.zeros(2), np.zeros(3), np.ones(2))
