"""The calibration's shape model: keypoints exact, Jacobians against central differences."""
from __future__ import annotations

import numpy as np
import pytest

from hand_tracker_ros.model import kinematics
from hand_tracker_ros.model.hand import HandModel
from hand_tracker_ros.model.shape import HandShape
from hand_tracker_ros.model.shape_jacobian import ShapeRig

X0 = HandShape(scale=1.05, palm_width_m=0.058, radius_scale=0.95).to_vector()


def _pose(model: HandModel, seed: int) -> np.ndarray:
    rng = np.random.default_rng(seed)
    theta = model.neutral_theta((0.01, -0.02, 0.3))
    theta[3:] += rng.uniform(-0.3, 0.3, theta.size - 3)
    return np.clip(theta, model.lower, model.upper)


@pytest.fixture(scope='module')
def model() -> HandModel:
    return HandModel.build(HandShape.from_vector(X0))


def _moved_shape(seed: int) -> np.ndarray:
    return X0 * (1.0 + np.random.default_rng(seed).uniform(-0.08, 0.08, X0.size))


def test_keypoints_equal_those_of_the_model_built_at_the_new_shape(model: HandModel) -> None:
    theta = _pose(model, 1)
    x = _moved_shape(2)
    posed = model.pose(theta, jacobian=False)
    moved = ShapeRig.keypoints(model).displace(posed._fk, x)
    other = HandModel.build(HandShape.from_vector(x)).pose(theta, jacobian=False)
    np.testing.assert_allclose(posed.keypoints_m + moved.displacement_m, other.keypoints_m,
                               atol=1e-12)


def test_zero_displacement_at_the_model_shape(model: HandModel) -> None:
    posed = model.pose(_pose(model, 3), jacobian=False)
    moved = ShapeRig.vertices(model).displace(posed._fk, X0)
    assert np.abs(moved.displacement_m).max() < 1e-15
    assert np.abs(moved.pose_jac).max() < 1e-15


@pytest.mark.parametrize('rig_of', [ShapeRig.vertices, ShapeRig.keypoints],
                         ids=['vertices', 'keypoints'])
def test_jacobians_match_central_differences(model: HandModel, rig_of) -> None:
    rig = rig_of(model)
    theta, x = _pose(model, 4), _moved_shape(5)

    def disp(th: np.ndarray, xx: np.ndarray) -> np.ndarray:
        return rig.displace(kinematics.forward_kinematics(model.rest, th), xx).displacement_m

    got = rig.displace(kinematics.forward_kinematics(model.rest, theta), x)
    h = 1e-6
    for j in range(x.size):
        step = np.zeros(x.size)
        step[j] = h * max(1.0, abs(x[j]))
        num = (disp(theta, x + step) - disp(theta, x - step)) / (2 * step[j])
        np.testing.assert_allclose(got.shape_jac[:, :, j], num, atol=1e-8, err_msg=f'x[{j}]')
    for k in range(theta.size):
        step = np.zeros(theta.size)
        step[k] = h
        num = (disp(theta + step, x) - disp(theta - step, x)) / (2 * h)
        np.testing.assert_allclose(got.pose_jac[:, :, k], num, atol=1e-8, err_msg=f'theta[{k}]')
