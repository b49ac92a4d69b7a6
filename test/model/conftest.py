"""Shared fixtures of the hand-model tests."""
from __future__ import annotations

from collections.abc import Callable

import numpy as np
import pytest

from hand_tracker_ros.model.hand import HandModel


@pytest.fixture(scope='session')
def model() -> HandModel:
    return HandModel.build()


@pytest.fixture
def random_theta(model: HandModel) -> Callable[[np.random.Generator], np.ndarray]:
    """Draws a pose inside the joint limits, wrist near the origin, any orientation."""
    def draw(rng: np.random.Generator) -> np.ndarray:
        span = model.upper - model.lower
        theta = model.lower + rng.uniform(0.05, 0.95, span.size) * span
        theta[:3] = rng.normal(0.0, 0.2, 3)
        theta[3:6] = rng.uniform(-np.pi, np.pi, 3)
        return theta
    return draw


@pytest.fixture
def numeric_jacobian() -> Callable[..., np.ndarray]:
    """Central-difference Jacobian (..., P) of ``fn(theta) -> (...)``: the test oracle."""
    def jac(fn: Callable[[np.ndarray], np.ndarray], theta: np.ndarray,
            step: float = 1e-6) -> np.ndarray:
        cols = []
        for k in range(theta.size):
            e = np.zeros_like(theta)
            e[k] = step
            cols.append((fn(theta + e) - fn(theta - e)) / (2.0 * step))
        return np.stack(cols, axis=-1)
    return jac
