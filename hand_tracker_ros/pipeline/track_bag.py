"""Track a whole bag offline: the estimate of every synchronized frame set, in order.

``hand-tracker track`` writes them as the live node publishes them
(:mod:`hand_tracker_ros.ros_io.estimates_bag`).
"""
from __future__ import annotations

import logging
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from hand_tracker_ros.bags.recover import readable_bag
from hand_tracker_ros.core.frames import FrameSet
from hand_tracker_ros.core.result import TrackResult
from hand_tracker_ros.model.hand import HandModel
from hand_tracker_ros.model.shape import HandShape
from hand_tracker_ros.pipeline.frames import frame_sets, ground_truth, load_rig, rig_file
from hand_tracker_ros.pipeline.offline import Detector, OfflinePipeline, PipelineConfig

LOG = logging.getLogger(__name__)


@dataclass(frozen=True, eq=False)
class TrackedFrame:
    """One frame's estimate and, for synthetic bags, its ground-truth keypoints."""

    result: TrackResult
    truth_keypoints_m: np.ndarray | None


def track_bag(bag: str | Path, *, rig_path: str | Path | None = None,
              config: PipelineConfig = PipelineConfig(), detector: Detector | None = None,
              init_from_ground_truth: bool = False,
              shape: HandShape | None = None) -> Iterator[TrackedFrame]:
    """Estimates of every synchronized frame set of ``bag``, in order.

    The hand model has ``shape`` (default: the default :class:`HandShape`).

    A truncated mcap bag is tracked up to the damage, with a warning
    (:func:`~hand_tracker_ros.bags.recover.readable_bag`); so is one damaged in the middle
    (:func:`~hand_tracker_ros.pipeline.frames.frame_sets`).
    """
    rig_path = rig_file(bag, rig_path)
    with readable_bag(bag) as readable:
        yield from _track_readable(readable, rig_path, config, detector, init_from_ground_truth,
                                   HandModel.build(shape))


def _track_readable(bag: Path, rig_path: Path, config: PipelineConfig,
                    detector: Detector | None, init_from_ground_truth: bool, model: HandModel
                    ) -> Iterator[TrackedFrame]:
    rig = load_rig(bag, rig_path)
    truth = ground_truth(bag)
    pipeline = OfflinePipeline(model, rig, config, detector)

    def initialise(frames: FrameSet) -> None:
        if init_from_ground_truth and not pipeline.session.initialized:
            if frames.stamp_ns not in truth:
                msg = f'{bag}: no ground truth at {frames.stamp_ns} to initialise from'
                raise ValueError(msg)
            pipeline.session.reset(np.asarray(truth[frames.stamp_ns].joint_positions))

    try:
        for result in pipeline.run(frame_sets(bag, rig), before_fit=initialise):
            gt = truth.get(result.stamp_ns)
            yield TrackedFrame(result, None if gt is None else gt.keypoints_m)
    finally:
        pipeline.close()
