"""Track a whole bag offline and write the estimates as a rosbag2.

Output topics (mcap): ``/hand/joint_states`` (sensor_msgs/JointState, only for frames judged
TRACKING, as the live node publishes) and ``/hand/state`` (hand_tracker_msgs/HandState, every
frame, with its status). Stamps are the input sets' stamps.
"""
from __future__ import annotations

import logging
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from hand_tracker_ros.bags.convert import HandStateValues, hand_state_msg, joint_state_msg
from hand_tracker_ros.bags.recover import readable_bag
from hand_tracker_ros.bags.writer import BagWriter
from hand_tracker_ros.model.hand import HandModel
from hand_tracker_ros.model.layout import PARAM_NAMES
from hand_tracker_ros.model.shape import SHAPE_NAMES, HandShape
from hand_tracker_ros.model.skeleton import KEYPOINT_NAMES
from hand_tracker_ros.pipeline.frames import (FrameSet, frame_sets, ground_truth, load_rig,
                                              rig_file)
from hand_tracker_ros.pipeline.offline import Detector, OfflinePipeline, PipelineConfig
from hand_tracker_ros.tracking.result import TrackResult, TrackStatus

LOG = logging.getLogger(__name__)
JOINTS_TOPIC = '/hand/joint_states'
STATE_TOPIC = '/hand/state'


@dataclass(frozen=True, eq=False)
class TrackedFrame:
    """One frame's estimate and, for synthetic bags, its ground-truth keypoints."""

    result: TrackResult
    truth_keypoints_m: np.ndarray | None


def hand_state_values(result: TrackResult, model: HandModel, world_frame: str
                      ) -> HandStateValues:
    """The HandState of one estimate."""
    names = tuple(result.energy_costs)
    return HandStateValues(
        stamp_ns=result.stamp_ns, frame_id=world_frame, status=int(result.status),
        confidence=result.confidence, joint_names=PARAM_NAMES, joint_positions=result.theta,
        keypoint_names=KEYPOINT_NAMES,
        keypoints_m=result.posed.keypoints_m, fingertips_m=result.posed.fingertips_m,
        shape_names=SHAPE_NAMES, shape_parameters=model.shape.to_vector(),
        energy_names=names, energy_costs=np.array([result.energy_costs[n] for n in names]),
        iterations=result.iterations, processing_time_s=result.timings_s.get('total', 0.0))


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


def write_estimates(frames: Iterator[TrackedFrame], out: str | Path, world_frame: str,
                    model: HandModel) -> list[TrackedFrame]:
    """Write the estimates to the rosbag2 ``out``; return the frames."""
    done = []
    with BagWriter(out) as writer:
        writer.add_topic(JOINTS_TOPIC, 'sensor_msgs/msg/JointState')
        writer.add_topic(STATE_TOPIC, 'hand_tracker_msgs/msg/HandState')
        for frame in frames:
            result = frame.result
            if result.status == TrackStatus.TRACKING:
                writer.write(JOINTS_TOPIC, result.stamp_ns,
                             joint_state_msg(result.stamp_ns, PARAM_NAMES, result.theta,
                                             world_frame))
            writer.write(STATE_TOPIC, result.stamp_ns,
                         hand_state_msg(hand_state_values(result, model, world_frame)))
            done.append(frame)
    return done
