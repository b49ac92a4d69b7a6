"""Where and how much to observe in the next set: one policy for the offline pipeline and
the composed graph.

While the session tracks the hand, the next set's features are only needed around it, and a
fingertip detection every few sets keeps the finger labels (the salient term's weight is
small next to the silhouette and edges that carry a tracked hand):

- features in a region of interest per camera (:func:`.roi.hand_rois` of the last accepted
  estimate) when ``use_roi``;
- fingertips detected in every ``detect_every``-th tracked set (counted from the last set
  that was not tracked), in the same region of interest.

While it does not track (start, LOST, after a search), features and detections cover every
image of every set: the search and the recovery need them most.

A set is planned from the session as it is *before* the previous set's fit, because the
live graph observes a set while the previous one is fitted (:mod:`hand_tracker_ros.pipeline.live`)
and the offline pipeline overlaps the two the same way; the ROI margin covers the two frames
of motion since that estimate.
"""
from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

from hand_tracker_ros.config import nested, param
from hand_tracker_ros.geometry.camera_model import Camera
from hand_tracker_ros.status import TrackStatus
from hand_tracker_ros.tracking.roi import RoiConfig, hand_rois
from hand_tracker_ros.tracking.session import TrackingSession
from hand_tracker_ros.vision.image import Box


@dataclass(frozen=True)
class AttentionConfig:
    """How much of each set is observed while the hand is tracked."""

    use_roi: bool = param(True, 'while the hand is tracked, compute features only in a '
                          'region of interest around the estimate')
    roi: RoiConfig = nested(RoiConfig)
    detect_every: int = param(2, 'detect fingertips in every n-th set while the hand is '
                              'tracked (in every set while it is not)', low=1, high=1000)


@dataclass(frozen=True)
class ObservationPlan:
    """What to compute for one set.

    Attributes
    ----------
    rois_px : list of (u0, v0, u1, v1) or None, or None
        Per camera, the half-open box in px of the features and the detections (None: that
        whole image); None: every whole image.
    detect : bool
        Whether to detect fingertips in this set.
    """

    rois_px: list[Box | None] | None
    detect: bool

    @classmethod
    def everything(cls) -> ObservationPlan:
        """Whole images, with detection."""
        return cls(None, True)


class Attention:
    """Plans each set's observation from the tracking session (module docstring)."""

    def __init__(self, config: AttentionConfig, cameras: Sequence[Camera]) -> None:
        self.config = config
        self.cameras = tuple(cameras)
        self._tracked = 0     # tracked sets planned since the last untracked one

    def plan(self, session: TrackingSession) -> ObservationPlan:
        """The plan of the next set, from the session's last status and estimate."""
        tracks, detect = self.next_kind(session)
        if not tracks:
            self._tracked = 0
            return ObservationPlan.everything()
        self._tracked += 1
        posed = session.tracker.last_posed
        assert posed is not None     # a tracked session has an estimate
        rois = hand_rois(posed, self.cameras, self.config.roi) if self.config.use_roi else None
        return ObservationPlan(rois, detect)

    def next_kind(self, session: TrackingSession) -> tuple[bool, bool]:
        """What :meth:`plan` would now plan, without planning: (the hand is tracked, the
        set detects fingertips). The live loop predicts the set's observation's duration by it
        (:mod:`hand_tracker_ros.pipeline.live`)."""
        tracks = (session.status == TrackStatus.TRACKING
                  and session.tracker.last_posed is not None)
        return tracks, not tracks or (self._tracked + 1) % self.config.detect_every == 0
