"""The estimates bag of ``hand-tracker track``: the live tracker's outputs, written offline.

The same topics and messages as the tracker node publishes (:class:`.estimates.EstimateEncoder`
with rosbags classes, so no rclpy is needed): ``/hand/robot_description`` (latched) at the
first set's stamp and again at each set tracked with a refined scale, then per set
``/hand/joint_states`` and ``/tf`` (TRACKING sets only), ``/hand/state`` and
``/hand/markers``. Bag times are the input sets' stamps. Played back (or
opened in Foxglove) it shows what the live graph would have shown.
"""
from __future__ import annotations

from collections.abc import Iterable
from pathlib import Path

from hand_tracker_ros import topics
from hand_tracker_ros.bags.writer import BagWriter
from hand_tracker_ros.model.hand import HandModel
from hand_tracker_ros.pipeline.track_bag import TrackedFrame
from hand_tracker_ros.ros_io.estimates import EstimateEncoder
from hand_tracker_ros.ros_io.message_kit import RosbagsKit

TOPICS = (topics.ROBOT_DESCRIPTION, *topics.ESTIMATES)


def write_estimates(frames: Iterable[TrackedFrame], out: str | Path, world_frame: str,
                    model: HandModel) -> list[TrackedFrame]:
    """Write the estimates to the rosbag2 (mcap) ``out``; return the frames."""
    encoder = EstimateEncoder(RosbagsKit(), model, world_frame)
    done: list[TrackedFrame] = []
    with BagWriter(out) as writer:
        for topic in TOPICS:
            writer.add_topic(topic.absolute, topic.msgtype,
                             qos='latched' if topic.latched else 'reliable')
        for frame in frames:
            result = frame.result
            if not done:
                writer.write(topics.ROBOT_DESCRIPTION.absolute, result.stamp_ns,
                             encoder.robot_description())
            # Built before any is written: a set's messages are in the bag all or none.
            messages = list(encoder.messages(result, result.timings_s.get('total', 0.0)))
            for topic, msg in messages:
                writer.write(topic.absolute, result.stamp_ns, msg)
            done.append(frame)
    return done
