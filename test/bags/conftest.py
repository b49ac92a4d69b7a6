"""Deterministic sample messages and bags shared by the bag tests."""
from __future__ import annotations

import types
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest

from hand_tracker_ros.bags import convert
from hand_tracker_ros.bags.writer import BagWriter

T0_NS = 1_700_000_000_123_456_789
PERIOD_NS = 33_333_333
N_FRAMES = 3
TOPICS = {
    '/cam0/image_raw': ('sensor_msgs/msg/Image', 'sensor_data'),
    '/cam0/camera_info': ('sensor_msgs/msg/CameraInfo', 'reliable'),
    '/hand/joint_states': ('sensor_msgs/msg/JointState', 'reliable'),
    '/hand/state': ('hand_tracker_msgs/msg/HandState', 'reliable'),
    '/cam0/salient_points': ('hand_tracker_msgs/msg/SalientPoints', 'reliable'),
}


def image(i: int) -> np.ndarray:
    return np.random.default_rng(i).integers(0, 256, (6, 7, 3), dtype=np.uint8)


def camera_info(stamp_ns: int) -> convert.CameraInfoValues:
    K = np.array([[500.0, 0.0, 3.5], [0.0, 501.0, 2.5], [0.0, 0.0, 1.0]])
    D = np.array([0.1, -0.2, 0.001, 0.002, 0.03])
    return convert.CameraInfoValues(stamp_ns=stamp_ns, frame_id='cam0_optical', width=7,
                                    height=6, K=K, D=D, distortion_model='plumb_bob')


def joints(i: int) -> tuple[tuple[str, ...], np.ndarray]:
    return ('hand_tx', 'index_mcp_flex'), np.array([0.01 * i, -0.5 + 0.1 * i])


def hand_state(stamp_ns: int, i: int) -> convert.HandStateValues:
    rng = np.random.default_rng(100 + i)
    names, positions = joints(i)
    return convert.HandStateValues(
        stamp_ns=stamp_ns, frame_id='world', status=1, confidence=0.75, joint_names=names,
        joint_positions=positions, keypoint_names=tuple(f'kp{k}' for k in range(21)),
        keypoints_m=rng.normal(size=(21, 3)), fingertips_m=rng.normal(size=(5, 3)),
        shape_names=('scale',), shape_parameters=np.array([1.05]),
        energy_names=('edges', 'salient'), energy_costs=np.array([0.25, 1.5]),
        iterations=7 + i, processing_time_s=0.5)


def salient(stamp_ns: int, i: int) -> convert.SalientPointsValues:
    uv = np.array([[1.5, 2.25], [3.0, 4.5], [5.0, 0.5]]) + i
    return convert.SalientPointsValues(
        stamp_ns=stamp_ns, frame_id='cam0_optical', camera_name='cam0', width=7, height=6,
        uv_px=uv, score=np.array([0.75, 0.5, 0.25]), label=np.array([-1, 1, 4]))


def frame_messages(i: int) -> dict[str, object]:
    """The message of every topic of frame ``i`` (stamp ``T0_NS + i * PERIOD_NS``)."""
    stamp = T0_NS + i * PERIOD_NS
    names, positions = joints(i)
    return {
        '/cam0/image_raw': convert.image_msg(image(i), stamp, 'cam0_optical'),
        '/cam0/camera_info': convert.camera_info_msg(camera_info(stamp)),
        '/hand/joint_states': convert.joint_state_msg(stamp, names, positions),
        '/hand/state': convert.hand_state_msg(hand_state(stamp, i)),
        '/cam0/salient_points': convert.salient_points_msg(salient(stamp, i)),
    }


def write_bag(path: Path, storage: str) -> Path:
    """Write ``N_FRAMES`` frames of every topic of ``TOPICS`` to a new bag at ``path``."""
    with BagWriter(path, storage=storage) as bag:
        for topic, (msgtype, qos) in TOPICS.items():
            bag.add_topic(topic, msgtype, qos=qos)
        for i in range(N_FRAMES):
            for topic, msg in frame_messages(i).items():
                bag.write(topic, T0_NS + i * PERIOD_NS, msg)
    return path


@pytest.fixture
def samples() -> types.SimpleNamespace:
    """The sample builders above, for test modules (no cross-test-module imports)."""
    return types.SimpleNamespace(
        T0_NS=T0_NS, PERIOD_NS=PERIOD_NS, N_FRAMES=N_FRAMES, TOPICS=TOPICS, image=image,
        camera_info=camera_info, joints=joints, hand_state=hand_state, salient=salient,
        frame_messages=frame_messages)


@pytest.fixture
def make_bag(tmp_path: Path) -> Callable[[str], Path]:
    """``make_bag(storage)`` writes the sample bag to a fresh directory and returns it."""
    return lambda storage: write_bag(tmp_path / f'bag_{storage}', storage)
