"""Messages between processes: custom types intact, camera images without loss."""
from __future__ import annotations

import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

pytestmark = pytest.mark.ros
FIXTURES = Path(__file__).parents[1] / 'fixtures'


@pytest.fixture()
def ros_node():
    import rclpy

    context = rclpy.Context()
    rclpy.init(context=context)
    node = rclpy.create_node('transport_test', context=context)
    executor = rclpy.executors.SingleThreadedExecutor(context=context)
    executor.add_node(node)
    yield node, executor
    node.destroy_node()
    rclpy.try_shutdown(context=context)


def _spin_until(executor, done, timeout_s: float) -> None:
    deadline = time.monotonic() + timeout_s
    while not done() and time.monotonic() < deadline:
        executor.spin_once(timeout_sec=0.05)


def test_custom_messages_arrive_intact(ros_node) -> None:
    from hand_tracker_msgs.msg import HandState, SalientPoints

    node, executor = ros_node
    got: dict[str, object] = {}
    node.create_subscription(HandState, 'hand/state', lambda m: got.setdefault('hs', m), 10)
    node.create_subscription(SalientPoints, 'salient_points',
                             lambda m: got.setdefault('sp', m), 10)
    proc = subprocess.Popen([sys.executable, str(FIXTURES / 'publish_custom_msgs.py'), '20'])
    try:
        _spin_until(executor, lambda: len(got) == 2, 30.0)
    finally:
        proc.kill()
        proc.wait()
    hs, sp = got['hs'], got['sp']
    assert hs.header.stamp.sec == 1700000000 and hs.header.stamp.nanosec == 123456789
    assert hs.status == HandState.STATUS_TRACKING
    assert list(hs.joint_names) == ['hand_tx', 'index_pip_flex']
    np.testing.assert_array_equal(hs.joint_positions, [0.25, -1.5])
    assert [(p.x, p.y, p.z) for p in hs.keypoints] == [(0.1, 0.2, 0.3), (-0.01, 0.02, -0.03)]
    assert [p.x for p in hs.fingertips] == [0.0, 1.0, 2.0, 3.0, 4.0]
    assert list(hs.energy_names) == ['edges', 'collision']
    np.testing.assert_array_equal(hs.energy_costs, [12.5, 0.25])
    assert hs.iterations == 42 and hs.processing_time == pytest.approx(0.0125)
    assert sp.camera_name == 'cam2' and (sp.width, sp.height) == (320, 240)
    assert [(p.u, p.v, p.score, p.label) for p in sp.points] == [
        (10.5, 20.25, 0.875, -1), (300.0, 1.0, 0.5, 3)]


def test_images_on_four_topics_arrive_without_loss(ros_node) -> None:
    """4 x 30 Hz 640x480 rgb8 for 3 s, best effort, under the shipped Fast DDS profile."""
    from rclpy.qos import QoSProfile, qos_profile_sensor_data
    from sensor_msgs.msg import Image

    node, executor = ros_node
    n_topics, frames = 4, 90
    received: set[tuple[int, int]] = set()

    def on_image(msg: Image) -> None:
        pixel = np.frombuffer(msg.data, np.uint8, count=3)
        assert (msg.width, msg.height, len(msg.data)) == (640, 480, 640 * 480 * 3)
        assert int(pixel[1]) + 256 * int(pixel[2]) == msg.header.stamp.sec
        received.add((int(pixel[0]), msg.header.stamp.sec))

    # Best effort like sensor data, but a queue deep enough that a busy test executor cannot
    # be what drops images (depth 5 lost 4 of 360 on a loaded machine): this measures the
    # transport.
    qos = QoSProfile(depth=frames, reliability=qos_profile_sensor_data.reliability)
    for t in range(n_topics):
        node.create_subscription(Image, f'/cam{t}/image_raw', on_image, qos)
    proc = subprocess.Popen([sys.executable, str(FIXTURES / 'publish_images.py'),
                             str(n_topics), '30', str(frames)])
    try:
        _spin_until(executor, lambda: len(received) == n_topics * frames or
                    proc.poll() is not None, 60.0)
        _spin_until(executor, lambda: len(received) == n_topics * frames, 2.0)
    finally:
        proc.kill()
        proc.wait()
    missing = n_topics * frames - len(received)
    assert missing == 0, f'{missing} of {n_topics * frames} images lost'
