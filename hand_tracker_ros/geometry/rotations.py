"""Rotation matrices: axis rotations, Rodrigues, axis-angle and an x-z-y Euler split.

All functions work on a single rotation (3x3 float64) unless stated otherwise.

Rodrigues' formula for a unit axis ``a`` and angle ``t``::

    R = I + sin(t) [a]_x + (1 - cos(t)) [a]_x^2

where ``[a]_x`` is the skew (cross-product) matrix, ``[a]_x v = a x v``. The inverse
(:func:`axis_angle_from_matrix`) reads the angle from the trace, ``cos t = (tr R - 1) / 2``,
and the axis from the antisymmetric part; near ``t = pi`` the antisymmetric part vanishes and
the axis is taken from the symmetric part ``(R + I) / 2 = a a^T``.

The x-z-y Euler split (:func:`euler_xzy_from_matrix`) writes ``R = Rx(a) Rz(b) Ry(c)``. It is
the decomposition used by the sphere-mesh joint-limit energy: the twist about the bone axis
(+y in our bone frames) is applied first in the bone frame and recovered last. With
``R = Rx(a) Rz(b) Ry(c)``::

    R[0, 1] = -sin b              -> b = asin(-R[0, 1])
    R[0, 0] =  cos b cos c,  R[0, 2] = cos b sin c       -> c = atan2(R[0, 2], R[0, 0])
    R[1, 1] =  cos a cos b,  R[2, 1] = sin a cos b       -> a = atan2(R[2, 1], R[1, 1])

It is singular (gimbal lock) at ``b = +-pi/2``; there ``a`` is set to 0 and
``c = atan2(-R[2, 0], R[2, 2])`` absorbs it.

Quaternions (:func:`quaternions_xyzw_from_matrices`, for ``geometry_msgs/Quaternion``) are unit
``(x, y, z, w)`` with ``w >= 0``: ``q = (sin(t/2) a, cos(t/2))`` for axis ``a`` and angle ``t``.
"""
from __future__ import annotations

import numpy as np
from scipy.spatial.transform import Rotation

from hand_tracker_ros._typing import FloatArray

_EPS = 1e-12


def rot_x(angle_rad: float) -> FloatArray:
    """Rotation about +x by ``angle_rad``; returns (3, 3) float64."""
    c, s = np.cos(angle_rad), np.sin(angle_rad)
    return np.array([[1.0, 0.0, 0.0], [0.0, c, -s], [0.0, s, c]])


def rot_y(angle_rad: float) -> FloatArray:
    """Rotation about +y by ``angle_rad``; returns (3, 3) float64."""
    c, s = np.cos(angle_rad), np.sin(angle_rad)
    return np.array([[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]])


def rot_z(angle_rad: float) -> FloatArray:
    """Rotation about +z by ``angle_rad``; returns (3, 3) float64."""
    c, s = np.cos(angle_rad), np.sin(angle_rad)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def skew(v: FloatArray) -> FloatArray:
    """Cross-product matrices.

    Parameters
    ----------
    v : (..., 3) float64

    Returns
    -------
    S : (..., 3, 3) float64
        ``S @ w == np.cross(v, w)``.
    """
    v = np.asarray(v, dtype=np.float64)
    s = np.zeros(v.shape[:-1] + (3, 3))
    s[..., 0, 1], s[..., 0, 2] = -v[..., 2], v[..., 1]
    s[..., 1, 0], s[..., 1, 2] = v[..., 2], -v[..., 0]
    s[..., 2, 0], s[..., 2, 1] = -v[..., 1], v[..., 0]
    return s


def axis_rotations(axes: FloatArray, angles_rad: FloatArray) -> FloatArray:
    """Batched Rodrigues formula for unit axes.

    Parameters
    ----------
    axes : (N, 3) float64
        Unit rotation axes.
    angles_rad : (N,) float64

    Returns
    -------
    R : (N, 3, 3) float64
    """
    k = skew(axes)
    s = np.sin(angles_rad)[:, None, None]
    c = np.cos(angles_rad)[:, None, None]
    return np.eye(3) + s * k + (1.0 - c) * (k @ k)


