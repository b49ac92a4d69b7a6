"""The `tracker` node: live tracking of a synthetic sequence, composed (features and
salient_points in the tracker process) and distributed (through a `features` process), and
clear log lines (with the node still running) on bad input.

No salient_points process runs in the distributed case: the tracker has never received salient
points, so it does not wait for them and tracks with empty detections (ros_io.observations,
frame assembly).
The test node publishes the first frame set and waits for its result (model warm-up in the
tracker process), then one set every PUBLISH_PERIOD_S.
"""
from __future__ import annotations

import time

import numpy as np
import pytest

from hand_tracker_ros.status import TrackStatus
from hand_tracker_ros.synthetic.sequence import SynthConfig, SyntheticSequence

pytestmark = pytest.mark.ros
PUBLISH_PERIOD_S = 0.5


def _stamp(msg) -> int:
    return msg.header.stamp.sec * 10**9 + msg.header.stamp.nanosec


def _header(stamp_ns: int, frame_id: str):
    from std_msgs.msg import Header

    header = Header(frame_id=frame_id)
    header.stamp.sec, header.stamp.nanosec = divmod(stamp_ns, 10**9)
    return header


def _camera_info(camera, stamp_ns: int, width: int | None = None):
    from sensor_msgs.msg import CameraInfo

    return CameraInfo(header=_header(stamp_ns, f'{camera.name}_optical_frame'),
                      width=width or camera.width, height=camera.height,
                      distortion_model=camera.distortion_model, d=list(camera.dist),
                      k=list(camera.K.ravel()))


def _ros_list(values) -> str:
    return '[' + ','.join(str(v) for v in values) + ']'


def _collect(node, kind, topic: str, out: list) -> None:
    node.create_subscription(kind, topic, out.append, 50)


