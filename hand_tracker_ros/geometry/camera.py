r"""Pinhole camera with OpenCV lens distortion, its projection Jacobian and back-projection.

A world point X (m) maps to the camera frame (REP 103 optical: z forward, x right, y down)
as ``p = R X + t`` with ``[R | t] = T_cam_world[:3]``. With ``x = p_x / p_z`` and
``y = p_y / p_z``, ``r^2 = x^2 + y^2``, OpenCV's distortion model is

.. math::

    f(r^2) = \frac{1 + k_1 r^2 + k_2 r^4 + k_3 r^6}{1 + k_4 r^2 + k_5 r^4 + k_6 r^6}

    x_d = x f + 2 p_1 x y + p_2 (r^2 + 2 x^2), \qquad
    y_d = y f + p_1 (r^2 + 2 y^2) + 2 p_2 x y

    u = f_x x_d + c_x, \qquad v = f_y y_d + c_y

'plumb_bob' has ``D = (k1, k2, p1, p2, k3)`` (so k4 = k5 = k6 = 0) and 'rational_polynomial'
``D = (k1, k2, p1, p2, k3, k4, k5, k6)``; both are evaluated by the same code.

Pixel convention: the centre of pixel (column u, row v) is at integer coordinates (u, v),
as in OpenCV and ROS; the pixel covers [u - 0.5, u + 0.5) x [v - 0.5, v + 0.5).

The projection is written out (one numba pass) rather than done with ``cv2.projectPoints``: the
latter always computes its 2N x 15 Jacobian w.r.t. the camera parameters and is about 10x slower
for the tracker's job (measured when it was written). The Jacobian w.r.t. the world point is the
chain ``d(uv)/dX = diag(f_x, f_y) . d(x_d, y_d)/d(x, y) . d(x, y)/dp . R`` with ``d(x, y)/dp =
[[1/z, 0, -x/z], [0, 1/z, -y/z]]``.
"""
from __future__ import annotations

import dataclasses
from collections.abc import Sequence
from dataclasses import dataclass

import cv2
import numba
import numpy as np
from numpy.typing import ArrayLike

from hand_tracker_ros._typing import FloatArray
from hand_tracker_ros.checks import check_finite, check_shape
from hand_tracker_ros.errors import CalibrationError

#: Distortion models accepted by :meth:`PinholeCamera.from_camera_info`, with coefficient count.
DISTORTION_MODELS = {'plumb_bob': 5, 'rational_polynomial': 8}

_RIGID_TOL = 1e-6
_UNDISTORT_CRITERIA = (cv2.TERM_CRITERIA_COUNT | cv2.TERM_CRITERIA_EPS, 100, 1e-12)


def _calib_array(cam: str, field: str, value: ArrayLike, shape: tuple[int, ...]) -> FloatArray:
    """Convert a calibration field to a read-only float64 array, naming it on failure."""
    try:
        arr = np.array(value, dtype=np.float64)
    except (TypeError, ValueError) as err:
        msg = f'{cam}: `{field}` must be numeric, got {value!r}'
        raise CalibrationError(msg) from err
    if arr.shape != shape:
        msg = f'{cam}: `{field}` must have shape {shape}, got {arr.shape}'
        raise CalibrationError(msg)
    if not np.all(np.isfinite(arr)):
        msg = f'{cam}: `{field}` holds non-finite values'
        raise CalibrationError(msg)
    arr.setflags(write=False)
    return arr


def _check_K(cam: str, K: FloatArray) -> None:
    if K[1, 0] != 0 or K[2, 0] != 0 or K[2, 1] != 0 or K[2, 2] != 1:
        msg = f'{cam}: `K` must be upper triangular with K[2, 2] = 1, got {K.tolist()}'
        raise CalibrationError(msg)
    if K[0, 0] <= 0 or K[1, 1] <= 0:
        msg = f'{cam}: `K` focal lengths must be positive, got fx={K[0, 0]}, fy={K[1, 1]}'
        raise CalibrationError(msg)
    if K[0, 1] != 0:
        # OpenCV's distortion model (and cv2.undistortPoints) ignores the skew term.
        msg = f'{cam}: `K` skew K[0, 1] must be 0, got {K[0, 1]}'
        raise CalibrationError(msg)


def _check_rigid(cam: str, T: FloatArray) -> None:
    R = T[:3, :3]
    if (not np.allclose(T[3], (0.0, 0.0, 0.0, 1.0), atol=_RIGID_TOL, rtol=0)
            or not np.allclose(R.T @ R, np.eye(3), atol=_RIGID_TOL, rtol=0)
            or np.linalg.det(R) < 0):
        msg = (f'{cam}: `T_cam_world` is not a rigid transform '
               '(orthonormal R, det +1, last row 0 0 0 1)')
        raise CalibrationError(msg)


