r"""L, the joint-limit term of the sphere-mesh tracker (the second seed, "Joint limits").

The second seed: docs/references.md.

.. math:: E_L = \sum_{a} I_a \, |a(c^t) - R_L \, a(c^0)|^2

over the finger bones ``a``; ``a(c)`` is the bone vector in the world (child keypoint minus
parent keypoint, m), ``c^0`` the rest pose, ``I_a = 1`` only where a limit is violated and
``R_L`` the *limiting rotation* that brings the bone back to the limit. Activity and targets
are found once per correspondence round (:meth:`JointLimitsEnergy.correspond`) from the pose
at the start of the round; bones inside their limits give no rows (``M = 0`` for a pose
inside every limit). Residuals are in m (bone-vector displacements), so the term's weight is
relative to the px residuals of the image terms: ``weight = 1e6`` makes 1 mm of bone
displacement cost as much as 1 px of one image point. Limits come from
:func:`~hand_tracker_ros.model.skeleton.joint_limits`, widened on both sides by
``margin_deg`` (negative narrows), so the tracker may run LM with wider bounds and let this
energy hold the anatomical range.

Finger bases (long-finger MCP, thumb CMC). With ``R_a``, ``R_b`` the rotations of bone ``a``
and its parent ``b`` (the palm) with respect to the rest pose, the seed's limiting rotation is

.. math:: R_L = R_b \tilde R_{b \to a} R_{b \to a}^T R_b^T R_a,

where ``R_{b->a} = R_b^T R_a`` is the local rotation and ``\tilde R_{b->a}`` the same rotation
with its flexion and abduction clamped. We evaluate the equation as written; with our exact bone
frames ``R_{b->a}^T R_b^T R_a = I``, so ``R_L = R_b \tilde R_{b->a}``: the parent's rotation
times the clamped local rotation, applied to the rest bone vector ``a(c^0)``. The Euler angles
are read in the bone's rest frame, where the model's joint is ``Q = Rz(-abd) Rx(flex)``
(abduction about the parent's axis, then flexion). The seed's x-z-y split ``Rx(tx) Rz(tz)
Ry(ty)`` (x flexion, z abduction, y twist found last) is applied to ``Q^T = Rx(-flex) Rz(abd)``:
it then recovers the model's angles exactly (``tx = -flex``, ``tz = abd``, twist 0). Applied to
``Q`` itself it would mix abduction into flexion (``tan tx = tan flex / cos abd``) and report
violations for poses inside the table (thumb CMC at flex 50, abd 70 deg reads tx = 74 deg).
Clamping keeps the twist, which is what the seed's "the twist component is discarded" amounts
to.

Upper joints (PIP, DIP, thumb MCP and IP). A plane is fitted to the finger's four joint
locations (least squares: the right singular vector of the smallest singular value of the
centred points); its normal ``n`` is oriented along the flexion axis (local +x) of the
finger's first bone, which is also the fallback normal when the joints are nearly collinear
(singular-value ratio below ``plane_min_aspect``). The joint angle is the signed angle about
``n`` from the parent bone's projection to the child bone's projection on the plane
(positive = flexion). Outside its limit, ``R_L`` rotates the projected child bone about
``n`` to the limit (and so also into the plane), keeping its length.

Finger plane to palm. Convention: the elevation of a finger plane is
``phi = asin(n . z_palm)``, the angle between ``n`` and the palm plane (``z_palm``, the palm
normal, points volar). For the long fingers ``n`` is the flexion axis, which lies in the palm
plane at rest (``phi = 0``); the thumb's plane is tilted (``phi`` from about 12 to 78 deg
over the CMC range). Outside ``plane_palm_deg`` (``thumb_plane_palm_deg``), ``R_L`` is the
smallest rotation taking ``n`` to the clamped elevation at the same azimuth; it is applied to
all three bones of the finger (three row blocks). A bone may then carry two blocks (base and
plane limit) whose targets compete; the plane limit is redundant with the CMC/MCP abduction
limits for our hinge model and exists for fidelity to the seed.

Residual in the parent's frame. A target is stored in the frame of the bone it is measured
against (palm for bases and plane limits, the parent finger bone for upper joints), as
``u = W_p^T R_L a(c^0)``, and the residual is expressed in that frame:

.. math:: r = W_p(\theta)^T a(c^t) - u,

the seed's world-frame residual ``a(c^t) - R_L a(c^0)`` rotated by ``W_p^T``: the same
norm at the start of the round, but it depends on the joint angles only. A target fixed in the
world would resist a motion of the parent (e.g. a global rotation asked for by the image terms)
within a round, and the world-frame residual gives the global rotation non-zero Jacobian columns
along which its norm does not change, so LM drifts along them. With ``w_k`` the world axis of
every revolute DOF ``k`` that moves bone ``p``, ``dW_p / dtheta_k = [w_k]_x W_p`` gives

.. math:: dr / d\theta_k = W_p^T (da / d\theta_k - w_k \times a),

with ``da/dtheta`` from ``keypoints_jac`` (3 rows per block).

Limitation of bone-vector limits (the seed's): a bone vector has two degrees of freedom, so at
90 deg of base flexion the abduction no longer moves it and its limit is not enforced there.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from hand_tracker_ros._typing import BoolArray, FloatArray, IntArray
from hand_tracker_ros.config import param
from hand_tracker_ros.core.context import RoundContext
from hand_tracker_ros.errors import ConfigError
from hand_tracker_ros.geometry.rotations import (
    euler_xzy_from_matrices,
    matrix_from_axis_angle,
    rot_x,
    rot_y,
    rot_z,
)
from hand_tracker_ros.model import kinematics
from hand_tracker_ros.model.hand import HandModel, PosedHand
from hand_tracker_ros.model.layout import P
from hand_tracker_ros.model.skeleton import FINGER_NAMES, RestSkeleton, joint_limits

NAME = 'limits'

_UPPER_JOINTS = {'thumb': ('mcp', 'ip')}
_BASE_BONES = 1 + 3 * np.arange(5)      # each finger's first bone (bone_transforms index)
_BASE_K = 6 + 4 * np.arange(5)          # each finger's base flexion in theta (abduction: + 1)
_UPPER_K = _BASE_K[:, None] + [2, 3]    # its 2nd and 3rd joints' flexion in theta
# A projection shorter than this fraction of its bone has no defined in-plane direction.
_MIN_PROJECTION = 1e-6
# Angles within this of a limit count as inside: rounding at a limit (a straight finger has
# PIP = 0 = its lower limit) must not create rows with zero residuals.
_ANGLE_TOL_RAD = 1e-9


@dataclass(frozen=True)
class JointLimitsConfig:
    """The joint-limit term L."""

    enabled: bool = param(True, 'use the joint-limit term')
    weight: float = param(1e6, 'term weight (cost = 0.5 * weight * |r|^2, r in m; 1e6 makes '
                          '1 mm of bone displacement cost like 1 px)', low=0.0, high=1e12)
    margin_deg: float = param(0.0, 'widen every finger limit of the table by this on both '
                              'sides (negative narrows)', unit='deg', low=-20.0, high=90.0)
    bases: bool = param(True, 'limit the finger bases (MCP, thumb CMC) by Euler clamping')
    upper_joints: bool = param(True, 'limit PIP/DIP and thumb MCP/IP in the finger plane')
    plane_to_palm: bool = param(True, 'limit the elevation of each finger plane over the palm')
    plane_palm_deg: tuple[float, ...] = param(
        (-20.0, 20.0), 'allowed elevation (lower, upper) of a long finger plane normal over '
        'the palm plane', unit='deg', low=-90.0, high=90.0)
    thumb_plane_palm_deg: tuple[float, ...] = param(
        (0.0, 85.0), 'allowed elevation (lower, upper) of the thumb plane normal over the '
        'palm plane', unit='deg', low=-90.0, high=90.0)
    plane_min_aspect: float = param(1e-3, 'joints whose second/first singular value ratio is '
                                    'below this are collinear: the plane normal is then the '
                                    "first bone's flexion axis", low=0.0, high=1.0)


@dataclass(frozen=True, eq=False)
class LimitTargets:
    """The violated limits of one round: one 3-row block per entry.

    Attributes
    ----------
    child_kp, parent_kp : (N,) int64
        Keypoints spanning the bone, ``a = k[child] - k[parent]``.
    frame_bone : (N,) int64
        Bone whose frame holds the target.
    target_local_m : (N, 3) float64
        Target bone vector ``u`` in that frame (m).
    labels : tuple of str
        What each block limits, e.g. 'index_mcp', 'index_pip', 'thumb_plane_distal'.
    """

    child_kp: IntArray
    parent_kp: IntArray
    frame_bone: IntArray
    target_local_m: FloatArray
    labels: tuple[str, ...]

    @property
    def n_residuals(self) -> int:
        """M = 3 x the number of blocks."""
        return 3 * int(self.child_kp.size)


@dataclass(frozen=True, eq=False)
class LimitAngles:
    """Joint angles as this term measures them (rad), FINGER_NAMES order.

    Attributes
    ----------
    base_flex, base_abd, base_twist : (5,) float64
        x-z-y Euler angles of the finger bases (module docstring).
    upper : (5, 2) float64
        In-plane angles at the 2nd and 3rd joints (PIP, DIP; thumb MCP, IP).
    plane_normal : (5, 3) float64
        Unit finger-plane normals (world).
    elevation : (5,) float64
        Elevation of each finger plane normal over the palm plane.
    """

    base_flex: FloatArray
    base_abd: FloatArray
    base_twist: FloatArray
    upper: FloatArray
    plane_normal: FloatArray
    elevation: FloatArray


def local_angles(local_rot: FloatArray) -> FloatArray:
    """Flexion, abduction and twist ``(..., 3)`` (rad) of base joints' local rotations.

    Parameters
    ----------
    local_rot : (..., 3, 3) float64
        ``Q``, each bone's rotation relative to its rest frame on the parent, with
        ``Q^T = Rx(-flex) Rz(abd) Ry(twist)`` (module docstring); twist is found last.
    """
    rot = np.asarray(local_rot, dtype=np.float64)
    return euler_xzy_from_matrices(np.swapaxes(rot, -1, -2)) * np.array([-1.0, 1.0, 1.0])


def local_rotation(flex_rad: float, abd_rad: float, twist_rad: float) -> FloatArray:
    """Inverse of :func:`local_angles`: ``Q = (Rx(-flex) Rz(abd) Ry(twist))^T`` (3, 3)."""
    return (rot_x(-flex_rad) @ rot_z(abd_rad) @ rot_y(twist_rad)).T


def fit_plane_normal(points_m: FloatArray, fallback: FloatArray,
                     min_aspect: float) -> FloatArray:
    """Least-squares plane normals ``(..., 3)`` of point sets ``points_m`` ``(..., K, 3)``,
    each oriented along its ``fallback`` ``(..., 3)``, a unit vector, which is the normal
    where the points are nearly collinear."""
    centred = points_m - points_m.mean(axis=-2, keepdims=True)
    _, sing, vt = np.linalg.svd(centred)
    normal = vt[..., 2, :]
    normal = np.where(np.sum(normal * fallback, axis=-1, keepdims=True) >= 0.0, normal, -normal)
    collinear = sing[..., 1] <= min_aspect * sing[..., 0]
    return np.where(collinear[..., None], fallback, normal)


def _signed_angles(a: FloatArray, b: FloatArray, normals: FloatArray) -> FloatArray:
    """Angles ``(N,)`` (rad) about ``normals`` from ``a`` to ``b`` (all ``(N, 3)``)."""
    # normals . (a x b) written out: np.cross on a few rows costs ~30 us a call.
    (a0, a1, a2), (b0, b1, b2), (n0, n1, n2) = a.T, b.T, normals.T
    sine = n0 * (a1 * b2 - a2 * b1) + n1 * (a2 * b0 - a0 * b2) + n2 * (a0 * b1 - a1 * b0)
    return np.arctan2(sine, np.sum(a * b, axis=-1))


def _project(v: FloatArray, normals: FloatArray) -> FloatArray:
    """Vectors ``v`` ``(..., 3)`` projected on the planes of their unit ``normals``
    ``(..., 3)``."""
    return v - np.sum(v * normals, axis=-1, keepdims=True) * normals


def _moved(clamped: FloatArray, angles: FloatArray) -> BoolArray:
    """Where clamping moved an angle by more than the rounding slack: a violated limit."""
    return np.abs(clamped - angles) > _ANGLE_TOL_RAD


class JointLimitsEnergy:
    """The joint-limit term L (see the module docstring).

    Parameters
    ----------
    config : JointLimitsConfig
    rest : RestSkeleton
        The model's rest geometry (``HandModel.rest``).
    rest_bone_transforms : (B, 4, 4) float64
        Rest bone frames in the hand frame (``HandModel.rest_bone_transforms``).
    """

    name = NAME

    def __init__(self, config: JointLimitsConfig, rest: RestSkeleton,
                 rest_bone_transforms: FloatArray) -> None:
        self.config = config
        self.rest = rest
        self.rest_rot = np.asarray(rest_bone_transforms, dtype=np.float64)[:, :3, :3]
        lower, upper = joint_limits()
        margin = np.deg2rad(config.margin_deg)
        self.lower = np.where(np.arange(P) >= 6, lower - margin, lower)
        self.upper = np.where(np.arange(P) >= 6, upper + margin, upper)
        for field in ('plane_palm_deg', 'thumb_plane_palm_deg'):
            bounds = getattr(config, field)
            if len(bounds) != 2 or bounds[0] > bounds[1]:
                msg = f'`{field}` must be (lower, upper) with lower <= upper, got {bounds!r}'
                raise ConfigError(msg)
        self.plane_range = np.deg2rad(np.array(
            [config.thumb_plane_palm_deg] + [config.plane_palm_deg] * 4))

    @classmethod
    def from_model(cls, config: JointLimitsConfig, model: HandModel) -> JointLimitsEnergy:
        """The term for a :class:`~hand_tracker_ros.model.hand.HandModel`."""
        return cls(config, model.rest, model.rest_bone_transforms)

    def measure(self, posed: PosedHand) -> LimitAngles:
        """The angles this term limits, for a posed hand (``bone_transforms``, ``keypoints_m``)."""
        # All five fingers at once (a loop over them cost about 0.5 ms per fit's rounds).
        rot = posed.bone_transforms[:, :3, :3]
        base = rot[_BASE_BONES]                                          # (5, 3, 3)
        flex, abd, twist = local_angles(
            np.swapaxes(rot[0] @ self.rest_rot[_BASE_BONES], -1, -2) @ base).T
        joints = posed.keypoints_m[1:21].reshape(5, 4, 3)                # finger i: 1 + 4i..
        n = fit_plane_normal(joints, base[:, :, 0], self.config.plane_min_aspect)
        bones = np.diff(joints, axis=1)                                  # (5, 3, 3)
        upper = np.stack([_signed_angles(_project(bones[:, j - 1], n),
                                         _project(bones[:, j], n), n)
                          for j in (1, 2)], axis=1)
        elev = np.arcsin(np.clip(n @ rot[0][:, 2], -1.0, 1.0))
        return LimitAngles(flex, abd, twist, upper, n, elev)

    @property
    def weight(self) -> float:
        """Weight of the term's cost ``0.5 * weight * |r|^2``."""
        return self.config.weight

    def correspond(self, context: RoundContext) -> LimitTargets:
        """Find the violated limits of ``context.posed`` (a RoundContext) and their targets."""
        return self.targets(context.posed)

    def targets(self, posed: PosedHand) -> LimitTargets:
        """The violated limits of ``posed`` and their targets (see :class:`LimitTargets`)."""
        angles = self.measure(posed)
        lower, upper = self.lower, self.upper
        # Every angle clamped to its range at once; a block for each angle the clamp moves.
        flex = np.clip(angles.base_flex, lower[_BASE_K], upper[_BASE_K])
        abd = np.clip(angles.base_abd, lower[_BASE_K + 1], upper[_BASE_K + 1])
        bends = np.clip(angles.upper, lower[_UPPER_K], upper[_UPPER_K])
        elev = np.clip(angles.elevation, self.plane_range[:, 0], self.plane_range[:, 1])
        base_out = self.config.bases & (_moved(flex, angles.base_flex)
                                        | _moved(abd, angles.base_abd))
        upper_out = self.config.upper_joints & _moved(bends, angles.upper)
        plane_out = self.config.plane_to_palm & _moved(elev, angles.elevation)
        blocks: list[tuple[int, int, int, FloatArray, str]] = []
        for i in np.flatnonzero(base_out | upper_out.any(axis=1) | plane_out).tolist():
            finger = FINGER_NAMES[i]
            if base_out[i]:
                blocks.append(self._base_block(posed, angles, i, finger, flex[i], abd[i]))
            for j in np.flatnonzero(upper_out[i]).tolist():
                blocks += self._upper_block(posed, angles, i, j + 1, finger, bends[i, j])
            if plane_out[i]:
                blocks += self._plane_blocks(posed, angles, i, finger, elev[i])
        if not blocks:
            empty = np.zeros(0, dtype=np.int64)
            return LimitTargets(empty, empty, empty, np.zeros((0, 3)), ())
        child, parent, frame, target, labels = zip(*blocks)
        return LimitTargets(np.array(child, dtype=np.int64), np.array(parent, dtype=np.int64),
                            np.array(frame, dtype=np.int64), np.array(target), labels)

    def _base_block(self, posed: PosedHand, angles: LimitAngles, i: int, finger: str,
                    flex_c: float, abd_c: float) -> tuple[int, int, int, FloatArray, str]:
        """The seed's R_L for the base joint of finger ``i``, clamped to ``flex_c, abd_c``."""
        bone = 1 + 3 * i
        rot = posed.bone_transforms[:, :3, :3]
        rest_a = self.rest_rot[bone]
        r_b, r_a = rot[0], rot[bone] @ rest_a.T      # rotations w.r.t. the rest pose
        r_local = r_b.T @ r_a                          # R_{b->a} in the hand frame
        clamped = rest_a @ local_rotation(flex_c, abd_c, angles.base_twist[i]) @ rest_a.T
        r_limit = r_b @ clamped @ r_local.T @ r_b.T @ r_a
        rest_vector = rest_a[:, 1] * self.rest.lengths_m[i, 0]
        joint = 'cmc' if finger == 'thumb' else 'mcp'
        return (2 + 4 * i, 1 + 4 * i, 0, r_b.T @ r_limit @ rest_vector, f'{finger}_{joint}')

    def _upper_block(self, posed: PosedHand, angles: LimitAngles, i: int, j: int, finger: str,
                     clamped: float) -> list[tuple[int, int, int, FloatArray, str]]:
        """The rotation about the finger-plane normal bringing joint ``j`` (1: the 2nd, 2: the
        3rd) of finger ``i`` to ``clamped``; none when the bone is normal to the plane."""
        n, angle = angles.plane_normal[i], angles.upper[i, j - 1]
        bone = posed.keypoints_m[2 + 4 * i + j] - posed.keypoints_m[1 + 4 * i + j]
        proj, length = _project(bone, n), float(np.linalg.norm(bone))
        if np.linalg.norm(proj) <= _MIN_PROJECTION * length:
            return []
        target = matrix_from_axis_angle(n * (clamped - angle)) @ proj
        target *= length / np.linalg.norm(proj)
        frame = 3 * i + j                              # the parent finger bone
        w_p = posed.bone_transforms[frame, :3, :3]
        joint = _UPPER_JOINTS.get(finger, ('pip', 'dip'))[j - 1]
        return [(2 + 4 * i + j, 1 + 4 * i + j, frame, w_p.T @ target, f'{finger}_{joint}')]

    def _plane_blocks(self, posed: PosedHand, angles: LimitAngles, i: int, finger: str,
                      clamped: float) -> list[tuple[int, int, int, FloatArray, str]]:
        """Smallest rotation of the finger plane to the elevation ``clamped``, on all three
        bones; none when the plane normal is the palm normal (no azimuth)."""
        elev = angles.elevation[i]
        palm = posed.bone_transforms[0, :3, :3]
        n, z = angles.plane_normal[i], palm[:, 2]
        horizontal = _project(n, z)
        if np.linalg.norm(horizontal) <= _MIN_PROJECTION:
            return []
        horizontal /= np.linalg.norm(horizontal)
        n_target = np.cos(clamped) * horizontal + np.sin(clamped) * z
        axis = np.cross(n, n_target)
        r_limit = matrix_from_axis_angle(axis / np.linalg.norm(axis) * abs(clamped - elev))
        bones = np.diff(posed.keypoints_m[1 + 4 * i:5 + 4 * i], axis=0)
        segments = ('metacarpal', 'proximal', 'distal') if finger == 'thumb' else (
            'proximal', 'middle', 'distal')
        return [(2 + 4 * i + s, 1 + 4 * i + s, 0, palm.T @ r_limit @ bones[s],
                 f'{finger}_plane_{segments[s]}') for s in range(3)]

    def residuals(self, posed: PosedHand, correspondences: LimitTargets) -> FloatArray:
        """Residuals ``r (M,)`` (m): ``W_p^T a(c^t) - u`` per block, x y z of frame ``p``."""
        c = correspondences
        bone = posed.keypoints_m[c.child_kp] - posed.keypoints_m[c.parent_kp]
        frames = posed.bone_transforms[c.frame_bone, :3, :3]
        return (np.einsum('nji,nj->ni', frames, bone) - c.target_local_m).reshape(-1)

    def jacobian_vertices(self, correspondences: LimitTargets) -> IntArray:
        """No mesh vertex: the rows read ``keypoints_jac`` only."""
        return np.zeros(0, dtype=np.int64)

    def linearize(self, posed: PosedHand, correspondences: LimitTargets
                  ) -> tuple[FloatArray, FloatArray]:
        """Residuals ``r (M,)`` (m) and analytic Jacobian ``J (M, P)`` (m per unit)."""
        c = correspondences
        if c.child_kp.size == 0:
            return np.zeros(0), np.zeros((0, P))
        bone = posed.keypoints_m[c.child_kp] - posed.keypoints_m[c.parent_kp]
        frames = posed.bone_transforms[c.frame_bone, :3, :3]
        r = np.einsum('nji,nj->ni', frames, bone) - c.target_local_m
        # The hinge axes are not part of PosedHand; forward kinematics is cheap (26 DOF).
        axes = kinematics.forward_kinematics(self.rest, posed.theta).axes
        turn = np.cross(axes[None, :, :], bone[:, None, :])             # (N, P, 3)
        turn[:, :3, :] = 0.0
        turn *= kinematics.MOVES.T[c.frame_bone][:, :, None]
        assert posed.keypoints_jac is not None, 'posed without its Jacobian'
        world = posed.keypoints_jac[c.child_kp] - posed.keypoints_jac[c.parent_kp]
        jac = np.einsum('nji,njk->nik', frames, world - turn.transpose(0, 2, 1))
        return r.reshape(-1), jac.reshape(-1, P)
