"""What one correspondence round sees: the posed hand, its views, the observations and history.

:class:`RoundContext` is the argument of every ``Energy.correspond``; :class:`PreviousFrame`
carries the estimate of the previous frame(s) for the flow and temporal terms, and
:class:`CollisionPairs` the cone-field constraints a frame's earlier rounds found.
"""
from __future__ import annotations

from dataclasses import dataclass

from hand_tracker_ros._typing import FloatArray, IntArray
from hand_tracker_ros.core.observations import FrameObservations
from hand_tracker_ros.core.views import ModelView
from hand_tracker_ros.model.hand import PosedHand


@dataclass(frozen=True)
class CollisionPairs:
    """Constraints of one correspondence round.

    Attributes
    ----------
    face_pairs : (K, 2) int64
        Intersecting faces of non-adjacent parts found at the start of the round.
    vertex_ids : (M,) int64
        Intruding vertex of each constraint.
    face_ids : (M,) int64
        Receiver face of each constraint.
    """

    face_pairs: IntArray
    vertex_ids: IntArray
    face_ids: IntArray

    @property
    def n_residuals(self) -> int:
        """Number of residuals ``M``."""
        return int(self.vertex_ids.size)


@dataclass(frozen=True, eq=False)
class PreviousFrame:
    """The estimate of the previous frame(s), for the flow and temporal terms.

    Attributes
    ----------
    posed : PosedHand
        The model posed at the previous frame's estimate (``theta[t-1]``).
    views : tuple of ModelView
        Its per-camera views (visibility at t-1 decides which points flow may carry).
    thetas : (K, P) float64
        The last K estimates, oldest first (K >= 1; the temporal prior uses up to 2).
    """

    posed: PosedHand
    views: tuple[ModelView, ...]
    thetas: FloatArray


@dataclass(frozen=True, eq=False)
class RoundContext:
    """Everything ``Energy.correspond`` may use for one correspondence round.

    ``collisions`` holds the cone-field constraints of the frame's earlier rounds, which the
    collision term keeps (a round's LM steps could otherwise slide a finger back into a
    contact an earlier round resolved, unseen until the next round).
    """

    posed: PosedHand
    views: tuple[ModelView, ...]
    observations: FrameObservations
    previous: PreviousFrame | None
    collisions: CollisionPairs | None = None
