"""Write a synthetic sequence as a rosbag2 (mcap by default) plus its rig YAML.

Layout of ``out_dir``: ``bag/`` (the rosbag2), ``rig.yaml`` and ``shape.yaml`` (the hand's
shape, :mod:`hand_tracker_ros.model.shape_file`) beside it. Topics:

==================================  ==============================  ==========
topic                               type                            QoS
==================================  ==============================  ==========
``/camK/image_raw``                 sensor_msgs/msg/Image (rgb8)    sensor data
  or ``/camK/image_raw/compressed``   sensor_msgs/msg/CompressedImage sensor data
``/camK/camera_info``               sensor_msgs/msg/CameraInfo      reliable
``/hand/ground_truth/joint_states`` sensor_msgs/msg/JointState      reliable
``/hand/ground_truth/state``        hand_tracker_msgs/msg/HandState reliable
==================================  ==============================  ==========
"""
from __future__ import annotations

from pathlib import Path
from typing import Literal

import numpy as np

from hand_tracker_ros import topics
from hand_tracker_ros.bags.convert import (
    CameraInfoValues,
    HandStateValues,
    camera_info_msg,
    compressed_image_msg,
    hand_state_msg,
    image_msg,
    joint_state_msg,
)
from hand_tracker_ros.bags.writer import BagWriter
from hand_tracker_ros.errors import ConfigError
from hand_tracker_ros.model.layout import PARAM_NAMES
from hand_tracker_ros.model.shape import SHAPE_NAMES
from hand_tracker_ros.model.shape_file import save_shape
from hand_tracker_ros.model.skeleton import KEYPOINT_NAMES
from hand_tracker_ros.progress import progress
from hand_tracker_ros.status import TrackStatus
from hand_tracker_ros.synthetic.sequence import SyntheticFrame, SyntheticSequence

GT_JOINTS_TOPIC = topics.GT_JOINT_STATES.absolute
GT_STATE_TOPIC = topics.GT_STATE.absolute
IMAGE_FORMATS = ('raw', 'jpeg', 'png')


def image_topic(camera: str) -> str:
    """``/<camera>/image_raw``."""
    return f'/{camera}/image_raw'


def compressed_image_topic(camera: str) -> str:
    """``/<camera>/image_raw/compressed``, image_transport's name for the compressed stream."""
    return f'{image_topic(camera)}/compressed'


def info_topic(camera: str) -> str:
    """``/<camera>/camera_info``."""
    return f'/{camera}/camera_info'


def optical_frame(camera: str) -> str:
    """The camera's optical frame id (REP 103 axes)."""
    return f'{camera}_optical_frame'


def ground_truth_state(sequence: SyntheticSequence, frame: SyntheticFrame,
                       world_frame: str) -> HandStateValues:
    """The ground-truth HandState of one frame."""
    return HandStateValues(
        stamp_ns=frame.stamp_ns, frame_id=world_frame, status=int(TrackStatus.TRACKING),
        confidence=1.0,
        joint_names=PARAM_NAMES, joint_positions=frame.theta, keypoint_names=KEYPOINT_NAMES,
        keypoints_m=frame.keypoints_m, fingertips_m=frame.fingertips_m,
        shape_names=SHAPE_NAMES, shape_parameters=sequence.model.shape.to_vector(),
        energy_names=(), energy_costs=np.zeros(0), iterations=0, processing_time_s=0.0)


def write_sequence(sequence: SyntheticSequence, out_dir: str | Path, *,
                   storage: Literal['mcap', 'sqlite3'] = 'mcap', image_format: str = 'raw'
                   ) -> Path:
    """Render every frame into ``out_dir/bag``, write ``out_dir/rig.yaml`` and
    ``out_dir/shape.yaml``; return the bag.

    ``image_format`` is ``raw`` (rgb8 ``Image`` on ``/camK/image_raw``) or ``jpeg``/``png``
    (``CompressedImage`` on ``/camK/image_raw/compressed``).
    """
    if image_format not in IMAGE_FORMATS:
        msg = f'image_format must be one of {", ".join(IMAGE_FORMATS)}, got {image_format!r}'
        raise ConfigError(msg)
    out = Path(out_dir)
    if out.exists() and any(out.iterdir()):
        msg = f'output directory {out} exists and is not empty'
        raise ConfigError(msg)
    out.mkdir(parents=True, exist_ok=True)
    rig = sequence.rig
    rig.to_yaml(out / 'rig.yaml')
    save_shape(sequence.model.shape, out / 'shape.yaml',
               comment='the ground-truth hand shape of bag/ (hand-tracker synth)')
    bag = out / 'bag'
    raw = image_format == 'raw'
    topic_of = image_topic if raw else compressed_image_topic
    msgtype = 'sensor_msgs/msg/Image' if raw else 'sensor_msgs/msg/CompressedImage'
    with BagWriter(bag, storage=storage) as writer:
        for cam in rig.names:
            writer.add_topic(topic_of(cam), msgtype, qos='sensor_data')
            writer.add_topic(info_topic(cam), 'sensor_msgs/msg/CameraInfo')
        writer.add_topic(GT_JOINTS_TOPIC, 'sensor_msgs/msg/JointState')
        writer.add_topic(GT_STATE_TOPIC, 'hand_tracker_msgs/msg/HandState')
        for frame in progress(sequence, total=len(sequence), desc='synth', unit='frame'):
            for camera, image in zip(rig.cameras, frame.images):
                frame_id = optical_frame(camera.name)
                writer.write(topic_of(camera.name), frame.stamp_ns,
                             image_msg(image, frame.stamp_ns, frame_id) if raw else
                             compressed_image_msg(image, frame.stamp_ns, frame_id,
                                                  image_format))
                writer.write(info_topic(camera.name), frame.stamp_ns, camera_info_msg(
                    CameraInfoValues(frame.stamp_ns, frame_id, camera.width, camera.height,
                                     camera.K, camera.dist, 'plumb_bob')))
            writer.write(GT_JOINTS_TOPIC, frame.stamp_ns,
                         joint_state_msg(frame.stamp_ns, PARAM_NAMES, frame.theta))
            writer.write(GT_STATE_TOPIC, frame.stamp_ns, hand_state_msg(
                ground_truth_state(sequence, frame, rig.world_frame)))
    return bag
