"""Forward kinematics of the hand skeleton and its analytic Jacobian.

Every bone ``b`` has a world transform ``T_b = T_parent(b) Trans(o_b) R_rest,b R_joint,b``
(4x4). The palm is moved by the global DOF,
``T_palm = Trans(t) Ry(hand_ry) Rz(hand_rz) Rx(hand_rx)``; the first bone of finger ``i`` has
``o = base_i``, ``R_joint = Rz(-abd) Rx(flex)`` (abduction about the local -z, then flexion
about the abducted local +x); the second and third have ``o = (0, length, 0)``,
``R_rest = I`` and ``R_joint = Rx(flex)``.

Jacobian. Each rotational DOF ``k`` is a hinge with world axis ``a_k`` through the pivot
``p_k`` (the joint centre; the wrist for the global rotation). A point ``x`` rigidly attached
to a bone that DOF ``k`` moves has

    dx / dtheta_k = a_k x (x - p_k)          (revolute)
    dx / dtheta_k = e_k                      (translation k = 0, 1, 2)

and zero for DOF that do not move its bone (``moves[k, b]``). The world axes are the hinge
axes of the current pose: for chained hinges in one joint the later axis is the earlier
hinge's rotation applied to the local axis (e.g. flexion axis ``R_parent R_rest Rz(-abd) e_x``).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numba
import numpy as np

from hand_tracker_ros._typing import BoolArray, FloatArray, IntArray
from hand_tracker_ros.model.layout import PARAM_NAMES, P
from hand_tracker_ros.model.skeleton import KEYPOINT_BONES, B, RestSkeleton

_RY, _RZ, _RX = (PARAM_NAMES.index(n) for n in ('hand_ry', 'hand_rz', 'hand_rx'))
# theta index of the first DOF of finger i (flex, abd, 2nd-joint flex, 3rd-joint flex).
_FINGER_DOF0 = 6 + 4 * np.arange(5)
# Bone ids of segment l of finger i: (5, 3).
_FINGER_BONES = 1 + 3 * np.arange(5)[:, None] + np.arange(3)[None, :]
MAX_BONE_DOFS = 3 + 4   # global rotations + the hinges of one finger chain


def _moves_table() -> BoolArray:
    """``moves[k, b]``: does DOF k move bone b? (P, B) bool."""
    moves = np.zeros((P, B), dtype=bool)
    moves[:6, :] = True
    for i in range(5):
        k0, bones = _FINGER_DOF0[i], _FINGER_BONES[i]
        moves[k0:k0 + 2, bones] = True
        moves[k0 + 2, bones[1:]] = True
        moves[k0 + 3, bones[2]] = True
    return moves


MOVES: BoolArray = _moves_table()
MOVES.setflags(write=False)


def bone_revolute_dofs() -> IntArray:
    """Revolute DOF moving each bone, padded with -1: (B, MAX_BONE_DOFS) int64."""
    table = np.full((B, MAX_BONE_DOFS), -1, dtype=np.int64)
    for b in range(B):
        dofs = np.flatnonzero(MOVES[3:, b]) + 3
        table[b, :dofs.size] = dofs
    return table


@dataclass(frozen=True)
class FKResult:
    """Posed skeleton.

    Attributes
    ----------
    bone_transforms : (B, 4, 4) float64
        ``T_world_bone`` of every bone.
    axes : (P, 3) float64
        World hinge axis of every revolute DOF; unit ``e_k`` for the translations.
    pivots : (P, 3) float64
        World pivot of every revolute DOF (zero rows for the translations).
    """

    bone_transforms: FloatArray
    axes: FloatArray
    pivots: FloatArray


@numba.njit(cache=True, nogil=True)
def _rot(axis: int, angle: float) -> np.ndarray:  # pragma: no cover - compiled
    """Rotation (3, 3) by ``angle`` about the coordinate axis 0 (x), 1 (y) or 2 (z)."""
    c, s = math.cos(angle), math.sin(angle)
    r = np.zeros((3, 3))
    i, j = (axis + 1) % 3, (axis + 2) % 3
    r[axis, axis] = 1.0
    r[i, i], r[i, j], r[j, i], r[j, j] = c, -s, s, c
    return r


@numba.njit(cache=True, nogil=True)
def _fk(theta: np.ndarray, rest_rot: np.ndarray, base_m: np.ndarray, lengths_m: np.ndarray,
        n_bones: int, finger_dof0: np.ndarray, finger_bones: np.ndarray, ry: int, rz: int,
        rx: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:  # pragma: no cover - compiled
    """Bone transforms (B, 4, 4), hinge axes (P, 3) and pivots (P, 3); see the module docstring.

    numba because FK runs at every pose (some 30 times per frame) and the numpy form spent
    ~0.18 ms in two dozen tiny array operations; the test compares it with that form.
    """
    n_p = theta.shape[0]
    transforms = np.zeros((n_bones, 4, 4))
    for b in range(n_bones):
        transforms[b, 3, 3] = 1.0
    axes, pivots = np.zeros((n_p, 3)), np.zeros((n_p, 3))
    for a in range(3):
        axes[a, a] = 1.0
    r_yz = _rot(1, theta[ry]) @ _rot(2, theta[rz])
    r_hand = r_yz @ _rot(0, theta[rx])
    t = theta[0:3]
    axes[ry, 1] = 1.0
    axes[rz] = _rot(1, theta[ry])[:, 2]
    axes[rx] = r_yz[:, 0]
    pivots[3:6] = t
    transforms[0, :3, :3], transforms[0, :3, 3] = r_hand, t
    for i in range(finger_dof0.shape[0]):
        k0 = finger_dof0[i]
        # First segment: R = R_hand R_rest Rz(-abd) Rx(flex).
        r_abd = r_hand @ rest_rot[i]
        r_flex = r_abd @ _rot(2, -theta[k0 + 1])
        rot = r_flex @ _rot(0, theta[k0])
        pos = t + r_hand @ base_m[i]
        axes[k0 + 1], axes[k0] = -r_abd[:, 2], r_flex[:, 0]
        pivots[k0 + 1], pivots[k0] = pos, pos
        transforms[finger_bones[i, 0], :3, :3] = rot
        transforms[finger_bones[i, 0], :3, 3] = pos
        for lvl in range(1, 3):
            pos = pos + rot[:, 1] * lengths_m[i, lvl - 1]
            axes[k0 + 1 + lvl], pivots[k0 + 1 + lvl] = rot[:, 0], pos
            rot = rot @ _rot(0, theta[k0 + 1 + lvl])
            transforms[finger_bones[i, lvl], :3, :3] = rot
            transforms[finger_bones[i, lvl], :3, 3] = pos
    return transforms, axes, pivots


def forward_kinematics(rest: RestSkeleton, theta: FloatArray) -> FKResult:
    """Bone transforms and hinge axes/pivots for pose ``theta`` (P,) float64 (trusted)."""
    transforms, axes, pivots = _fk(theta, rest.rest_rot, rest.base_m, rest.lengths_m, B,
                                   _FINGER_DOF0, _FINGER_BONES, _RY, _RZ, _RX)
    return FKResult(bone_transforms=transforms, axes=axes, pivots=pivots)


def transform_points(fk: FKResult, bones: IntArray, local_m: FloatArray) -> FloatArray:
    """World positions (N, 3) of points given in their bone frames.

    Parameters
    ----------
    bones : (N,) int64
        Bone of every point.
    local_m : (N, 3) float64
        Coordinates in that bone's frame.
    """
    t = fk.bone_transforms[bones]
    return np.einsum('nij,nj->ni', t[:, :3, :3], local_m) + t[:, :3, 3]


@numba.njit(cache=True, nogil=True)
def _points_jacobian(axes: np.ndarray, pivots: np.ndarray, moves: np.ndarray, bones: np.ndarray,
                     points: np.ndarray) -> np.ndarray:  # pragma: no cover - compiled
    """:func:`points_jacobian` (N, 3, P) from the hinge axes (P, 3), pivots (P, 3) m, the
    ``moves`` table (P, B) bool, the bones (N,) int64 and the points (N, 3) m.

    numba because the numpy form (a broadcast ``np.cross``, a mask and a transpose) took
    80 us at every LM evaluation against 3 us here; the test compares the two."""
    n, n_p = points.shape[0], axes.shape[0]
    out = np.zeros((n, 3, n_p))
    for i in range(n):
        b = bones[i]
        for k in range(n_p):
            if not moves[k, b]:
                continue
            if k < 3:
                out[i, k, k] = 1.0
                continue
            d0, d1, d2 = (points[i, 0] - pivots[k, 0], points[i, 1] - pivots[k, 1],
                          points[i, 2] - pivots[k, 2])
            a0, a1, a2 = axes[k, 0], axes[k, 1], axes[k, 2]
            out[i, 0, k] = a1 * d2 - a2 * d1
            out[i, 1, k] = a2 * d0 - a0 * d2
            out[i, 2, k] = a0 * d1 - a1 * d0
    return out


def points_jacobian(fk: FKResult, bones: IntArray, points_m: FloatArray) -> FloatArray:
    """Jacobian (N, 3, P) of world points rigidly attached to ``bones`` (N,).

    ``points_m`` (N, 3) are their current world positions. Column ``k`` is ``e_k`` for the
    translations, ``a_k x (X - p_k)`` for a revolute DOF that moves the bone (module
    docstring), and zero otherwise.
    """
    return _points_jacobian(fk.axes, fk.pivots, MOVES, np.asarray(bones, dtype=np.int64),
                            np.ascontiguousarray(points_m, dtype=np.float64))


def keypoint_local(rest: RestSkeleton) -> FloatArray:
    """Keypoints (21, 3) in the frames of KEYPOINT_BONES: bone origins, tips at the bone end."""
    local = np.zeros((len(KEYPOINT_BONES), 3))
    local[4::4, 1] = rest.lengths_m[:, 2]
    return local


def rest_transforms(rest: RestSkeleton) -> FloatArray:
    """Bone transforms (B, 4, 4) of the rest pose (theta = 0) in the hand frame."""
    return forward_kinematics(rest, np.zeros(P)).bone_transforms
