r"""T, the temporal prior: the 3D keypoints stay near their prediction from the previous frames.

As in htrack's temporal term, the prior acts on the 21 joint positions rather than on the
pose vector, so that the wrist translation (m), the global rotation and the finger angles
(rad) are weighed by how far they actually move the hand and no root-vs-fingertip scale
balance has to be tuned. With ``k(theta)`` the keypoints (21, 3) posed through the model and
``theta_{t-1}``, ``theta_{t-2}`` the last estimates (``RoundContext.previous.thetas``, oldest
first), the prediction is

.. math::

    \hat k = 2 k(\theta_{t-1}) - k(\theta_{t-2})     \quad \text{('constant_velocity')}
    \hat k = k(\theta_{t-1})                          \quad \text{('damping', or one frame)}

and the residual is ``r = vec(k(theta) - k_hat)`` (M = 63, m, keypoint-major x y z), with
the Jacobian ``keypoints_jac``. With only one previous frame the constant-velocity mode damps
towards it; without a previous frame the term is empty (M = 0). The constant-velocity
prediction need not be reachable by any pose (bone lengths are not preserved by
extrapolation); the prior then pulls towards the nearest pose in the least-squares sense.
Residuals are in m, so the weight is relative to the px residuals of the image terms:
``weight = 1e4`` makes 1 cm on one keypoint cost like 1 px on one image point.

References: docs/references.md.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from hand_tracker_ros._typing import FloatArray, IntArray
from hand_tracker_ros.checks import check_finite, check_shape
from hand_tracker_ros.config import param
from hand_tracker_ros.core.context import RoundContext
from hand_tracker_ros.model import kinematics
from hand_tracker_ros.model.hand import HandModel, PosedHand
from hand_tracker_ros.model.layout import P
from hand_tracker_ros.model.skeleton import KEYPOINT_BONES, RestSkeleton

NAME = 'temporal'
MODES = ('constant_velocity', 'damping')


@dataclass(frozen=True)
class TemporalConfig:
    """The temporal prior T."""

    enabled: bool = param(True, 'use the temporal prior')
    weight: float = param(1e4, 'term weight (cost = 0.5 * weight * |r|^2, r in m; 1e4 makes '
                          '1 cm on one keypoint cost like 1 px)', low=0.0, high=1e12)
    mode: str = param('constant_velocity', 'prediction from the previous frames: '
                      "'constant_velocity' (2 k[t-1] - k[t-2]; k[t-1] with one frame) or "
                      "'damping' (k[t-1])", choices=MODES)


@dataclass(frozen=True, eq=False)
class TemporalTarget:
    """The predicted keypoints of one frame.

    Attributes
    ----------
    keypoints_m : (K, 3) float64
        Prediction in KEYPOINT_NAMES order (K = 21), or (0, 3) without a previous frame.
    """

    keypoints_m: FloatArray

    @property
    def n_residuals(self) -> int:
        """M = 3 K."""
        return int(self.keypoints_m.size)


class TemporalEnergy:
    """The temporal prior T (see the module docstring).

    Parameters
    ----------
    config : TemporalConfig
    rest : RestSkeleton
        The model's rest geometry (``HandModel.rest``).
    keypoint_local_m : (21, 3) float64
        Keypoints in their bone frames (``HandModel.keypoint_local_m``).
    """

    name = NAME

    def __init__(self, config: TemporalConfig, rest: RestSkeleton,
                 keypoint_local_m: FloatArray) -> None:
        self.config = config
        self.rest = rest
        self.keypoint_local_m = np.asarray(keypoint_local_m, dtype=np.float64)
        check_shape('keypoint_local_m', self.keypoint_local_m, (len(KEYPOINT_BONES), 3))
        self._bones = np.asarray(KEYPOINT_BONES, dtype=np.int64)

    @classmethod
    def from_model(cls, config: TemporalConfig, model: HandModel) -> TemporalEnergy:
        """The term for a :class:`~hand_tracker_ros.model.hand.HandModel`."""
        return cls(config, model.rest, model.keypoint_local_m)

    def keypoints(self, theta: FloatArray) -> FloatArray:
        """Keypoints (21, 3) float64 (m) of the model at ``theta`` (P,)."""
        fk = kinematics.forward_kinematics(self.rest, theta)
        return kinematics.transform_points(fk, self._bones, self.keypoint_local_m)

    def predict(self, thetas: FloatArray) -> TemporalTarget:
        """Prediction from the last estimates ``thetas`` (K, P) float64, oldest first.

        Raises
        ------
        ShapeError
            If ``thetas`` is not (K, P) or not finite.
        """
        thetas = np.asarray(thetas, dtype=np.float64)
        check_shape('thetas', thetas, (None, P))
        check_finite('thetas', thetas)
        if thetas.shape[0] == 0:
            return TemporalTarget(np.zeros((0, 3)))
        last = self.keypoints(thetas[-1])
        if self.config.mode == 'damping' or thetas.shape[0] == 1:
            return TemporalTarget(last)
        return TemporalTarget(2.0 * last - self.keypoints(thetas[-2]))

    @property
    def weight(self) -> float:
        """Weight of the term's cost ``0.5 * weight * |r|^2``."""
        return self.config.weight

    def correspond(self, context: RoundContext) -> TemporalTarget:
        """The prediction from ``context.previous.thetas`` (empty without a previous frame)."""
        if context.previous is None:
            return TemporalTarget(np.zeros((0, 3)))
        return self.predict(context.previous.thetas)

    def residuals(self, posed: PosedHand, correspondences: TemporalTarget) -> FloatArray:
        """Residuals ``r (M,)`` (m): ``k(theta) - k_hat``, keypoint-major x y z."""
        target = correspondences.keypoints_m
        if target.shape[0] == 0:
            return np.zeros(0)
        return (posed.keypoints_m - target).reshape(-1)

    def jacobian_vertices(self, correspondences: TemporalTarget) -> IntArray:
        """No mesh vertex: the rows read ``keypoints_jac`` only."""
        return np.zeros(0, dtype=np.int64)

    def linearize(self, posed: PosedHand, correspondences: TemporalTarget
                  ) -> tuple[FloatArray, FloatArray]:
        """Residuals ``r (M,)`` (m) and analytic Jacobian ``J (M, P)`` (m per unit)."""
        if correspondences.keypoints_m.shape[0] == 0:
            return np.zeros(0), np.zeros((0, P))
        assert posed.keypoints_jac is not None, 'posed without its Jacobian'
        return (self.residuals(posed, correspondences),
                posed.keypoints_jac.reshape(-1, P))
