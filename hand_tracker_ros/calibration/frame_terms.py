r"""One calibration frame: the tracker's image terms as functions of pose *and* shape.

For frame ``k`` with fixed correspondences, the image terms that see the hand's size
(``SIZE_TERMS`` of the registry: edges, silhouette, salient points; their configs and weights
are the tracker's, but the edge term matches the outer silhouette only, below) give residuals
of the posed hand.
Here the hand is posed at ``theta_k`` with the shape ``x`` of
:mod:`hand_tracker_ros.model.shape_jacobian`,
``X(theta_k, x) = X_LBS(theta_k; x0) + D(theta_k, x)``, and every term is linearized against
the stacked parameters ``z_k = [theta_k; x]`` (P + S): the terms only read
``posed.vertices_m``, the rows ``posed.vertices_jac[ids]`` and ``size(posed.theta)``, so a
:class:`~hand_tracker_ros.core.shaped_pose.ShapedPose` whose vertex Jacobian has the
``P + S`` columns ``[dX_LBS/dtheta + dD/dtheta, dD/dx]`` makes each term's analytic Jacobian
the one with respect to ``z_k`` by the chain rule (the test checks it against central
differences).

Correspondences are found on the model built at ``x0`` (where ``D = 0``), as the tracker finds
them, except for the edges of inner contours (a finger before the palm,
``EdgeEnergyConfig.inner_contours`` off). Those are seen only through shading: its fall-off at
an occluding rim places the image edge off the model's contour, and the offset went into the
shape: started at the true shape of a 0.9x pinch, the fit drifted to a palm 7.4 % too long and
fingers 3.8 % too thin on the inner contours alone, 5.5 % and 3.7 % on all of them (+0.6 % and
3.0 % with the palm's points at the fingers' weight, ``palm_sqrt_weight`` 1), and stayed within
0.7 % (scale), 0.2 % (palm) and 1.1 % (thickness) on the outer silhouette's (README, "Hand
shape"). The tracker keeps them: they place the fingers before the palm (tracking on the outer
ones alone: 3.01 against 2.26 mm, the mean of seven bags).
"""
from __future__ import annotations

import dataclasses
from collections.abc import Sequence
from typing import cast

import numpy as np

from hand_tracker_ros._typing import FloatArray
from hand_tracker_ros.core.context import RoundContext
from hand_tracker_ros.core.energy import Term
from hand_tracker_ros.core.observations import FrameObservations
from hand_tracker_ros.core.shaped_pose import ShapedPose
from hand_tracker_ros.core.views import model_views
from hand_tracker_ros.energies.registry import TermsConfig, size_terms
from hand_tracker_ros.geometry.camera_model import Camera
from hand_tracker_ros.model.hand import HandModel, PosedHand
from hand_tracker_ros.model.shape_jacobian import S, ShapeRig
from hand_tracker_ros.render.contours import model_edges
from hand_tracker_ros.tracking.problem import FixedTerms


class FrameTerms:
    """The image terms of one frame with correspondences fixed, over ``z = [theta; x]``.

    Parameters
    ----------
    model : HandModel
        Built at the shape ``x0`` the correspondences are found with.
    rig : ShapeRig
        ``ShapeRig.vertices(model)``.
    terms : sequence of Term
    cameras : sequence of Camera
    observations : FrameObservations
    theta : (P,) float64
        Pose at which the correspondences are found.
    """

    def __init__(self, model: HandModel, rig: ShapeRig, terms: Sequence[Term],
                 cameras: Sequence[Camera], observations: FrameObservations,
                 theta: FloatArray) -> None:
        self.model = model
        posed = model.pose(theta, jacobian=False)
        views = model_views(posed, model_edges(model), tuple(cameras))
        self.fixed = FixedTerms(terms, RoundContext(posed, views, observations, None))
        # Only the rows the terms read are displaced and get Jacobian rows.
        self._rig = rig.subset(self.fixed.vertex_ids)

    def shaped(self, theta: FloatArray, x: FloatArray, *, jacobian: bool) -> ShapedPose:
        """The hand at ``theta`` (P,) and shape ``x`` (S,); only the rows the terms read are
        displaced and have Jacobian rows (the others are the model's, with zero rows)."""
        ids = self.fixed.vertex_ids
        posed = self.model.pose(theta, jacobian=jacobian, jacobian_vertices=ids)
        moved = self._rig.displace(posed._fk, x, jacobian=jacobian)
        vertices = posed.vertices_m.copy()
        vertices[ids] += moved.displacement_m
        jac = None
        if jacobian:
            jac = np.zeros((vertices.shape[0], 3, theta.size + S))
            # Both made with their Jacobians above.
            assert posed.vertices_jac is not None and moved.pose_jac is not None
            jac[ids, :, :theta.size] = posed.vertices_jac[ids] + moved.pose_jac
            jac[ids, :, theta.size:] = moved.shape_jac
        return ShapedPose(np.concatenate([theta, x]), vertices, jac,
                          self.model.fingertip_vertex_ids)

    def residuals(self, theta: FloatArray, x: FloatArray, *, jacobian: bool
                  ) -> tuple[FloatArray, FloatArray | None]:
        """Stacked ``sqrt(w_i) r_i`` (M,) and, with ``jacobian``, their ``dr/dz`` (M, P + S)."""
        return self.fixed.rows(self.shaped(theta, x, jacobian=jacobian), jacobian,
                               theta.size + S)

    def squares(self, theta: FloatArray, x: FloatArray) -> dict[str, tuple[float, int]]:
        """Per term: ``|r|^2`` (the term's units squared, without its weight) and the row
        count at ``theta``, ``x``."""
        shaped = self.shaped(theta, x, jacobian=False)
        out = {}
        # The size terms read only what a ShapedPose has (tracking.problem.weighted_rows).
        hand = cast(PosedHand, shaped)
        for t, c in zip(self.fixed.terms, self.fixed.correspondences):
            r = t.energy.residuals(hand, c)
            out[t.name] = (float(r @ r), int(r.size))
        return out


def frame_terms(model: HandModel, cameras: Sequence[Camera],
                observations: Sequence[FrameObservations], thetas: FloatArray,
                config: TermsConfig = TermsConfig()) -> list[FrameTerms]:
    """One :class:`FrameTerms` per frame; ``thetas`` (N, P) float64."""
    rig = ShapeRig.vertices(model)
    outer = dataclasses.replace(config.edges, inner_contours=False)
    terms = size_terms(dataclasses.replace(config, edges=outer), model)
    return [FrameTerms(model, rig, terms, cameras, obs, theta)
            for obs, theta in zip(observations, thetas)]

