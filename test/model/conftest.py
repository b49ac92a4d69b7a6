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
