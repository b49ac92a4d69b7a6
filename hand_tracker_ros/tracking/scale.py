r"""Slow online refinement of the hand's global scale while tracking.

A hand of another size than the model is tracked with the right angles on the wrong-sized
hand, 10-15 mm off for a hand 10 % smaller or larger, and a model too large for the hand
spills over the observed silhouette, so the frames are judged doubtful or LOST and refitted.
``hand-tracker calibrate`` fits the whole shape from a recording; this module only follows
the global ``scale`` (:mod:`hand_tracker_ros.model.shape`) of a hand tracked without one.

**One frame's estimate.** Every length and radius scales with ``s``, so the posed hand scales
about its root, the translation ``t`` of the pose:
:math:`X(\theta, s) = t + (s / s_0)\,(X(\theta, s_0) - t)` exactly, and
:math:`\partial X / \partial s = (X - t) / s_0` at the model's scale :math:`s_0`. With the
terms that see the hand's size (``SIZE_TERMS``: edges, silhouette, fingertips) corresponded
at the frame's fitted pose, their stacked weighted residuals :math:`r` (M,) and Jacobian
:math:`[J_\theta, j_s]` (M, P + 1), the pose is eliminated (Schur complement, as in
:mod:`hand_tracker_ros.calibration.solver`):

.. math::

    I = j_s^T j_s - b^T A^+ b, \qquad g = j_s^T r - b^T A^+ J_\theta^T r, \qquad
    A = J_\theta^T J_\theta, \quad b = J_\theta^T j_s

and one Gauss-Newton step gives the frame's estimate :math:`\hat s = s_0 - g / I` with its
information :math:`I` (:class:`FrameScale`).

**The policy** (:class:`ScaleRefiner`). Every ``every``-th frame at least ``min_confidence``
confident is measured (a model too large for the hand is LOST at first, so LOST frames count
too; a hand out of view is near 0). The estimates since the model last changed are averaged,
weighted by their information with the forgetting factor ``memory``:
:math:`\bar s = \sum_k \rho^{n-k} I_k \hat s_k / \sum_k \rho^{n-k} I_k`. After
``min_estimates`` of them the model starts to follow when :math:`|\bar s / s_0 - 1|` exceeds
``trigger``, and then moves to :math:`\bar s` (at most ``max_step`` relative per move, within
``limits`` times the start scale; the model is rebuilt, the average restarts) until it is within
``settle``. The trigger is larger than the settle band because the estimate is biased low by
1-2 % (the test's frame: 1.079 for a 1.1x hand after six rebuilds); a model that followed it
on hands of the default size lost up to 0.6 mm (README, "Hand shape").
"""
from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from hand_tracker_ros._typing import FloatArray
from hand_tracker_ros.config import param
from hand_tracker_ros.core.context import RoundContext
from hand_tracker_ros.core.energy import Term
from hand_tracker_ros.core.observations import FrameObservations
from hand_tracker_ros.core.shaped_pose import ShapedPose
from hand_tracker_ros.core.views import ModelView
from hand_tracker_ros.model.hand import PosedHand
from hand_tracker_ros.model.layout import Layout
from hand_tracker_ros.tracking.problem import FixedTerms

# Information below this share of j_s^T j_s: the frame does not see the scale.
_MIN_RELATIVE_INFO = 1e-6


@dataclass(frozen=True)
class ScaleConfig:
    """Online refinement of the hand's global scale (module docstring)."""

    enabled: bool = param(True, 'follow the hand\'s global scale while tracking')
    every: int = param(3, 'measure every k-th frame that is confident enough', low=1,
                       high=10000)
    min_confidence: float = param(0.1, 'frames less confident than this are not measured',
                                  low=0.0, high=1.0)
    memory: float = param(0.7, 'forgetting factor of the average of the estimates', low=0.0,
                          high=1.0)
    min_estimates: int = param(2, 'estimates averaged before the model may move', low=1,
                               high=1000)
    trigger: float = param(0.03, 'the model starts to follow when the average differs from '
                           'its scale by more than this (relative)', low=0.0, high=1.0)
    settle: float = param(0.005, 'and follows until it is within this (relative)', low=0.0,
                          high=1.0)
    max_step: float = param(0.02, 'largest relative change of the scale per move', low=0.0,
                            high=1.0)
    limits: tuple[float, float] = param((0.8, 1.25), 'the scale stays within these factors '
                                        'of the start scale', low=0.01, high=100.0)

    def __post_init__(self) -> None:
        if not self.limits[0] <= 1.0 <= self.limits[1]:
            msg = f'`limits` must hold 1 (the start scale), got {tuple(self.limits)}'
            raise ValueError(msg)
        if self.settle > self.trigger:
            msg = f'`settle` ({self.settle}) must not exceed `trigger` ({self.trigger})'
            raise ValueError(msg)


@dataclass(frozen=True)
class ScaleEstimate:
    """One frame's Gauss-Newton estimate of the scale and its information (1 / variance
    up to the residuals' unit variance)."""

    scale: float
    information: float