@pytest.mark.slow
@pytest.mark.parametrize('inputs', ['images', 'features'])
def test_tracker_follows_a_synthetic_sequence(node_process, ros, hand_model, tmp_path,
                                              inputs: str) -> None:
    from diagnostic_msgs.msg import DiagnosticArray
    from hand_tracker_msgs.msg import HandState
    from rclpy.qos import DurabilityPolicy, QoSProfile, qos_profile_sensor_data
    from sensor_msgs.msg import CameraInfo, Image, JointState
    from std_msgs.msg import String
    from tf2_msgs.msg import TFMessage
    from visualization_msgs.msg import MarkerArray

    from hand_tracker_ros.model.urdf import urdf_text
    from hand_tracker_ros.ros_io.images import image_msg

    node, spin_until = ros
    sequence = SyntheticSequence(SynthConfig(motion='tapping', n_frames=10, n_cameras=3),
                                 hand_model)
    names = sequence.rig.names
    sequence.rig.to_yaml(tmp_path / 'rig.yaml')
    composed = inputs == 'images'
    features = None if composed else node_process('features',
                                                  '-p', f'cameras:={_ros_list(names)}')
    tracker = node_process('tracker', '-p', f'cameras:={_ros_list(names)}',
                           '-p', f'inputs:={inputs}',
                           '-p', f'rig_file:={tmp_path / "rig.yaml"}',
                           '-p', f'initial_pose:={_ros_list(sequence.thetas[0])}',
                           '-p', 'initialization:=initial_pose',
                           '-p', 'publish_overlay:=true', '-p', 'diagnostics_period_s:=0.5')
    joints, states, markers, diags, overlays, tfs = [], [], [], [], [], []
    _collect(node, JointState, 'hand/joint_states', joints)
    _collect(node, HandState, 'hand/state', states)
    _collect(node, MarkerArray, 'hand/markers', markers)
    _collect(node, TFMessage, '/tf', tfs)
    _collect(node, DiagnosticArray, '/diagnostics', diags)
    _collect(node, Image, f'{names[0]}/overlay', overlays)
    plans, flows = [], []
    if not composed:      # distributed: the features process follows the tracker's plans
        from hand_tracker_msgs.msg import ObservationPlan
        _collect(node, ObservationPlan, 'hand/observation_plan', plans)
        _collect(node, Image, f'{names[0]}/flow', flows)
    images = {c: node.create_publisher(Image, f'{c}/image_raw', qos_profile_sensor_data)
              for c in names}
    infos = {c: node.create_publisher(CameraInfo, f'{c}/camera_info', qos_profile_sensor_data)
             for c in names}
    # The tracker subscribes once warm; composed, it alone reads the images.
    readers = 1 if composed else 2
    assert spin_until(lambda: 'ready: tracking with cameras' in tracker.output() and all(
        node.count_subscribers(f'/{c}/{"image_raw" if composed else "edges"}')
        and p.get_subscription_count() == readers for c, p in infos.items()), 90.0), \
        tracker.output()
    frames = list(sequence)
    def publish(frame) -> None:
        for camera, image in zip(sequence.rig.cameras, frame.images):
            header = _header(frame.stamp_ns, f'{camera.name}_optical_frame')
            infos[camera.name].publish(_camera_info(camera, frame.stamp_ns))
            images[camera.name].publish(image_msg(image, header))

    # The first (warm-up) frame goes through before the rest are paced. It is re-sent until
    # the tracker answers: a best-effort image sent before the features node's reader matched
    # our writer is lost (discovery is not symmetric); repeats of a stamp are dropped as
    # duplicates by the node.
    deadline = time.monotonic() + 60.0
    publish(frames[0])
    while not spin_until(lambda: states, 2.0) and time.monotonic() < deadline:
        publish(frames[0])
    assert states, tracker.output()
    for frame in frames[1:]:
        spin_until(lambda: False, PUBLISH_PERIOD_S)
        publish(frame)
    spin_until(lambda: False, PUBLISH_PERIOD_S)
    stamps = [f.stamp_ns for f in frames]
    spin_until(lambda: len(states) >= len(frames), 20.0)
    assert spin_until(lambda: any(d.status[-1].message != 'no input yet' for d in diags), 5.0)
    by_stamp = {f.stamp_ns: f for f in frames}
    assert {_stamp(m) for m in joints} <= set(stamps)
    assert len({_stamp(m) for m in joints}) >= 0.9 * len(frames), tracker.output()
    tracked = [s for s in states if s.status == TrackStatus.TRACKING]
    errors_mm = [1e3 * np.linalg.norm(np.array([(p.x, p.y, p.z) for p in s.keypoints])
                                      - by_stamp[_stamp(s)].keypoints_m, axis=1).mean()
                 for s in tracked]
    assert np.mean(errors_mm) < 15.0, errors_mm
    assert all(s.header.frame_id == 'world' and len(s.joint_positions) == 26 for s in states)
    assert {m.ns for m in markers[-1].markers} == {'skeleton', 'joints', 'fingertips'}
    assert _stamp(markers[-1].markers[0]) in stamps
    assert overlays and _stamp(overlays[0]) in stamps and overlays[0].encoding == 'rgb8'
    status = {s.name: {kv.key: kv.value for kv in s.values} for s in diags[-1].status}
    assert f'tracker: {names[0]} input' in status
    assert status['tracker: tracking']['status'] == 'tracking'
    # /tf exactly with the JointStates, one transform per URDF joint.
    assert sorted(_stamp(t.transforms[0]) for t in tfs) == sorted(_stamp(m) for m in joints)
    assert all(len(t.transforms) == 26 for t in tfs)
    # robot_description is latched: a subscriber that comes late still gets it.
    description = []
    node.create_subscription(String, 'hand/robot_description', description.append,
                             QoSProfile(depth=1, durability=DurabilityPolicy.TRANSIENT_LOCAL))
    assert spin_until(lambda: description, 10.0)
    assert description[0].data == urdf_text(hand_model, root_link='world')
    if not composed:
        # One plan per fit, made from the estimate before it; once tracked, the features of
        # the first camera are computed only inside the planned regions (the flow, finite
        # everywhere on a whole image, is NaN outside them).
        assert len(plans) >= len(frames) - 1
        boxes = [(r.x_offset, r.y_offset, r.x_offset + r.width, r.y_offset + r.height)
                 for p in plans for n, r in zip(p.camera_names, p.rois)
                 if n == names[0] and r.width > 0]
        assert boxes and all(b[2] - b[0] < sequence.rig.cameras[0].width for b in boxes)
        u0, v0 = min(b[0] for b in boxes), min(b[1] for b in boxes)
        u1, v1 = max(b[2] for b in boxes), max(b[3] for b in boxes)
        last = max(flows, key=_stamp)
        assert _stamp(last) == stamps[-1]
        flow = np.frombuffer(last.data, np.float32).reshape(last.height, last.width, 2)
        inside = np.zeros(flow.shape[:2], bool)
        inside[v0:v1, u0:u1] = True
        assert np.isfinite(flow[inside]).any() and not np.isfinite(flow[~inside]).any()
    assert (features is None or features.proc.poll() is None) and tracker.proc.poll() is None
    assert 'Traceback' not in tracker.output()