def matrix_from_axis_angle(rotvec: FloatArray) -> FloatArray:
    """Rodrigues: axis-angle vector (axis * angle, rad) (3,) -> rotation (3, 3)."""
    rotvec = np.asarray(rotvec, dtype=np.float64)
    angle = float(np.linalg.norm(rotvec))
    if angle < _EPS:
        return np.eye(3) + skew(rotvec)
    return axis_rotations(rotvec[None] / angle, np.array([angle]))[0]


def axis_angle_from_matrix(rot: FloatArray) -> FloatArray:
    """Inverse Rodrigues: rotation (3, 3) -> axis-angle vector (3,), angle in [0, pi]."""
    rot = np.asarray(rot, dtype=np.float64)
    cos_t = np.clip((np.trace(rot) - 1.0) / 2.0, -1.0, 1.0)
    angle = float(np.arccos(cos_t))
    anti = np.array([rot[2, 1] - rot[1, 2], rot[0, 2] - rot[2, 0], rot[1, 0] - rot[0, 1]])
    if angle < 1e-6:
        return anti / 2.0
    if np.pi - angle > 1e-4:
        return anti / (2.0 * np.sin(angle)) * angle
    # Near pi, sin(angle) ~ 0 makes the antisymmetric part useless: use (R + I) / 2 = a a^T,
    # take its largest column for the axis and fix the sign with the antisymmetric part.
    sym = (rot + np.eye(3)) / 2.0
    col = int(np.argmax(np.diag(sym)))
    axis = sym[:, col] / np.sqrt(max(sym[col, col], _EPS))
    if axis @ anti < 0.0:
        axis = -axis
    return axis / np.linalg.norm(axis) * angle


def euler_xzy_from_matrices(rots: FloatArray) -> FloatArray:
    """Decompose rotations ``(..., 3, 3)`` as ``R = Rx(a) Rz(b) Ry(c)``: ``(..., 3)`` of
    ``(a, b, c)`` rad, ``b`` in [-pi/2, pi/2] (the module docstring; at gimbal lock a = 0)."""
    rots = np.asarray(rots, dtype=np.float64)
    b = np.arcsin(np.clip(-rots[..., 0, 1], -1.0, 1.0))
    locked = np.cos(b) < 1e-9
    a = np.where(locked, 0.0, np.arctan2(rots[..., 2, 1], rots[..., 1, 1]))
    c = np.where(locked, np.arctan2(-rots[..., 2, 0], rots[..., 2, 2]),
                 np.arctan2(rots[..., 0, 2], rots[..., 0, 0]))
    return np.stack([a, b, c], axis=-1)


def euler_xzy_from_matrix(rot: FloatArray) -> tuple[float, float, float]:
    """Decompose ``R = Rx(a) Rz(b) Ry(c)``; returns ``(a, b, c)`` rad, ``b`` in [-pi/2, pi/2]."""
    a, b, c = euler_xzy_from_matrices(rot).tolist()
    return a, b, c


def matrix_from_euler_xzy(a_rad: float, b_rad: float, c_rad: float) -> FloatArray:
    """``Rx(a) Rz(b) Ry(c)`` (3, 3); the inverse of :func:`euler_xzy_from_matrix`."""
    return rot_x(a_rad) @ rot_z(b_rad) @ rot_y(c_rad)


def quaternions_xyzw_from_matrices(rots: FloatArray) -> FloatArray:
    """Rotations (N, 3, 3) -> unit quaternions (N, 4) ``(x, y, z, w)``, ``w >= 0``."""
    quats = Rotation.from_matrix(np.asarray(rots, dtype=np.float64)).as_quat()
    return np.where(quats[:, 3:] < 0.0, -quats, quats)
