"""The tracking pipeline without a ROS graph: frame set -> features -> detections -> fit.

The same steps the nodes run (``features``, ``salient_points``, ``tracker``), in one process
and deterministically, so a bag can be tracked and evaluated offline. For evaluation on
synthetic data the structured edge noise of Ballan's supplementary can be applied to every
edge map (seeded per frame and camera, so runs are reproducible).

:meth:`OfflinePipeline.step` observes and fits one set; :meth:`OfflinePipeline.run` overlaps
the two stages over a sequence as the node graph does (features and detection of set k+1
while set k is fitted). What each set observes is planned by :mod:`..tracking.attention`
from the session as it was before the previous set's fit (the whole images, or a region of
interest around a tracked hand and a detection every few sets), in both, so both give the
same estimates; ``run`` only takes less wall time per frame.

References: docs/references.md.
"""
from __future__ import annotations

import dataclasses
import itertools
import time
from collections.abc import Callable, Iterable, Iterator
from concurrent.futures import Future, ThreadPoolExecutor
from dataclasses import dataclass

import numpy as np

from hand_tracker_ros._typing import UInt8Array
from hand_tracker_ros.config import nested, param
from hand_tracker_ros.core.frames import FrameSet
from hand_tracker_ros.core.observations import CameraObservation, FrameObservations
from hand_tracker_ros.core.result import TrackResult
from hand_tracker_ros.geometry.rig import CameraRig
from hand_tracker_ros.model.hand import HandModel
from hand_tracker_ros.synthetic.edge_noise import EdgeNoiseConfig, add_edge_noise
from hand_tracker_ros.tracking.attention import Attention, AttentionConfig, ObservationPlan
from hand_tracker_ros.tracking.session import SessionConfig, TrackingSession
from hand_tracker_ros.tracking.tracker import HandTracker, TrackerConfig
from hand_tracker_ros.vision.detections import SalientDetections
from hand_tracker_ros.vision.detector.detector import DetectorConfig, FingertipDetector
from hand_tracker_ros.vision.edges import EdgeMap
from hand_tracker_ros.vision.features import CameraFeatures, FeaturesConfig, MultiCameraFeatures
from hand_tracker_ros.vision.image import Box
from hand_tracker_ros.vision.resolution import to_working, working_camera

# image (H, W, 3) uint8, region of interest (None: the whole image) -> fingertip candidates
Detector = Callable[[UInt8Array, Box | None], SalientDetections]


@dataclass(frozen=True)
class PipelineConfig:
    """Features, tracker and (for synthetic evaluation) edge noise."""

    features: FeaturesConfig = nested(FeaturesConfig)
    detector: DetectorConfig = nested(DetectorConfig)
    use_detector: bool = param(True, 'detect fingertips (salient points) with the trained '
                               'detector')
    tracker: TrackerConfig = nested(TrackerConfig)
    session: SessionConfig = nested(SessionConfig)
    attention: AttentionConfig = nested(AttentionConfig)
    auto_initialize: bool = param(True, 'find the hand from the observations on the first frame '
                                  'and after session.failure.reinit_after lost frames')
    edge_noise: EdgeNoiseConfig = nested(EdgeNoiseConfig)
    edge_noise_seed: int = param(0, 'seed of the structured edge noise', low=0)
    working_width_px: int = param(0, 'observe and fit wider images scaled down to this width '
                                  '(vision/resolution.py); 0: at their own size', unit='px',
                                  low=0, high=100000)


