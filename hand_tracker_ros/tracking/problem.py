"""The tracking objective: weighted energy terms stacked for Levenberg-Marquardt.

With fixed correspondences ``c_i`` for every enabled term ``i``, the objective of one round is

    F(theta) = sum_i 0.5 * w_i * |r_i(theta; c_i)|^2 = 0.5 * |r(theta)|^2,
    r = [sqrt(w_1) r_1; ...; sqrt(w_n) r_n],   J = dr/dtheta = [sqrt(w_i) J_i]

where each ``r_i, J_i`` comes from the term's ``linearize`` on the model posed at ``theta``.
Terms are independent: their order does not matter (house rule 6).
"""
from __future__ import annotations

import math
from collections.abc import Sequence
from typing import cast

import numpy as np

from hand_tracker_ros._typing import FloatArray, IntArray
from hand_tracker_ros.core.context import RoundContext
from hand_tracker_ros.core.energy import Term
from hand_tracker_ros.core.shaped_pose import ShapedPose
from hand_tracker_ros.model.hand import HandModel, PosedHand
from hand_tracker_ros.optim.lm import ResidualFunction


class Problem:
    """Weighted terms over the pose of one hand model."""

    def __init__(self, model: HandModel, terms: Sequence[Term]) -> None:
        self.model = model
        self.terms = tuple(t for t in terms if t.weight > 0.0)

    @property
    def names(self) -> tuple[str, ...]:
        """Names of the active terms, in stacking order."""
        return tuple(t.name for t in self.terms)

    def correspond(self, context: RoundContext) -> tuple[object, ...]:
        """Correspondences of every term for one round."""
        return tuple(t.energy.correspond(context) for t in self.terms)

    def function(self, correspondences: Sequence[object]) -> ResidualFunction:
        """The stacked residual function of one round, for :func:`levenberg_marquardt`."""
        scales = [math.sqrt(t.weight) for t in self.terms]
        # Skin with the Jacobian only the vertices some row reads (a third of the mesh).
        needed = read_vertices(self.terms, correspondences,
                               self.model.rest_vertices_m.shape[0])

        def fun(theta: FloatArray, jacobian: bool) -> tuple[FloatArray, FloatArray | None]:
            posed = self.model.pose(theta, jacobian=jacobian, jacobian_vertices=needed)
            return weighted_rows(self.terms, correspondences, scales, posed, jacobian,
                                 theta.size)

        return fun

    def costs(self, theta: FloatArray, correspondences: Sequence[object]) -> dict[str, float]:
        """Per-term cost ``0.5 * w * |r|^2`` at ``theta``."""
        posed = self.model.pose(theta, jacobian=False)
        return {t.name: 0.5 * t.weight * float(np.sum(t.energy.residuals(posed, c) ** 2))
                for t, c in zip(self.terms, correspondences)}


class FixedTerms:
    """Terms with their correspondences found once, in ``context``, and their weighted rows
    on any hand the terms can read: a :class:`PosedHand` or a
    :class:`~hand_tracker_ros.core.shaped_pose.ShapedPose` with parameters beyond the pose
    (the calibration's shape, the online scale). Such a hand needs Jacobian rows only for
    :attr:`vertex_ids`.

    Parameters
    ----------
    terms : sequence of Term
    context : RoundContext
        The posed hand (its model's mesh), its views and the observations.
    """

    def __init__(self, terms: Sequence[Term], context: RoundContext) -> None:
        self.terms = tuple(terms)
        self.correspondences = tuple(t.energy.correspond(context) for t in self.terms)
        model = context.posed.model
        self.vertex_ids = read_vertices(self.terms, self.correspondences,
                                        model.rest_vertices_m.shape[0],
                                        model.fingertip_vertex_ids)

    def rows(self, posed: PosedHand | ShapedPose, jacobian: bool, n_params: int
             ) -> tuple[FloatArray, FloatArray | None]:
        """Stacked ``sqrt(w_i) r_i`` (M,) at ``posed`` and, with ``jacobian``, their
        Jacobian (M, ``n_params``) (:func:`weighted_rows`)."""
        return weighted_rows(self.terms, self.correspondences,
                             [math.sqrt(t.weight) for t in self.terms], posed, jacobian,
                             n_params)


def read_vertices(terms: Sequence[Term], correspondences: Sequence[object], n_vertices: int,
                  also: IntArray | None = None) -> IntArray:
    """The mesh vertices (K,) int64, ascending and unique, whose Jacobian rows the terms read
    with these correspondences (``Energy.jacobian_vertices``), and ``also``: a mask over the
    ``n_vertices`` of the mesh (``np.unique`` sorted the repeats, 0.1-0.3 ms a round)."""
    read = np.zeros(n_vertices, dtype=bool)
    for term, corr in zip(terms, correspondences):
        read[term.energy.jacobian_vertices(corr)] = True
    if also is not None:
        read[also] = True
    return np.flatnonzero(read)


def weighted_rows(terms: Sequence[Term], correspondences: Sequence[object],
                  scales: Sequence[float], posed: PosedHand | ShapedPose, jacobian: bool,
                  n_params: int) -> tuple[FloatArray, FloatArray | None]:
    """``r = [s_1 r_1; ...]`` (M,) of the terms at ``posed`` with their correspondences and
    ``s_i = sqrt(w_i)``, and with ``jacobian`` ``J = [s_1 J_1; ...]`` (M, ``n_params``).
    A :class:`ShapedPose` is read by terms that read only what it has (its module docstring;
    the calibration's and the online scale's terms), though the energies' signatures name
    :class:`PosedHand`."""
    hand = cast(PosedHand, posed)
    rows: list[FloatArray] = []
    jacs: list[FloatArray] = []
    for term, corr, scale in zip(terms, correspondences, scales):
        if jacobian:
            r, J = term.energy.linearize(hand, corr)
            jacs.append(J)
        else:
            r = term.energy.residuals(hand, corr)
        rows.append(scale * r)
    r_all = np.concatenate(rows) if rows else np.zeros(0)
    if not jacobian:
        return r_all, None
    if not jacs:
        return r_all, np.zeros((0, n_params))
    # Stacked first, then scaled in place: one pass over J instead of a scaled copy per term.
    J_all = np.vstack(jacs)
    J_all *= np.repeat(scales, [r.size for r in rows])[:, None]
    return r_all, J_all
