r"""How the posed hand moves when its shape changes: the calibration's shape model.

A :class:`~.hand.HandModel` is built for one shape ``x0`` (the 19-vector of
:meth:`~.shape.HandShape.to_vector`, ``SHAPE_NAMES`` order: scale ``s``, palm length ``PL``
and width ``PW``, 15 segment lengths ``l_il``, radius factor ``rs``). Its mesh comes from
marching cubes, so two shapes have different vertices; the calibration instead moves the
vertices of the ``x0`` mesh with the shape, and rebuilds the mesh between its rounds.

Every vertex (and keypoint) is attached to its dominant bone ``b`` with rest coordinates
``q0`` in that bone's frame. Rest rotations and joint angles do not depend on the shape, so
with the posed bone rotations ``R_b(theta)`` the displacement from ``x0`` to ``x`` is

.. math::

    D(\theta, x) = \underbrace{R_{palm}\,\Delta base_i
                   + \sum_{l' < l} R_{i l'} e_y \, \Delta L_{i l'}}_{C_b:\ \text{bone origin}}
                   + R_b \, \Delta q

with ``L_il = s l_il``, ``base_i = base0_i * (s PW / s0 PW0, s PL / s0 PL0, s / s0)`` (the
skeleton places the base joints at fixed fractions of the palm size) and the vertex's own
deformation

- finger bone of rest length ``L0``: ``q = (k q0x, q0y + (L - L0) u, k q0z)`` with
  ``u = clip(q0y / L0, 0, 1)`` (stretched along the bone, the tip cap moving with its end)
  and ``k = s rs / (s0 rs0)`` (thickness);
- palm: ``q = q0 * (s PW / s0 PW0, s PL / s0 PL0, k)``.

The posed hand at shape ``x`` is ``X(theta, x) = X_LBS(theta; x0) + D(theta, x)``.
Keypoints (joint centres, and tips at ``(0, L_i2, 0)`` in the distal bone) follow this
exactly: for them ``X(theta, x)`` equals the keypoints of the model built at ``x`` (the test
checks it). Jacobians, with ``w`` any fixed vector carried by bone ``b``:

.. math::

    \frac{\partial D}{\partial x} = \frac{\partial C_b}{\partial x}
        + R_b \frac{\partial q}{\partial x}, \qquad
    \frac{\partial (R_b w)}{\partial \theta_k} = a_k \times (R_b w) \;
        [\text{DOF } k \text{ moves } b]

(``a_k`` the world hinge axis of :mod:`.kinematics`; translations move no direction), so
``dX/dtheta = dX_LBS/dtheta + dD/dtheta``, which is ``dX_LBS/dtheta`` at ``x = x0``.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from hand_tracker_ros._typing import FloatArray, IntArray
from hand_tracker_ros.model import kinematics
from hand_tracker_ros.model.hand import HandModel
from hand_tracker_ros.model.shape import SHAPE_NAMES
from hand_tracker_ros.model.skeleton import KEYPOINT_BONES, B

S = len(SHAPE_NAMES)
_SCALE, _PL, _PW, _RS = 0, 1, 2, S - 1
# Shape index of segment l of finger i: (5, 3).
_SEGMENT = 3 + 3 * np.arange(5)[:, None] + np.arange(3)[None, :]


@dataclass(frozen=True, eq=False)
class ShapeDisplacement:
    """Displacement ``D`` (N, 3) m and its Jacobians at one pose and shape.

    Attributes
    ----------
    displacement_m : (N, 3) float64
    shape_jac : (N, 3, S) float64 or None
        ``dD/dx`` (m per shape unit; SHAPE_NAMES order); None without ``jacobian``.
    pose_jac : (N, 3, P) float64 or None
        ``dD/dtheta`` (zero at ``x = x0``); None without ``jacobian``.
    """

    displacement_m: FloatArray
    shape_jac: FloatArray | None
    pose_jac: FloatArray | None


@dataclass(frozen=True, eq=False)
class ShapeRig:
    """Points of a model attached to bones, ready to be displaced by a shape change.

    Attributes
    ----------
    x0 : (S,) float64
        The model's shape vector.
    bones : (N,) int64
        Dominant bone of every point.
    local_m : (N, 3) float64
        Rest coordinates ``q0`` in that bone's frame.
    base_m : (5, 3) float64
        Base joints of ``x0`` in the hand frame.
    lengths_m : (5, 3) float64
        Segment lengths of ``x0``.
    """

    x0: FloatArray
    bones: IntArray
    local_m: FloatArray
    base_m: FloatArray
    lengths_m: FloatArray

    @classmethod
    def vertices(cls, model: HandModel) -> ShapeRig:
        """The mesh vertices of ``model``, each on its dominant bone (``vertex_part``)."""
        bones = model.vertex_part.astype(np.int64)
        inv = np.linalg.inv(model.rest_bone_transforms)[bones]
        local = np.einsum('nij,nj->ni', inv[:, :3, :3], model.rest_vertices_m) + inv[:, :3, 3]
        return cls(model.shape.to_vector(), bones, local, model.rest.base_m,
                   model.rest.lengths_m)

    @classmethod
    def keypoints(cls, model: HandModel) -> ShapeRig:
        """The 21 keypoints of ``model`` (KEYPOINT_BONES)."""
        return cls(model.shape.to_vector(), np.asarray(KEYPOINT_BONES, dtype=np.int64),
                   model.keypoint_local_m, model.rest.base_m, model.rest.lengths_m)

    def subset(self, ids: IntArray) -> ShapeRig:
        """The rig of the points ``ids`` (K,) int64 only."""
        return ShapeRig(self.x0, self.bones[ids], self.local_m[ids], self.base_m,
                        self.lengths_m)

    def _local(self, x: FloatArray) -> tuple[FloatArray, FloatArray]:
        """Deformed local coordinates ``q - q0`` (N, 3) and ``dq/dx`` (N, 3, S)."""
        x0, q0 = self.x0, self.local_m
        n = len(self.bones)
        k0 = x0[_SCALE] * x0[_RS]
        kx, ky = (x0[_SCALE] * x0[_PW], x0[_SCALE] * x0[_PL])
        dq = np.zeros((n, 3))
        jac = np.zeros((n, 3, S))
        palm = self.bones == 0
        finger = ~palm
        # Thickness (finger x, z; palm z) scales with s * rs.
        radial = np.where(finger[:, None], np.array([1.0, 0.0, 1.0]), np.array([0.0, 0.0, 1.0]))
        ratio_r = x[_SCALE] * x[_RS] / k0
        dq += radial * q0 * (ratio_r - 1.0)
        jac[:, :, _SCALE] += radial * q0 * x[_RS] / k0
        jac[:, :, _RS] += radial * q0 * x[_SCALE] / k0
        # Palm x and y scale with the palm width and length.
        for axis, idx, ref in ((0, _PW, kx), (1, _PL, ky)):
            ratio = x[_SCALE] * x[idx] / ref
            dq[palm, axis] += q0[palm, axis] * (ratio - 1.0)
            jac[palm, axis, _SCALE] += q0[palm, axis] * x[idx] / ref
            jac[palm, axis, idx] += q0[palm, axis] * x[_SCALE] / ref
        # Finger points stretch along their bone (+y).
        fi, lvl = np.divmod(self.bones[finger] - 1, 3)
        seg = _SEGMENT[fi, lvl]
        length0 = self.lengths_m[fi, lvl]
        u = np.clip(q0[finger, 1] / length0, 0.0, 1.0)
        rows = np.flatnonzero(finger)
        dq[rows, 1] += (x[_SCALE] * x[seg] - length0) * u
        jac[rows, 1, _SCALE] += x[seg] * u
        jac[rows, 1, seg] += x[_SCALE] * u
        return dq, jac

    def _origins(self, x: FloatArray) -> tuple[FloatArray, FloatArray]:
        """Hand-frame pieces of every bone origin's displacement.

        Returns ``w`` (B, 4, 3) and ``dw/dx`` (B, 4, 3, S): piece 0 is carried by the palm
        (the base joint), piece ``1 + l'`` by segment ``l'`` of the finger (zero unless
        ``l' < l``).
        """
        x0 = self.x0
        ref = np.array([x0[_SCALE] * x0[_PW], x0[_SCALE] * x0[_PL], x0[_SCALE]])
        fac = np.array([x[_SCALE] * x[_PW], x[_SCALE] * x[_PL], x[_SCALE]]) / ref
        dfac = np.zeros((3, S))
        dfac[:, _SCALE] = np.array([x[_PW], x[_PL], 1.0]) / ref
        dfac[0, _PW], dfac[1, _PL] = x[_SCALE] / ref[0], x[_SCALE] / ref[1]
        w, dw = np.zeros((B, 4, 3)), np.zeros((B, 4, 3, S))
        for i in range(5):
            for lvl in range(3):
                b = 1 + 3 * i + lvl
                w[b, 0] = self.base_m[i] * (fac - 1.0)
                dw[b, 0] = self.base_m[i][:, None] * dfac
                for prev in range(lvl):
                    seg = _SEGMENT[i, prev]
                    w[b, 1 + prev, 1] = x[_SCALE] * x[seg] - self.lengths_m[i, prev]
                    dw[b, 1 + prev, 1, _SCALE] = x[seg]
                    dw[b, 1 + prev, 1, seg] = x[_SCALE]
        return w, dw

    def displace(self, fk: kinematics.FKResult, x: FloatArray, *, jacobian: bool = True
                 ) -> ShapeDisplacement:
        """``D`` and, with ``jacobian``, ``dD/dx`` and ``dD/dtheta`` at the posed skeleton
        ``fk`` and shape ``x`` (S,)."""
        rot = fk.bone_transforms[:, :3, :3]
        moves = kinematics.MOVES.astype(np.float64)        # (P, B)
        w, dw = self._origins(x)
        # Piece p of bone b is carried by bone carrier[b, p] (0 = palm, else segment l').
        carrier = np.zeros((B, 4), dtype=np.int64)
        for b in range(1, B):
            carrier[b, 1:] = 1 + 3 * ((b - 1) // 3) + np.arange(3)
        world = np.einsum('bpij,bpj->bpi', rot[carrier], w)             # (B, 4, 3)
        origin = world.sum(axis=1)
        dq, dq_jac = self._local(x)
        r = rot[self.bones]
        own = np.einsum('nij,nj->ni', r, dq)
        disp = origin[self.bones] + own
        if not jacobian:
            return ShapeDisplacement(disp, None, None)
        origin_jac = np.einsum('bpij,bpjs->bis', rot[carrier], dw)     # (B, 3, S)
        axes = fk.axes.copy()
        axes[:3] = 0.0                                                   # translations
        # d(R w)/dtheta_k = a_k x (R w) for the DOF moving the carrier.
        origin_pose = np.einsum('bpk,bpki->bik', moves.T[carrier],
                                np.cross(axes[None, None], world[:, :, None, :]))
        shape_jac = origin_jac[self.bones] + np.einsum('nij,njs->nis', r, dq_jac)
        own_pose = np.cross(axes[None], own[:, None, :]) * moves.T[self.bones][:, :, None]
        pose_jac = origin_pose[self.bones] + own_pose.transpose(0, 2, 1)
        return ShapeDisplacement(disp, shape_jac, pose_jac)
