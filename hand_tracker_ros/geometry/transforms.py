"""Rigid transforms as (4, 4) homogeneous matrices.

A transform ``T_b_a`` maps points from frame ``a`` to frame ``b``:
``p_b = R p_a + t`` with ``T_b_a = [[R, t], [0, 1]]``. Its inverse is
``T_a_b = [[R^T, -R^T t], [0, 1]]``.

Camera frames follow the REP 103 optical convention: z forward (along the viewing ray),
x right, y down in the image.
"""
from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike

from hand_tracker_ros._typing import FloatArray
from hand_tracker_ros.checks import check_shape
from hand_tracker_ros.errors import CalibrationError

_EPS = 1e-9


def make_T(R: ArrayLike, t: ArrayLike) -> FloatArray:
    """Build a homogeneous transform.

    Parameters
    ----------
    R : (3, 3) float64
        Rotation matrix.
    t : (3,) float64
        Translation (m).

    Returns
    -------
    T : (4, 4) float64
    """
    R = np.asarray(R, dtype=np.float64)
    t = np.asarray(t, dtype=np.float64)
    check_shape('R', R, (3, 3))
    check_shape('t', t, (3,))
    T = np.eye(4)
    T[:3, :3] = R
    T[:3, 3] = t
    return T


def invert_T(T: ArrayLike) -> FloatArray:
    """Invert a rigid transform in closed form (no general matrix inverse).

    Parameters
    ----------
    T : (4, 4) float64
        Rigid transform ``T_b_a``.

    Returns
    -------
    T_inv : (4, 4) float64
        ``T_a_b``.
    """
    T = np.asarray(T, dtype=np.float64)
    check_shape('T', T, (4, 4))
    R_t = T[:3, :3].T
    return make_T(R_t, -R_t @ T[:3, 3])


def transform_points(T: ArrayLike, points: ArrayLike) -> FloatArray:
    """Apply ``T`` to points.

    Parameters
    ----------
    T : (4, 4) float64
        Transform ``T_b_a``.
    points : (N, 3) float64
        Points in frame ``a``.

    Returns
    -------
    points_b : (N, 3) float64
    """
    T = np.asarray(T, dtype=np.float64)
    points = np.asarray(points, dtype=np.float64)
    check_shape('T', T, (4, 4))
    check_shape('points', points, (None, 3))
    return points @ T[:3, :3].T + T[:3, 3]


def look_at(eye_m: ArrayLike, target_m: ArrayLike,
            up: ArrayLike = (0.0, 0.0, 1.0)) -> FloatArray:
    """Pose of a camera at ``eye_m`` looking at ``target_m``, as ``T_cam_world``.

    The optical axes are z = (target - eye) / |target - eye|, x = z x up (normalised, the
    image's right), y = z x x (the image's down), so ``up`` appears upwards in the image.

    Parameters
    ----------
    eye_m : (3,) float64
        Camera centre in the world frame.
    target_m : (3,) float64
        Point the optical axis passes through.
    up : (3,) float64
        World direction that should point up in the image; must not be parallel to the
        viewing direction.

    Returns
    -------
    T_cam_world : (4, 4) float64

    Raises
    ------
    CalibrationError
        If eye and target coincide or ``up`` is parallel to the viewing direction.
    """
    eye = np.asarray(eye_m, dtype=np.float64)
    target = np.asarray(target_m, dtype=np.float64)
    up_v = np.asarray(up, dtype=np.float64)
    for name, v in (('eye_m', eye), ('target_m', target), ('up', up_v)):
        check_shape(name, v, (3,))
    forward = target - eye
    dist = np.linalg.norm(forward)
    if dist < _EPS:
        msg = 'look_at: `eye_m` and `target_m` coincide'
        raise CalibrationError(msg)
    z = forward / dist
    x = np.cross(z, up_v)
    x_norm = np.linalg.norm(x)
    if x_norm < _EPS * max(1.0, float(np.linalg.norm(up_v))):
        msg = 'look_at: `up` is parallel to the viewing direction'
        raise CalibrationError(msg)
    x /= x_norm
    y = np.cross(z, x)
    R_cam_world = np.stack([x, y, z])
    return make_T(R_cam_world, -R_cam_world @ eye)