@numba.njit(cache=True, nogil=True)
def distort_point(x: float, y: float, dist8: np.ndarray
                  ) -> tuple[float, float, float, float, float, float]:  # pragma: no cover
    """Distorted normalised coordinates ``(x_d, y_d)`` of ``(x, y)`` (module docstring), and
    the pieces ``(f, r2, num, den)`` that :func:`pixel_jacobian` reuses. ``dist8`` is
    ``PinholeCamera.dist8``. The one copy of the distortion model: every projection kernel
    (here and in ``energies._projection``) calls it."""
    k1, k2, p1, p2, k3, k4, k5, k6 = (dist8[0], dist8[1], dist8[2], dist8[3], dist8[4],
                                      dist8[5], dist8[6], dist8[7])
    r2 = x * x + y * y
    num = 1.0 + r2 * (k1 + r2 * (k2 + r2 * k3))
    den = 1.0 + r2 * (k4 + r2 * (k5 + r2 * k6))
    f = num / den
    xd = x * f + 2.0 * p1 * x * y + p2 * (r2 + 2.0 * x * x)
    yd = y * f + p1 * (r2 + 2.0 * y * y) + 2.0 * p2 * x * y
    return xd, yd, f, r2, num, den


@numba.njit(cache=True, nogil=True)
def pixel_jacobian(x: float, y: float, inv_z: float, f: float, r2: float, num: float,
                   den: float, fx: float, fy: float, R: np.ndarray, dist8: np.ndarray,
                   out: np.ndarray) -> None:  # pragma: no cover - compiled
    """Write ``d(u, v)/dX_world`` (2, 3) of one point into ``out``.

    ``x, y`` are its normalised coordinates, ``inv_z = 1 / p_z`` and ``f, r2, num, den`` the
    pieces :func:`distort_point` returned: ``d(x_d, y_d)/d(x, y) = [[a, b], [b, d]]`` (with
    ``dr2/dx = 2x``, ``dr2/dy = 2y``), times ``diag(f_x, f_y)``, ``d(x, y)/dp = inv_z [[1, 0,
    -x], [0, 1, -y]]`` and ``dp/dX = R``.
    """
    k1, k2, p1, p2, k3, k4, k5, k6 = (dist8[0], dist8[1], dist8[2], dist8[3], dist8[4],
                                      dist8[5], dist8[6], dist8[7])
    dnum = k1 + r2 * (2.0 * k2 + 3.0 * k3 * r2)
    dden = k4 + r2 * (2.0 * k5 + 3.0 * k6 * r2)
    df_dr2 = (dnum * den - num * dden) / (den * den)
    a = f + 2.0 * x * x * df_dr2 + 2.0 * p1 * y + 6.0 * p2 * x
    b = 2.0 * x * y * df_dr2 + 2.0 * p1 * x + 2.0 * p2 * y
    d = f + 2.0 * y * y * df_dr2 + 6.0 * p1 * y + 2.0 * p2 * x
    q0 = (fx * a * inv_z, fx * b * inv_z, -fx * (a * x + b * y) * inv_z)
    q1 = (fy * b * inv_z, fy * d * inv_z, -fy * (b * x + d * y) * inv_z)
    for c in range(3):
        out[0, c] = q0[0] * R[0, c] + q0[1] * R[1, c] + q0[2] * R[2, c]
        out[1, c] = q1[0] * R[0, c] + q1[1] * R[1, c] + q1[2] * R[2, c]