class OfflinePipeline:
    """Features, detection and tracking of one rig's frame sets, in order.

    The fingertip detector is the shipped (or ``detector.model_path``) trained one unless
    ``detector`` is given or ``use_detector`` is off. The cameras' images are detected on two
    threads (ONNX Runtime releases the GIL: 4 whole images at 320x240 measured 8.0 ms in turn
    and 5.1 ms on 2 threads with the detector of 2026-11-27).
    """

    def __init__(self, model: HandModel, rig: CameraRig, config: PipelineConfig = PipelineConfig(),
                 detector: Detector | None = None) -> None:
        self.rig = rig
        self.config = config
        # The cameras as the tracker sees them (vision/resolution.py).
        self.cameras = tuple(working_camera(c, config.working_width_px) for c in rig.cameras)
        self.tracker = HandTracker(model, self.cameras, config.tracker)
        self.session = TrackingSession(self.tracker, config.session,
                                       search=config.auto_initialize)
        self._attention = Attention(config.attention, self.cameras)
        self._next_plan: ObservationPlan | None = None
        self._features = MultiCameraFeatures(rig.names, config.features)
        if detector is None and config.use_detector:
            detector = FingertipDetector.load(config=config.detector).detect
        self._detector = detector
        self._detection_pool = ThreadPoolExecutor(max_workers=2, thread_name_prefix='detector')
        # One thread: sets are observed in order (flow and the edge-noise seed depend on it).
        self._observer = ThreadPoolExecutor(max_workers=1, thread_name_prefix='observer')
        self._frame = 0

    def close(self) -> None:
        """Stop the observer, feature and detection thread pools."""
        self._observer.shutdown(wait=True)
        self._features.close()
        self._detection_pool.shutdown(wait=True)

    def _noisy(self, features: CameraFeatures, camera_index: int) -> CameraFeatures:
        rng = np.random.default_rng([self.config.edge_noise_seed, self._frame, camera_index])
        edges, orientation = add_edge_noise(features.edges.edges,
                                            features.edges.orientation_rad, rng,
                                            self.config.edge_noise)
        edge_map = EdgeMap(edges, orientation, features.edges.offset_uv_px)
        return dataclasses.replace(features, edges=edge_map)

    def observe(self, frames: FrameSet, plan: ObservationPlan | None = None
                ) -> tuple[FrameObservations, dict[str, float]]:
        """Features and detections of one frame set, with the tracker's per-frame work done
        (:meth:`HandTracker.prepare`), and their wall times (s); ``plan`` (default:
        everything) limits them."""
        plan = ObservationPlan.everything() if plan is None else plan
        start = time.perf_counter()
        images = [to_working(image, cam) for image, cam in zip(frames.images, self.cameras)]
        features = self._features.process(images, frames.stamp_ns, rois_px=plan.rois_px)
        if self.config.edge_noise.enabled:
            features = tuple(self._noisy(f, c) for c, f in enumerate(features))
        mid = time.perf_counter()
        rois = plan.rois_px if plan.rois_px is not None else [None] * len(images)
        tips = (list(self._detection_pool.map(self._detector, images, rois))
                if self._detector and plan.detect
                else [SalientDetections.empty()] * len(images))
        end = time.perf_counter()
        cameras = tuple(CameraObservation(cam, feat, tip)
                        for cam, feat, tip in zip(self.cameras, features, tips))
        observations = FrameObservations(frames.stamp_ns, cameras)
        self.tracker.prepare(observations)
        self._frame += 1
        return observations, {'features': mid - start, 'detection': end - mid,
                              'prepare': time.perf_counter() - end}

    def step(self, frames: FrameSet) -> TrackResult:
        """Observe and track one frame set.

        The tracking session (:mod:`..tracking.session`) decides status, recovery and, with
        ``auto_initialize``, the search for the hand; otherwise it must have been reset to a
        pose (``pipeline.session.reset``).
        """
        observed = self.observe(frames, self._take_plan())
        self._next_plan = self._attention.plan(self.session)   # as run() plans the next set
        return self._fit(*observed)

    def _take_plan(self) -> ObservationPlan:
        """The plan of the next set: the one :meth:`step` made before its fit, else now."""
        plan, self._next_plan = self._next_plan, None
        return plan if plan is not None else self._attention.plan(self.session)

    def run(self, frame_sets: Iterable[FrameSet],
            before_fit: Callable[[FrameSet], None] | None = None) -> Iterator[TrackResult]:
        """Track frame sets in order, observing set k+1 on a thread while set k is fitted.

        The estimates are those of :meth:`step` on every set in turn. ``before_fit(frames)``
        runs right before each fit (e.g. to reset the tracker to a known pose). A result's
        ``timings_s['total']`` is still the sum of the stages (the latency of one set); the
        wall time per set is lower because observing overlaps fitting.
        """
        sets = iter(frame_sets)

        def observe_next() -> list[tuple[FrameSet, Future]]:
            return [(frames, self._observer.submit(self.observe, frames, self._take_plan()))
                    for frames in itertools.islice(sets, 1)]

        ahead = observe_next()
        while ahead:
            (frames, pending), = ahead
            observed = pending.result()
            ahead = observe_next()
            if before_fit is not None:
                before_fit(frames)
            yield self._fit(*observed)

    def _fit(self, observations: FrameObservations, timings: dict[str, float]) -> TrackResult:
        result = self.session.step(observations)
        result.timings_s.update(timings)
        result.timings_s['total'] += sum(timings.values())
        return result
