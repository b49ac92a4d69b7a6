"""Tests of PinholeCamera (projection, Jacobian, rays, validation) and the transform helpers."""
from __future__ import annotations

import cv2
import numpy as np
import pytest

from hand_tracker_ros.errors import CalibrationError, ShapeError
from hand_tracker_ros.geometry.camera import PinholeCamera
from hand_tracker_ros.geometry.transforms import invert_T, look_at, make_T, transform_points

PLUMB_BOB = np.array([-0.12, 0.08, 0.0015, -0.001, -0.02])
RATIONAL = np.array([0.3, -0.1, 0.001, 0.0005, 0.02, 0.35, -0.08, 0.03])


@pytest.fixture
def rng() -> np.random.Generator:
    return np.random.default_rng(20261122)


def _camera(dist: np.ndarray = PLUMB_BOB, name: str = 'cam0') -> PinholeCamera:
    K = np.array([[310.0, 0.0, 158.3], [0.0, 305.0, 121.7], [0.0, 0.0, 1.0]])
    return PinholeCamera(name, 320, 240, K, dist, look_at((0.35, -0.25, 0.2), (0.01, 0.0, 0.0)))


def _points(rng: np.random.Generator, n: int = 200) -> np.ndarray:
    return rng.normal(scale=0.06, size=(n, 3))


@pytest.mark.parametrize('dist', [PLUMB_BOB, RATIONAL, np.zeros(5)],
                         ids=['plumb_bob', 'rational', 'none'])
def test_project_matches_cv2(rng, dist):
    cam = _camera(dist)
    X = _points(rng)
    uv, depth = cam.project(X)
    rvec, _ = cv2.Rodrigues(cam.R_cam_world)
    ref, _ = cv2.projectPoints(X, rvec, cam.T_cam_world[:3, 3], cam.K, dist)
    np.testing.assert_allclose(uv, ref.reshape(-1, 2), atol=1e-8)
    np.testing.assert_allclose(depth, transform_points(cam.T_cam_world, X)[:, 2], atol=1e-15)


@pytest.mark.parametrize('dist', [PLUMB_BOB, RATIONAL], ids=['plumb_bob', 'rational'])
def test_project_jacobian_matches_central_differences(rng, dist):
    cam = _camera(dist)
    X = _points(rng, 50)
    uv, depth, J = cam.project_jacobian(X)
    uv_ref, depth_ref = cam.project(X)
    np.testing.assert_allclose(uv, uv_ref, atol=1e-12)
    np.testing.assert_array_equal(depth, depth_ref)
    eps = 1e-6
    numeric = np.empty_like(J)
    for k in range(3):
        step = np.zeros(3)
        step[k] = eps
        numeric[:, :, k] = (cam.project(X + step)[0] - cam.project(X - step)[0]) / (2 * eps)
    np.testing.assert_allclose(J, numeric, rtol=1e-6, atol=1e-4)


def test_points_behind_camera_have_nan_pixels():
    cam = _camera()
    behind = cam.center_world - 0.1 * cam.R_cam_world[2]
    uv, depth = cam.project(np.stack([behind, np.zeros(3)]))
    assert depth[0] < 0 < depth[1]
    assert np.isnan(uv[0]).all() and np.isfinite(uv[1]).all()


@pytest.mark.parametrize('dist', [PLUMB_BOB, RATIONAL], ids=['plumb_bob', 'rational'])
def test_rays_round_trip(rng, dist):
    cam = _camera(dist)
    uv = rng.uniform((0.0, 0.0), (319.0, 239.0), size=(300, 2))
    origin, dirs = cam.rays(uv)
    np.testing.assert_allclose(origin, cam.center_world)
    np.testing.assert_allclose(np.linalg.norm(dirs, axis=1), 1.0, atol=1e-12)
    for s in (0.2, 0.9):
        uv_back, depth = cam.project(origin + s * dirs)
        assert (depth > 0).all()
        np.testing.assert_allclose(uv_back, uv, atol=1e-6)


def test_center_and_rotation():
    cam = _camera()
    np.testing.assert_allclose(transform_points(cam.T_cam_world, cam.center_world[None]), 0.0,
                               atol=1e-15)
    np.testing.assert_allclose(cam.R_cam_world @ cam.R_cam_world.T, np.eye(3), atol=1e-12)


def test_scaled_keeps_field_of_view(rng):
    cam = _camera(PLUMB_BOB)
    big = cam.scaled(640, 480)
    X = _points(rng)
    uv, _ = cam.project(X)
    uv_big, _ = big.project(X)
    np.testing.assert_allclose(uv_big + 0.5, 2.0 * (uv + 0.5), atol=1e-9)
    assert (big.width, big.height) == (640, 480)


