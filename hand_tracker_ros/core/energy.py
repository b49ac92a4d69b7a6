"""The protocol every energy term follows (house rule 6).

An energy term maps the posed hand and the observations of one frame to residuals ``r (M,)``
and their analytic Jacobian ``J = dr/dtheta (M, P)``. Terms are stateless: everything a term
needs from the data (edge matches, flow targets, the fingertip assignment, colliding triangle
pairs, ...) is found once per *correspondence round* by :meth:`Energy.correspond` and returned
as an immutable value, which is then held fixed for the Levenberg-Marquardt call of that round,
so trial steps keep the residual count ``M`` constant. The problem stacks
``sqrt(weight) * r`` of every enabled term; the order of terms never matters.

Each term also names the mesh vertices its Jacobian rows read (``jacobian_vertices``): the
problem poses the hand with the vertex Jacobian of their union only (about a third of the
mesh), so a term must read no other row of ``posed.vertices_jac`` (the tracking test checks
the stacked Jacobian against the one from a fully posed hand).

Cost convention: a term's cost is ``0.5 * weight * |r|^2``.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Protocol, TypeVar, runtime_checkable

from hand_tracker_ros._typing import FloatArray, IntArray
from hand_tracker_ros.core.context import RoundContext
from hand_tracker_ros.core.observations import FrameObservations
from hand_tracker_ros.model.hand import PosedHand

#: The correspondences of one term for one round (an immutable value, the term's own type).
C = TypeVar('C')


class Energy(Protocol[C]):
    """One energy term: correspondences per round, residuals and analytic Jacobian per step.

    ``C`` is the term's correspondence type, e.g. ``EdgeEnergy`` is an
    ``Energy[EdgeCorrespondences]``; the problem stacks terms of different ``C``.
    """

    #: The term's name, its key in the configuration (``TermsConfig``) and in the cost table.
    name: str

    @property
    def weight(self) -> float:
        """Configured weight of the term's cost ``0.5 * weight * |r|^2``."""

    def correspond(self, context: RoundContext) -> C:
        """Find this term's correspondences for one round.

        ``context`` carries the posed hand at the start of the round, the per-camera model
        views (render, visibility, contours) and the frame's observations. The returned value
        is immutable and fixes the residual count for the round.
        """

    def residuals(self, posed: PosedHand, correspondences: C) -> FloatArray:
        """Residuals ``r (M,)`` of the posed hand for fixed correspondences."""

    def linearize(self, posed: PosedHand, correspondences: C
                  ) -> tuple[FloatArray, FloatArray]:
        """Residuals ``r (M,)`` and analytic Jacobian ``dr/dtheta (M, P)``."""

    def jacobian_vertices(self, correspondences: C) -> IntArray:
        """Mesh vertices (K,) int64 whose rows of ``posed.vertices_jac`` ``linearize`` reads
        (repeats allowed); the problem skins only the union of these with their Jacobian."""


@runtime_checkable
class PreparesFrames(Protocol):
    """An energy with per-frame work that does not depend on the pose (e.g. lookup tables of
    the observed mask), done once per frame set where it is observed: on the observing
    thread, while the previous set is being fitted on another."""

    def prepare(self, observations: FrameObservations) -> None:
        """Compute and cache in ``observations`` what later rounds of the frame read; the
        results are those the rounds would compute themselves."""


@dataclass(frozen=True)
class Term:
    """An energy term with its weight (cost = 0.5 * weight * |r|^2)."""

    energy: Energy[Any]   # terms of any correspondence type are stacked together
    weight: float

    @property
    def name(self) -> str:
        """The energy's name."""
        return self.energy.name
