"""Test-wide setup: an isolated ROS domain per test session and our DDS profile."""
from __future__ import annotations

import os
from collections.abc import Callable

import numpy as np
import pytest

# Each pytest session gets its own DDS domain so that concurrent runs on one machine (other
# developers, CI) never see each other's nodes and topics. Under `pytest -n N` (xdist) each
# worker is a process of its own and picks its own domain: the one it inherits from the
# controller would make the workers' tests hear each other's topics.
if 'PYTEST_XDIST_WORKER' in os.environ:
    os.environ['ROS_DOMAIN_ID'] = str(20 + os.getpid() % 180)
else:
    os.environ.setdefault('ROS_DOMAIN_ID', str(20 + os.getpid() % 180))
os.environ.setdefault('ROS_AUTOMATIC_DISCOVERY_RANGE', 'LOCALHOST')


def pytest_configure(config: pytest.Config) -> None:
    config.addinivalue_line('markers', 'slow: takes more than a few seconds')
    config.addinivalue_line('markers', 'ros: needs the built workspace (source .ws/env.sh)')
    from hand_tracker_ros.ros_env import apply_ros_defaults
    apply_ros_defaults()


@pytest.fixture(scope='session')
def hand_model():
    """The default hand model, built once per session."""
    from hand_tracker_ros.model.hand import HandModel

    return HandModel.build()


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
