"""What the tracking session reports for one frame set: status, estimate and confidence.

These are the values that cross into the ROS adapters (``HandState``, ``JointState``,
markers, ``/diagnostics``) and into the offline estimates bags, so they live below both.
"""
from __future__ import annotations

from dataclasses import dataclass, field

from hand_tracker_ros._typing import FloatArray
from hand_tracker_ros.model.hand import PosedHand
from hand_tracker_ros.optim.lm import FitStatus
from hand_tracker_ros.status import TrackStatus


@dataclass(frozen=True, eq=False)
class TrackResult:
    """The estimate of one frame set.

    Attributes
    ----------
    stamp_ns : int
        Stamp of the input set (ns).
    status : TrackStatus
        TRACKING when the estimate is trusted, LOST otherwise (:mod:`.session`).
    theta : (P,) float64
        Pose parameters (m, rad).
    posed : PosedHand
        The model posed at ``theta``; ``posed.model`` is the shape in use, which the session
        may refine while tracking (:mod:`hand_tracker_ros.tracking.scale`).
    iterations : int
        LM iterations spent on the set, recovery included.
    energy_costs : dict of str to float
        ``0.5 * w * |r|^2`` per term at the estimate.
    confidence : float
        Probability in [0, 1] that the estimate is right (:mod:`.evidence`).
    evidence : dict of str to float
        The image evidence the confidence was computed from.
    timings_s : dict of str to float
        Wall time of each stage (s); ``total`` is the latency of the set.
    labels : tuple of tuple
        The ``labels`` of every round correspondence that has them, in term order (the
        salient term: per camera, detection -> finger, -1 unassigned; the limits term: the
        active constraints).
    recovered_from : str
        Where the estimate came from when it did not continue the last one (empty otherwise):
        a recovery hypothesis, a pinned finger's start (e.g. ``'ring_extended'``; step 4b of
        :mod:`hand_tracker_ros.tracking.session`), ``'search'``, or ``'initial_pose'`` (a
        restart there).
    lm_statuses : tuple of FitStatus
        Why each Levenberg-Marquardt call of the kept fit stopped (``Fit.lm_statuses``).
    """

    stamp_ns: int
    status: TrackStatus
    theta: FloatArray
    posed: PosedHand
    iterations: int
    energy_costs: dict[str, float]
    confidence: float
    evidence: dict[str, float] = field(default_factory=dict)
    timings_s: dict[str, float] = field(default_factory=dict)
    labels: tuple[tuple[object, ...], ...] = ()
    recovered_from: str = ''
    lm_statuses: tuple[FitStatus, ...] = ()