class FrameScale:
    """The size-seeing terms of one frame, corresponded at its fit, over ``[theta; s]``.

    The hand at pose ``theta`` and scale ``s`` is the model's mesh scaled about the root:
    ``X = t + k (X0 - t)``, ``k = s / s0``, with ``X0`` the model posed at ``theta``, so
    ``dX/dtheta = k dX0/dtheta + (1 - k) dt/dtheta`` and ``dX/ds = (X0 - t) / s0``.

    Parameters
    ----------
    terms : sequence of Term
        The enabled terms of ``SIZE_TERMS``, built for ``posed``'s model.
    posed : PosedHand
        The fit: correspondences are found there, with its ``views``.
    views : sequence of ModelView
    observations : FrameObservations
    """

    def __init__(self, terms: Sequence[Term], posed: PosedHand, views: Sequence[ModelView],
                 observations: FrameObservations) -> None:
        self.theta, self.model = posed.theta, posed.model
        self.fixed = FixedTerms(terms, RoundContext(posed, tuple(views), observations, None))

    def residuals(self, theta: FloatArray, scale: float, *, jacobian: bool
                  ) -> tuple[FloatArray, FloatArray | None]:
        """Stacked ``sqrt(w_i) r_i`` (M,) at pose ``theta`` (P,) and ``scale``, and with
        ``jacobian`` their derivative (M, P + 1) with respect to ``[theta; scale]``."""
        ids, p = self.fixed.vertex_ids, theta.size
        posed = self.model.pose(theta, jacobian=jacobian, jacobian_vertices=ids)
        root = theta[Layout.translation]
        s0 = self.model.shape.scale
        k = scale / s0
        vertices = root + k * (posed.vertices_m - root)
        jac = None
        if jacobian:
            assert posed.vertices_jac is not None
            jac = np.zeros((*vertices.shape, p + 1))
            jac[ids, :, :p] = k * posed.vertices_jac[ids]
            jac[ids, :, Layout.translation] += (1.0 - k) * np.eye(3)
            jac[ids, :, p] = (posed.vertices_m[ids] - root) / s0
        shaped = ShapedPose(np.append(theta, scale), vertices, jac,
                            self.model.fingertip_vertex_ids)
        return self.fixed.rows(shaped, jacobian, p + 1)

    def estimate(self) -> ScaleEstimate | None:
        """The frame's estimate of the scale (module docstring), linearized at its fit and
        the model's scale; None when the frame does not constrain the scale."""
        s0, p = self.model.shape.scale, self.theta.size
        r, J = self.residuals(self.theta, s0, jacobian=True)
        assert J is not None
        j_theta, j_s = J[:, :p], J[:, p]
        b = j_theta.T @ j_s
        solved = np.linalg.lstsq(j_theta.T @ j_theta, np.column_stack([b, j_theta.T @ r]),
                                 rcond=None)[0]
        seen = float(j_s @ j_s)
        information = seen - float(b @ solved[:, 0])
        if not (seen > 0.0 and information > _MIN_RELATIVE_INFO * seen):
            return None
        gradient = float(j_s @ r) - float(b @ solved[:, 1])
        return ScaleEstimate(s0 - gradient / information, information)


class ScaleRefiner:
    """When to measure the scale and where the model's scale goes (module docstring).

    Parameters
    ----------
    config : ScaleConfig
    start_scale : float
        The scale the session started with (``limits`` are relative to it).
    """

    def __init__(self, config: ScaleConfig, start_scale: float) -> None:
        self.config = config
        self.start_scale = float(start_scale)
        self._frames = 0        # confident frames since the last measurement
        self._weight = 0.0      # sum of rho^(n-k) I_k
        self._weighted = 0.0    # sum of rho^(n-k) I_k s_k
        self._count = 0         # estimates since the model last moved
        self._following = False

    def due(self, confidence: float) -> bool:
        """Count a frame of this ``confidence``; True when the scale should be measured on it
        (the count starts again)."""
        if confidence >= self.config.min_confidence:
            self._frames += 1
        if self._frames < self.config.every:
            return False
        self._frames = 0
        return True

    def update(self, scale: float, estimate: ScaleEstimate | None) -> float | None:
        """Take a frame's ``estimate`` (None: not measurable) made with the model at
        ``scale``; the model's new scale, or None to keep it."""
        cfg = self.config
        if estimate is None:
            return None
        self._weight = cfg.memory * self._weight + estimate.information
        self._weighted = cfg.memory * self._weighted + estimate.information * estimate.scale
        self._count += 1
        if self._count < cfg.min_estimates:
            return None
        deviation = abs(self._weighted / self._weight / scale - 1.0)
        if not self._following and deviation > cfg.trigger:
            self._following = True
        elif self._following and deviation <= cfg.settle:
            self._following = False
        if not self._following:
            return None
        step = np.clip(self._weighted / self._weight, scale * (1.0 - cfg.max_step),
                       scale * (1.0 + cfg.max_step))
        new = float(np.clip(step, *(self.start_scale * np.asarray(cfg.limits, float))))
        self._weight = self._weighted = 0.0
        self._count = 0
        return new if new != scale else None
