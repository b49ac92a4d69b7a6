"""The `features` node turns synthetic camera frames into the core's features, and survives
bad input with a clear log line."""
from __future__ import annotations

import numpy as np
import pytest

from hand_tracker_ros.synthetic.sequence import SynthConfig, SyntheticSequence
from hand_tracker_ros.vision.features import FeatureExtractor, FeaturesConfig
from hand_tracker_ros.vision.visualize import edge_image, mask_image

pytestmark = pytest.mark.ros
CAMERAS = ('cam0', 'cam1')


def test_features_node_matches_the_core_and_survives_bad_images(node_process, ros, hand_model):
    from rclpy.qos import qos_profile_sensor_data
    from sensor_msgs.msg import Image
    from std_msgs.msg import Header

    from hand_tracker_ros.ros_io.images import image_msg

    node, spin_until = ros
    features = node_process('features', '-p', f'cameras:={list(CAMERAS)}'.replace("'", ''))
    sequence = SyntheticSequence(SynthConfig(motion='tapping', n_frames=3, n_cameras=2),
                                 hand_model)
    received: dict[tuple[str, str, int], np.ndarray] = {}

    def keep(cam: str, kind: str, msg: Image) -> None:
        stamp = msg.header.stamp.sec * 10**9 + msg.header.stamp.nanosec
        dtype = np.float32 if msg.encoding.startswith('32F') else np.uint8
        channels = 2 if msg.encoding == '32FC2' else 1
        received[(cam, kind, stamp)] = np.frombuffer(msg.data, dtype).reshape(
            msg.height, msg.width, channels).squeeze()

    pubs = {c: node.create_publisher(Image, f'{c}/image_raw', qos_profile_sensor_data)
            for c in CAMERAS}
    subs = [node.create_subscription(Image, f'{cam}/{kind}',
                                     lambda m, c=cam, k=kind: keep(c, k, m), 10)
            for cam in CAMERAS for kind in ('edges', 'mask', 'flow')]
    assert spin_until(lambda: all(p.get_subscription_count() for p in pubs.values())
                      and all(s.get_publisher_count() for s in subs), 30.0)

    def publish(cam: str, image: np.ndarray, stamp_ns: int) -> None:
        header = Header(frame_id=f'{cam}_optical_frame')
        header.stamp.sec, header.stamp.nanosec = divmod(stamp_ns, 10**9)
        pubs[cam].publish(image_msg(image, header))

    # Prime until every camera answered: a best-effort sample sent before the node's reader
    # has matched our writer (discovery is not symmetric) is lost, and the frames below are
    # compared one by one. Primes repeat one image, so the node's state after any number of
    # them (the previous frame, for flow) is the core's after one.
    core = {c: FeatureExtractor(c, FeaturesConfig()) for c in CAMERAS}
    first = sequence.frame(0).images
    prime_ns = 1_600_000_000 * 10**9
    for cam, image in zip(CAMERAS, first):
        core[cam].process(image, prime_ns)
    primes: list[int] = []

    def answered() -> bool:
        return all(any((c, 'edges', p) in received for p in primes) for c in CAMERAS)

    while len(primes) < 100 and not answered():
        primes.append(prime_ns + len(primes))
        for cam, image in zip(CAMERAS, first):
            publish(cam, image, primes[-1])
        spin_until(answered, 0.2)
    assert answered(), features.output()
    for cam in CAMERAS:   # a camera's first frame has no flow
        answered = min(p for p in primes if (cam, 'edges', p) in received)
        assert (cam, 'flow', answered) not in received

    expected = {}
    for frame in sequence:
        for cam, image in zip(CAMERAS, frame.images):
            publish(cam, image, frame.stamp_ns)
            expected[(cam, frame.stamp_ns)] = core[cam].process(image, frame.stamp_ns)
        spin_until(lambda: False, 0.3)  # pace the frames like a camera would
    stamps = [f.stamp_ns for f in sequence]
    assert spin_until(lambda: all((c, 'flow', stamps[-1]) in received for c in CAMERAS), 30.0)
    # A set with a bad image is dropped whole (the other camera's good image of that stamp
    # too), with an error; the next set is served.
    bad = Image(height=240, width=320, encoding='64FC1', step=2560)
    bad.data = bytes(240 * 2560)
    bad.header.stamp.sec = 1_750_000_000
    pubs['cam0'].publish(bad)
    publish('cam1', sequence.frame(0).images[1], 1_750_000_000 * 10**9)
    assert spin_until(lambda: "unsupported encoding '64FC1'" in features.output(), 20.0)
    for cam, image in zip(CAMERAS, sequence.frame(0).images):
        publish(cam, image, 1_800_000_000 * 10**9)
    assert spin_until(lambda: all((c, 'edges', 1_800_000_000 * 10**9) in received
                                  for c in CAMERAS), 20.0)
    assert ('cam1', 'edges', 1_750_000_000 * 10**9) not in received
    for (cam, stamp), feats in expected.items():
        np.testing.assert_array_equal(received[(cam, 'edges', stamp)], edge_image(feats.edges))
        np.testing.assert_array_equal(received[(cam, 'mask', stamp)], mask_image(feats.mask))
    np.testing.assert_allclose(received[('cam1', 'flow', stamps[1])],
                               expected[('cam1', stamps[1])].flow.flow_px, atol=1e-6)
    assert features.proc.poll() is None


def test_features_node_reads_the_compressed_transport(node_process, ros, hand_model):
    from rclpy.qos import qos_profile_sensor_data
    from sensor_msgs.msg import CompressedImage, Image

    from hand_tracker_ros.bags.image_codec import compress_rgb

    node, spin_until = ros
    features = node_process('features', '-p', 'cameras:=[cam0]',
                            '-p', 'image_transport:=compressed')
    image = SyntheticSequence(SynthConfig(motion='tapping', n_frames=1, n_cameras=1),
                              hand_model).frame(0).images[0]
    received: list[np.ndarray] = []
    pub = node.create_publisher(CompressedImage, 'cam0/image_raw/compressed',
                                qos_profile_sensor_data)
    sub = node.create_subscription(
        Image, 'cam0/edges', lambda m: received.append(
            np.frombuffer(m.data, np.uint8).reshape(m.height, m.width)), 10)
    assert spin_until(lambda: pub.get_subscription_count() and sub.get_publisher_count(), 30.0)
    data, fmt = compress_rgb(image, 'png')   # lossless: the node sees exactly ``image``
    msg = CompressedImage(format=fmt)
    msg.data = data.tobytes()
    for _ in range(100):
        pub.publish(msg)
        if spin_until(lambda: bool(received), 0.2):
            break
    assert received, features.output()
    expected = FeatureExtractor('cam0', FeaturesConfig()).process(image, 0)
    np.testing.assert_array_equal(received[0], edge_image(expected.edges))