def test_from_camera_info_models():
    T = np.eye(4)
    K9 = [300.0, 0.0, 160.0, 0.0, 300.0, 120.0, 0.0, 0.0, 1.0]
    cam = PinholeCamera.from_camera_info('c', 320, 240, K9, PLUMB_BOB, 'plumb_bob', T)
    assert cam.distortion_model == 'plumb_bob'
    cam = PinholeCamera.from_camera_info('c', 320, 240, K9, RATIONAL, 'rational_polynomial', T)
    assert cam.distortion_model == 'rational_polynomial'
    np.testing.assert_array_equal(cam.dist, RATIONAL)
    cam = PinholeCamera.from_camera_info('c', 320, 240, K9, [], 'plumb_bob', T)
    np.testing.assert_array_equal(cam.dist, np.zeros(5))
    with pytest.raises(CalibrationError, match="c: unsupported `distortion_model` 'equidistant'"):
        PinholeCamera.from_camera_info('c', 320, 240, K9, [0.0] * 4, 'equidistant', T)
    with pytest.raises(CalibrationError, match='c: `D` must have 8 numbers .* got 5'):
        PinholeCamera.from_camera_info('c', 320, 240, K9, PLUMB_BOB, 'rational_polynomial', T)
    with pytest.raises(CalibrationError, match='c: `K` must have 9 numbers, got 4'):
        PinholeCamera.from_camera_info('c', 320, 240, [1.0] * 4, PLUMB_BOB, 'plumb_bob', T)


def _K(**changes: float) -> np.ndarray:
    K = np.array([[300.0, 0.0, 160.0], [0.0, 300.0, 120.0], [0.0, 0.0, 1.0]])
    index = {'fx': (0, 0), 'skew': (0, 1), 'fy': (1, 1), 'k10': (1, 0), 'k22': (2, 2)}
    for key, value in changes.items():
        K[index[key]] = value
    return K


@pytest.mark.parametrize(('kwargs', 'pattern'), [
    ({'K': _K(fx=np.nan)}, 'c: `K` holds non-finite values'),
    ({'K': _K(k10=1.0)}, 'c: `K` must be upper triangular'),
    ({'K': _K(k22=2.0)}, 'c: `K` must be upper triangular'),
    ({'K': _K(fy=-300.0)}, 'c: `K` focal lengths must be positive'),
    ({'K': _K(skew=0.5)}, r'c: `K` skew K\[0, 1\] must be 0'),
    ({'K': np.eye(4)}, r'c: `K` must have shape \(3, 3\), got \(4, 4\)'),
    ({'dist': np.zeros(4)}, 'c: `dist` must have 5 .* or 8 .* numbers, got 4'),
    ({'dist': np.array([0.0, np.inf, 0, 0, 0])}, 'c: `dist` holds non-finite values'),
    ({'T_cam_world': np.diag([1.0, 1.0, 2.0, 1.0])}, 'c: `T_cam_world` is not a rigid'),
    ({'T_cam_world': np.diag([1.0, 1.0, -1.0, 1.0])}, 'c: `T_cam_world` is not a rigid'),
    ({'T_cam_world': np.eye(3)}, r'c: `T_cam_world` must have shape \(4, 4\)'),
    ({'width': 0}, 'c: `width` must be a positive integer, got 0'),
    ({'height': 2.5}, 'c: `height` must be a positive integer, got 2.5'),
    ({'name': ''}, '`name` must be a non-empty string'),
])
def test_invalid_calibration_is_rejected(kwargs, pattern):
    args = {'name': 'c', 'width': 320, 'height': 240, 'K': _K(), 'dist': np.zeros(5),
            'T_cam_world': np.eye(4)} | kwargs
    with pytest.raises(CalibrationError, match=pattern):
        PinholeCamera(**args)


def test_project_rejects_bad_shapes():
    cam = _camera()
    with pytest.raises(ShapeError, match=r'`points_world` must be \(\*, 3\), got \(4, 2\)'):
        cam.project(np.zeros((4, 2)))
    with pytest.raises(ShapeError, match='`uv_px` holds 1 non-finite'):
        cam.rays(np.array([[1.0, np.nan]]))


def test_transform_helpers(rng):
    R, _ = np.linalg.qr(rng.normal(size=(3, 3)))
    R *= np.sign(np.linalg.det(R))
    T = make_T(R, rng.normal(size=3))
    np.testing.assert_allclose(invert_T(T) @ T, np.eye(4), atol=1e-12)
    X = rng.normal(size=(10, 3))
    homogeneous = (T @ np.column_stack([X, np.ones(10)]).T).T[:, :3]
    np.testing.assert_allclose(transform_points(T, X), homogeneous, atol=1e-12)


def test_look_at_axes():
    target = np.array([0.02, -0.01, 0.03])
    T = look_at((0.4, 0.3, 0.25), target, up=(0.0, 0.0, 1.0))
    K = _K()
    cam = PinholeCamera('c', 320, 240, K, np.zeros(5), T)
    uv, _ = cam.project(np.stack([target, target + (0.0, 0.0, 0.05)]))
    np.testing.assert_allclose(uv[0], K[:2, 2], atol=1e-9)
    assert uv[1, 1] < uv[0, 1] - 10.0  # world up is image up (smaller row)
    with pytest.raises(CalibrationError, match='`up` is parallel'):
        look_at((0.0, 0.0, 1.0), (0.0, 0.0, 0.0))
    with pytest.raises(CalibrationError, match='coincide'):
        look_at((0.1, 0.0, 0.0), (0.1, 0.0, 0.0))