@numba.njit(cache=True, nogil=True)
def _project(points: np.ndarray, R: np.ndarray, t: np.ndarray, K: np.ndarray, dist8: np.ndarray,
             jacobian: bool
             ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:  # pragma: no cover - compiled
    """Pixel coordinates (N, 2), depths (N,) and, with ``jacobian``, ``d(u, v)/dX`` (N, 2, 3)
    (else (0, 2, 3)) of world points (N, 3); NaN behind the camera.

    numba because the tracker projects the whole mesh (about 5k vertices) into every camera
    at every correspondence round, where the numpy form spent ~0.2 ms per camera on a dozen
    elementwise temporaries.
    """
    n = points.shape[0]
    uv = np.empty((n, 2))
    z = np.empty(n)
    duv_dX = np.empty((n if jacobian else 0, 2, 3))
    fx, fy = K[0, 0], K[1, 1]
    for i in range(n):
        c0 = R[0, 0] * points[i, 0] + R[0, 1] * points[i, 1] + R[0, 2] * points[i, 2] + t[0]
        c1 = R[1, 0] * points[i, 0] + R[1, 1] * points[i, 1] + R[1, 2] * points[i, 2] + t[1]
        c2 = R[2, 0] * points[i, 0] + R[2, 1] * points[i, 1] + R[2, 2] * points[i, 2] + t[2]
        z[i] = c2
        inv_z = 1.0 / c2 if c2 > 0.0 else np.nan
        x, y = c0 * inv_z, c1 * inv_z
        xd, yd, f, r2, num, den = distort_point(x, y, dist8)
        uv[i, 0] = fx * xd + K[0, 2]
        uv[i, 1] = fy * yd + K[1, 2]
        if not jacobian:
            continue
        pixel_jacobian(x, y, inv_z, f, r2, num, den, fx, fy, R, dist8, duv_dX[i])
    return uv, z, duv_dX


@dataclass(frozen=True, eq=False)
class PinholeCamera:
    """A calibrated camera: intrinsics, OpenCV distortion and world pose.

    Attributes
    ----------
    name : str
        Camera name (e.g. 'cam0'), unique within a rig.
    width, height : int
        Image size (px).
    K : (3, 3) float64
        Intrinsic matrix ``[[fx, 0, cx], [0, fy, cy], [0, 0, 1]]`` (px).
    dist : (5,) or (8,) float64
        OpenCV distortion coefficients: plumb_bob (k1, k2, p1, p2, k3) or
        rational_polynomial (k1, k2, p1, p2, k3, k4, k5, k6).
    T_cam_world : (4, 4) float64
        Rigid transform with ``p_cam = T_cam_world @ p_world``.
    """

    name: str
    width: int
    height: int
    K: FloatArray
    dist: FloatArray
    T_cam_world: FloatArray
    _dist8: FloatArray = dataclasses.field(init=False, repr=False)

    def __post_init__(self) -> None:
        cam = self.name if isinstance(self.name, str) and self.name else repr(self.name)
        if not isinstance(self.name, str) or not self.name:
            msg = f'camera {cam}: `name` must be a non-empty string'
            raise CalibrationError(msg)
        for field in ('width', 'height'):
            value = getattr(self, field)
            if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value <= 0:
                msg = f'{cam}: `{field}` must be a positive integer, got {value!r}'
                raise CalibrationError(msg)
            object.__setattr__(self, field, int(value))
        K = _calib_array(cam, 'K', self.K, (3, 3))
        _check_K(cam, K)
        n_dist = np.size(self.dist)
        if n_dist not in (5, 8):
            msg = (f'{cam}: `dist` must have 5 (plumb_bob) or 8 (rational_polynomial) '
                   f'numbers, got {n_dist}')
            raise CalibrationError(msg)
        dist = _calib_array(cam, 'dist', self.dist, (n_dist,))
        T = _calib_array(cam, 'T_cam_world', self.T_cam_world, (4, 4))
        _check_rigid(cam, T)
        dist8 = np.zeros(8)
        dist8[:n_dist] = dist
        dist8.setflags(write=False)
        object.__setattr__(self, 'K', K)
        object.__setattr__(self, 'dist', dist)
        object.__setattr__(self, 'T_cam_world', T)
        object.__setattr__(self, '_dist8', dist8)

    @classmethod
    def from_camera_info(cls, name: str, width: int, height: int, K9: Sequence[float],
                         D: Sequence[float], distortion_model: str,
                         T_cam_world: ArrayLike) -> PinholeCamera:
        """Build a camera from the plain values of a ``sensor_msgs/CameraInfo`` plus extrinsics.

        Parameters
        ----------
        name : str
            Camera name.
        width, height : int
            Image size (px).
        K9 : (9,) float
            Row-major intrinsic matrix (CameraInfo ``k``).
        D : (5,) or (8,) float
            Distortion coefficients (CameraInfo ``d``); an empty ``D`` means no distortion.
        distortion_model : str
            'plumb_bob' (5 coefficients) or 'rational_polynomial' (8).
        T_cam_world : (4, 4) float64
            Extrinsics, ``p_cam = T_cam_world @ p_world``.

        Raises
        ------
        CalibrationError
            Unknown distortion model, wrong coefficient count or any invalid field.
        """
        if distortion_model not in DISTORTION_MODELS:
            msg = (f'{name}: unsupported `distortion_model` {distortion_model!r}; '
                   f'expected one of {sorted(DISTORTION_MODELS)}')
            raise CalibrationError(msg)
        n_expected = DISTORTION_MODELS[distortion_model]
        d = np.asarray(D, dtype=np.float64).ravel()
        if d.size == 0:
            d = np.zeros(n_expected)
        if d.size != n_expected:
            msg = (f'{name}: `D` must have {n_expected} numbers for {distortion_model}, '
                   f'got {d.size}')
            raise CalibrationError(msg)
        if np.size(K9) != 9:
            msg = f'{name}: `K` must have 9 numbers, got {np.size(K9)}'
            raise CalibrationError(msg)
        K = np.asarray(K9, dtype=np.float64).reshape(3, 3)
        return cls(name, width, height, K, d, np.asarray(T_cam_world, dtype=np.float64))

    @property
    def distortion_model(self) -> str:
        """'plumb_bob' or 'rational_polynomial' (from the number of coefficients)."""
        return 'plumb_bob' if self.dist.size == 5 else 'rational_polynomial'

    @property
    def dist8(self) -> FloatArray:
        """(8,) float64 ``k1, k2, p1, p2, k3, k4, k5, k6`` (plumb_bob padded with zeros)."""
        return self._dist8

    @property
    def R_cam_world(self) -> FloatArray:
        """(3, 3) float64 rotation from world to camera axes."""
        return self.T_cam_world[:3, :3]

    @property
    def center_world(self) -> FloatArray:
        """(3,) float64 camera centre in the world frame (m): ``-R^T t``."""
        return -self.T_cam_world[:3, :3].T @ self.T_cam_world[:3, 3]

    def scaled(self, width: int, height: int) -> PinholeCamera:
        """The same camera (pose, field of view, distortion) at another resolution.

        With pixel centres at integer coordinates, the image edge ``-0.5`` stays fixed:
        ``u' + 0.5 = s_x (u + 0.5)``, so ``f_x' = s_x f_x`` and ``c_x' = s_x (c_x + 0.5) - 0.5``.
        """
        sx, sy = width / self.width, height / self.height
        K = np.array(self.K)
        K[0, 0] *= sx
        K[1, 1] *= sy
        K[0, 2] = sx * (K[0, 2] + 0.5) - 0.5
        K[1, 2] = sy * (K[1, 2] + 0.5) - 0.5
        return PinholeCamera(self.name, width, height, K, self.dist, self.T_cam_world)

    def _points(self, points_world: ArrayLike) -> FloatArray:
        pts = np.asarray(points_world, dtype=np.float64)
        check_shape('points_world', pts, (None, 3))
        check_finite('points_world', pts)
        return pts

    def project(self, points_world: ArrayLike) -> tuple[FloatArray, FloatArray]:
        """Project world points to distorted pixel coordinates.

        Parameters
        ----------
        points_world : (N, 3) float64
            Points in the world frame (m).

        Returns
        -------
        uv_px : (N, 2) float64
            Pixel coordinates (column, row); NaN where ``depth_m <= 0`` (behind the camera).
        depth_m : (N,) float64
            Camera-frame z of each point.
        """
        uv, z, _ = _project(self._points(points_world), self.R_cam_world,
                            self.T_cam_world[:3, 3], self.K, self._dist8, False)
        return uv, z

    def project_jacobian(self, points_world: ArrayLike
                         ) -> tuple[FloatArray, FloatArray, FloatArray]:
        """Project world points and differentiate the pixel coordinates w.r.t. them.

        Parameters
        ----------
        points_world : (N, 3) float64
            Points in the world frame (m).

        Returns
        -------
        uv_px : (N, 2) float64
            As :meth:`project` (NaN behind the camera).
        depth_m : (N,) float64
            Camera-frame z.
        duv_dX : (N, 2, 3) float64
            ``d(u, v) / d(X_world)`` (px / m), distortion included; NaN behind the camera.
        """
        return _project(self._points(points_world), self.R_cam_world, self.T_cam_world[:3, 3],
                        self.K, self._dist8, True)

    def rays(self, uv_px: ArrayLike) -> tuple[FloatArray, FloatArray]:
        """Back-project pixels to world rays (undistorting with ``cv2.undistortPoints``).

        Parameters
        ----------
        uv_px : (N, 2) float64
            Distorted pixel coordinates.

        Returns
        -------
        origin_world : (3,) float64
            Camera centre (m), shared by all rays.
        directions_world : (N, 3) float64
            Unit ray directions; ``project(origin + s * direction) == uv`` for any s > 0.
        """
        uv = np.asarray(uv_px, dtype=np.float64)
        check_shape('uv_px', uv, (None, 2))
        check_finite('uv_px', uv)
        if uv.shape[0] == 0:
            return self.center_world, np.zeros((0, 3))
        xy = cv2.undistortPoints(uv.reshape(-1, 1, 2), self.K, self._dist8, None, None, None,
                                     _UNDISTORT_CRITERIA).reshape(-1, 2)
        d_cam = np.column_stack([xy, np.ones(len(xy))])
        d_cam = d_cam / np.linalg.norm(d_cam, axis=1, keepdims=True)
        return self.center_world, d_cam @ self.R_cam_world
