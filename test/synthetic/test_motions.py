"""Scripted motions: within limits, smooth, deterministic, and actually moving."""
from __future__ import annotations

import numpy as np
import pytest

from hand_tracker_ros.errors import ConfigError
from hand_tracker_ros.model.layout import Layout
from hand_tracker_ros.model.skeleton import joint_limits
from hand_tracker_ros.synthetic.motions import ALL_MOTIONS, MOTIONS, trajectory


@pytest.mark.parametrize('name', ALL_MOTIONS)
def test_motion_is_within_limits_smooth_and_moving(name: str) -> None:
    thetas = trajectory(name, 90, 30.0, seed=3)
    lower, upper = joint_limits()
    assert thetas.shape == (90, Layout.P)
    assert np.all(thetas >= lower - 1e-12) and np.all(thetas <= upper + 1e-12)
    step = np.abs(np.diff(thetas[:, Layout.revolute], axis=0))
    assert step.max() < np.deg2rad(12.0)          # no jumps at 30 fps
    assert np.ptp(thetas, axis=0).max() > np.deg2rad(20.0)   # something moves a lot


def test_random_motion_is_deterministic_per_seed() -> None:
    a, b = trajectory('random', 60, 30.0, seed=7), trajectory('random', 60, 30.0, seed=7)
    np.testing.assert_array_equal(a, b)
    assert not np.allclose(a, trajectory('random', 60, 30.0, seed=8))


def test_unknown_motion_is_a_clear_error() -> None:
    with pytest.raises(ConfigError, match="unknown motion 'dance'"):
        trajectory('dance', 10, 30.0)


def test_calibration_motion_spreads_makes_a_fist_and_turns() -> None:
    thetas = np.rad2deg(trajectory('calibration', 90, 30.0))
    assert 'calibration' not in MOTIONS      # not in the benchmark or detector training set
    assert thetas[:, Layout.index('index_mcp_abd')].max() > 10.0
    assert thetas[:, Layout.index('pinky_mcp_abd')].min() < -12.0
    assert thetas[:, Layout.index('index_pip_flex')].max() > 80.0
    assert np.ptp(thetas[:, Layout.index('hand_ry')]) > 90.0
