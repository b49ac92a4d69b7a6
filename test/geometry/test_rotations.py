"""Round trips and identities of hand_tracker_ros.geometry.rotations."""
from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from hand_tracker_ros.geometry import rotations as rot


@pytest.fixture
def rng() -> np.random.Generator:
    return np.random.default_rng(7)


def test_axis_rotations_match_scipy() -> None:
    for fn, axis in ((rot.rot_x, 'x'), (rot.rot_y, 'y'), (rot.rot_z, 'z')):
        np.testing.assert_allclose(fn(0.7), Rotation.from_euler(axis, 0.7).as_matrix(),
                                   atol=1e-14)


def test_skew_is_cross_product(rng: np.random.Generator) -> None:
    v, w = rng.normal(size=(2, 5, 3))
    np.testing.assert_allclose(np.einsum('nij,nj->ni', rot.skew(v), w), np.cross(v, w),
                               atol=1e-14)


def test_rodrigues_matches_scipy_and_round_trips(rng: np.random.Generator) -> None:
    for _ in range(50):
        rv = rng.normal(size=3)
        rv *= rng.uniform(0.0, np.pi - 1e-3) / np.linalg.norm(rv)
        mat = rot.matrix_from_axis_angle(rv)
        np.testing.assert_allclose(mat, Rotation.from_rotvec(rv).as_matrix(), atol=1e-12)
        np.testing.assert_allclose(rot.axis_angle_from_matrix(mat), rv, atol=1e-9)


@pytest.mark.parametrize('angle', [0.0, 1e-9, np.pi - 1e-6, np.pi])
def test_axis_angle_edge_angles(angle: float) -> None:
    axis = np.array([0.3, -0.5, 0.8]) / np.linalg.norm([0.3, -0.5, 0.8])
    mat = rot.matrix_from_axis_angle(axis * angle)
    back = rot.matrix_from_axis_angle(rot.axis_angle_from_matrix(mat))
    np.testing.assert_allclose(back, mat, atol=1e-6)


def test_euler_xzy_round_trip(rng: np.random.Generator) -> None:
    for _ in range(50):
        a, c = rng.uniform(-np.pi, np.pi, 2)
        b = rng.uniform(-np.pi / 2 + 1e-3, np.pi / 2 - 1e-3)
        got = rot.euler_xzy_from_matrix(rot.matrix_from_euler_xzy(a, b, c))
        np.testing.assert_allclose(got, (a, b, c), atol=1e-9)


@pytest.mark.parametrize('b', [np.pi / 2, -np.pi / 2])
def test_euler_xzy_gimbal_lock_reconstructs(b: float) -> None:
    mat = rot.matrix_from_euler_xzy(0.4, b, -0.9)
    a2, b2, c2 = rot.euler_xzy_from_matrix(mat)
    assert a2 == 0.0
    np.testing.assert_allclose(rot.matrix_from_euler_xzy(a2, b2, c2), mat, atol=1e-9)


def test_euler_xzy_of_a_stack_matches_scipy_and_rebuilds_a_locked_matrix(
        rng: np.random.Generator) -> None:
    from scipy.spatial.transform import Rotation

    angles = rng.uniform(-1.5, 1.5, (2, 4, 3))
    angles[0, 1, 1] = np.pi / 2                           # one matrix in gimbal lock
    mats = np.array([[rot.matrix_from_euler_xzy(*abc) for abc in row] for row in angles])
    got = rot.euler_xzy_from_matrices(mats)
    assert got.shape == (2, 4, 3)
    free = np.ones((2, 4), dtype=bool)
    free[0, 1] = False
    # Rx(a) Rz(b) Ry(c) is SciPy's intrinsic 'XZY' sequence.
    np.testing.assert_allclose(got[free], Rotation.from_matrix(mats[free]).as_euler('XZY'),
                               atol=1e-9)
    a, b, c = got[0, 1]
    assert a == 0.0
    np.testing.assert_allclose(rot.matrix_from_euler_xzy(a, b, c), mats[0, 1], atol=1e-9)


def test_quaternions_are_unit_xyzw_with_w_non_negative(rng) -> None:
    rotvecs = rng.normal(size=(50, 3)) * 1.5
    rotvecs[0] = (np.pi, 0.0, 0.0)                                  # w = 0
    mats = np.array([rot.matrix_from_axis_angle(v) for v in rotvecs])
    quats = rot.quaternions_xyzw_from_matrices(mats)
    assert quats.shape == (50, 4) and np.all(quats[:, 3] >= 0.0)
    np.testing.assert_allclose(np.linalg.norm(quats, axis=1), 1.0, atol=1e-12)
    angle = np.linalg.norm(rotvecs[1])
    expected = np.r_[np.sin(angle / 2) * rotvecs[1] / angle, np.cos(angle / 2)]
    np.testing.assert_allclose(quats[1], expected * np.sign(expected[3]), atol=1e-12)
    np.testing.assert_allclose(Rotation.from_quat(quats).as_matrix(), mats, atol=1e-12)