def _feature_messages(extractor, camera_name: str, image, stamp_ns: int) -> dict:
    from hand_tracker_ros.ros_io.images import image_msg
    from hand_tracker_ros.vision.visualize import edge_image, flow_image, mask_image

    feats = extractor.process(image, stamp_ns)
    header = _header(stamp_ns, f'{camera_name}_optical_frame')
    msgs = {'edges': image_msg(edge_image(feats.edges), header),
            'edge_orientation': image_msg(feats.edges.orientation_rad, header),
            'mask': image_msg(mask_image(feats.mask), header)}
    if feats.flow is not None:
        flow = flow_image(feats.flow).copy()
        flow[: flow.shape[0] // 4] = np.nan       # NaN flow must be read as "no flow"
        msgs['flow'] = image_msg(flow, header)
    return msgs


@pytest.mark.slow
def test_tracker_survives_bad_input_with_clear_logs(node_process, ros, hand_model,
                                                    tmp_path) -> None:
    from hand_tracker_msgs.msg import HandState
    from sensor_msgs.msg import CameraInfo, Image
    from visualization_msgs.msg import Marker, MarkerArray

    from hand_tracker_ros.vision.features import FeatureExtractor, FeaturesConfig

    node, spin_until = ros
    sequence = SyntheticSequence(SynthConfig(motion='tapping', n_frames=6, n_cameras=2),
                                 hand_model)
    names = sequence.rig.names
    sequence.rig.to_yaml(tmp_path / 'rig.yaml')
    tracker = node_process('tracker', '-p', f'cameras:={_ros_list(names)}',
                           '-p', 'inputs:=features',
                           '-p', f'rig_file:={tmp_path / "rig.yaml"}',
                           '-p', f'initial_pose:={_ros_list(sequence.thetas[0])}',
                           '-p', 'initialization:=initial_pose',
                           '-p', 'diagnostics_period_s:=0.2')
    states, markers = [], []
    _collect(node, HandState, 'hand/state', states)
    _collect(node, MarkerArray, 'hand/markers', markers)
    parts = ('edges', 'edge_orientation', 'mask', 'flow')
    pubs = {(c, p): node.create_publisher(Image, f'{c}/{p}', 10) for c in names for p in parts}
    infos = {c: node.create_publisher(CameraInfo, f'{c}/camera_info', 10) for c in names}
    assert spin_until(lambda: 'tracking with cameras' in tracker.output() and all(
        p.get_subscription_count() for p in (*pubs.values(), *infos.values())), 90.0)
    extractors = {c: FeatureExtractor(c, FeaturesConfig()) for c in names}
    frames = [sequence.frame(k) for k in range(6)]
    messages = [{c: _feature_messages(extractors[c], c, f.images[i], f.stamp_ns)
                 for i, c in enumerate(names)} for f in frames]

    def send(k: int, cameras=names, skip: tuple = ()) -> None:
        for cam in cameras:
            for part, msg in messages[k][cam].items():
                if (cam, part) not in skip:
                    pubs[(cam, part)].publish(msg)

    def has_state(k: int, timeout_s: float = 30.0) -> bool:
        return spin_until(lambda: any(_stamp(s) == frames[k].stamp_ns for s in states),
                          timeout_s)

    cam0, cam1 = sequence.rig.cameras
    infos['cam0'].publish(_camera_info(cam0, frames[0].stamp_ns))     # none for cam1
    send(0)
    assert has_state(0), tracker.output()
    send(1)                                                          # flow with NaN rows
    assert has_state(1), tracker.output()
    assert spin_until(lambda: 'no camera_info on cam1/camera_info' in tracker.output(), 10.0)
    wrong = Image(header=messages[2]['cam0']['edges'].header, height=240, width=320,
                  encoding='rgb8', step=960, data=bytes(240 * 960))
    pubs[('cam0', 'edges')].publish(wrong)
    send(2, skip=(('cam0', 'edges'),))
    assert spin_until(lambda: 'cam0/edges: expected encoding mono8' in tracker.output(), 10.0)
    infos['cam1'].publish(_camera_info(cam1, frames[3].stamp_ns, width=640))
    assert spin_until(lambda: 'camera_info says 640x240' in tracker.output(), 10.0)
    send(3)                                                          # cam1 frames are dropped
    spin_until(lambda: False, 0.3)
    infos['cam1'].publish(_camera_info(cam1, frames[3].stamp_ns))    # fixed calibration
    for k in (4, 5):                                                 # but cam1 goes silent
        spin_until(lambda: False, 0.7)
        send(k, cameras=('cam0',))
    assert spin_until(lambda: 'cam1: no frames for more than' in tracker.output(), 10.0)
    assert not has_state(2, 0.1) and not has_state(3, 0.1) and not has_state(4, 0.1)
    send(5, cameras=('cam1',))                                       # cam1 is back
    assert has_state(5), tracker.output()
    # The hand leaves the images: LOST, DELETEALL markers, then a search for it (the initial
    # pose was the start only), which finds no hand in the empty masks of the next set.
    for k in range(1, 5):
        stamp = frames[5].stamp_ns + k * 40_000_000
        for (cam, part), msg in _restamped(messages[5], stamp).items():
            pubs[(cam, part)].publish(msg)
        if k < 4:
            assert spin_until(lambda s=stamp: any(_stamp(m) == s for m in states), 30.0)
    lost = [s for s in states if _stamp(s) > frames[5].stamp_ns]
    assert [s.status for s in lost] == [HandState.STATUS_LOST] * 3
    assert spin_until(lambda: len(markers) >= len(states), 5.0)
    assert [m.action for m in markers[-1].markers] == [Marker.DELETEALL]
    assert spin_until(lambda: 're-initializing from observations' in tracker.output(), 5.0)
    assert spin_until(lambda: 'cannot find the hand yet' in tracker.output(), 30.0)
    assert tracker.proc.poll() is None and 'Traceback' not in tracker.output()


def _restamped(messages: dict, stamp_ns: int) -> dict:
    """Camera -> part -> message copied to ``stamp_ns``, with empty masks and edge maps (the
    hand left the images)."""
    from sensor_msgs.msg import Image

    return {(cam, part): Image(header=_header(stamp_ns, msg.header.frame_id),
                               height=msg.height, width=msg.width, encoding=msg.encoding,
                               is_bigendian=msg.is_bigendian, step=msg.step,
                               data=bytes(len(msg.data)) if part in ('mask', 'edges')
                               else msg.data)
            for cam, parts in messages.items() for part, msg in parts.items()}


def test_unreadable_rig_file_is_a_clear_startup_error(tmp_path) -> None:
    import subprocess

    from hand_tracker_ros.ament import executable

    proc = subprocess.run([str(executable('tracker')), '--ros-args', '-p',
                           f'rig_file:={tmp_path / "missing.yaml"}'],
                          capture_output=True, text=True, timeout=60)
    assert proc.returncode != 0
    assert 'cannot read rig file' in proc.stdout + proc.stderr


def test_bad_shape_file_is_a_clear_startup_error(tmp_path) -> None:
    import subprocess

    from hand_tracker_ros.ament import executable
    from hand_tracker_ros.geometry.rig import CameraRig

    CameraRig.ring(3, 64, 48).to_yaml(tmp_path / 'rig.yaml')
    (tmp_path / 'shape.yaml').write_text('format: hand_tracker_ros/hand_shape/1\nscale: -1\n')
    proc = subprocess.run([str(executable('tracker')), '--ros-args',
                           '-p', 'cameras:=[cam0, cam1, cam2]',
                           '-p', f'rig_file:={tmp_path / "rig.yaml"}',
                           '-p', f'shape_file:={tmp_path / "shape.yaml"}'],
                          capture_output=True, text=True, timeout=60)
    assert proc.returncode != 0
    assert 'shape.yaml' in proc.stdout + proc.stderr
    assert 'finite and > 0: scale' in proc.stdout + proc.stderr
