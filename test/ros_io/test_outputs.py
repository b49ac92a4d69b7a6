"""TrackResult -> ROS messages (ros_io.estimates): names, stamps, every HandState field, marker
ids, DELETEALL, TF, robot_description, the same messages from the rclpy and the rosbags kit;
diagnostics; and the feature-topic decoding / frame assembly of ros_io.observations."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from hand_tracker_ros.core.result import TrackResult
from hand_tracker_ros.model.layout import PARAM_NAMES
from hand_tracker_ros.model.skeleton import KEYPOINT_NAMES
from hand_tracker_ros.node_config import NEUTRAL_POSE
from hand_tracker_ros.status import TrackStatus
from hand_tracker_ros.tracking.overlay import KEYPOINT_PARENTS, draw_overlay
from hand_tracker_ros.vision.edges import edges_within

pytestmark = pytest.mark.ros
STAMP_NS = 1_700_000_123_456_789_012


def _result(model, status: TrackStatus) -> TrackResult:
    theta = model.neutral_theta((0.01, -0.02, 0.03))
    return TrackResult(STAMP_NS, status, theta, model.pose(theta, jacobian=False), 17,
                       {'edges': 1.5, 'collision': 0.25}, 0.8)


def test_neutral_pose_default_matches_the_model(hand_model) -> None:
    np.testing.assert_array_equal(NEUTRAL_POSE, hand_model.neutral_theta())


def _encoder(model, publish_mesh=False, frame='world'):
    from hand_tracker_ros.ros_io.estimates import EstimateEncoder
    from hand_tracker_ros.ros_io.message_kit import RclpyKit

    return EstimateEncoder(RclpyKit(), model, frame, publish_mesh)


def test_joint_and_hand_state_carry_the_estimate(hand_model) -> None:
    result = _result(hand_model, TrackStatus.TRACKING)
    joints = _encoder(hand_model).joint_state(result)
    assert joints.name == list(PARAM_NAMES)
    np.testing.assert_array_equal(joints.position, result.theta)
    assert (joints.header.stamp.sec, joints.header.stamp.nanosec) == divmod(STAMP_NS, 10**9)
    assert joints.header.frame_id == 'world'
    state = _encoder(hand_model, frame='map').hand_state(result, 0.125)
    assert state.status == state.STATUS_TRACKING and state.header.frame_id == 'map'
    assert state.joint_names == list(PARAM_NAMES) and state.keypoint_names == list(KEYPOINT_NAMES)
    keypoints = np.array([(p.x, p.y, p.z) for p in state.keypoints])
    np.testing.assert_allclose(keypoints, result.posed.keypoints_m)
    tips = np.array([(p.x, p.y, p.z) for p in state.fingertips])
    np.testing.assert_allclose(tips, result.posed.fingertips_m)
    assert len(state.shape_names) == len(state.shape_parameters) == 19
    assert list(state.energy_names) == ['collision', 'edges']          # sorted
    assert dict(zip(state.energy_names, state.energy_costs)) == {'edges': 1.5, 'collision': 0.25}
    assert state.iterations == 17 and state.processing_time == pytest.approx(0.125)
    assert state.confidence == pytest.approx(0.8)
    lost = _encoder(hand_model).hand_state(_result(hand_model, TrackStatus.LOST), 0.0)
    assert lost.status == lost.STATUS_LOST and len(lost.joint_positions) == len(PARAM_NAMES)


def test_a_set_gives_every_output_topic_and_lost_ones_no_pose(hand_model) -> None:
    from hand_tracker_ros import topics

    encoder = _encoder(hand_model)
    tracked = encoder.messages(_result(hand_model, TrackStatus.TRACKING), 0.1)
    assert [t for t, _ in tracked] == list(topics.ESTIMATES)
    lost = encoder.messages(_result(hand_model, TrackStatus.LOST), 0.1)
    assert [t for t, _ in lost] == [topics.STATE, topics.MARKERS]


def test_a_result_of_another_shape_resends_the_urdf_and_is_encoded_with_it(hand_model
                                                                           ) -> None:
    """After the session refined the hand's scale: the URDF first, then HandState, TF and
    the mesh of the new model; the model after it is encoded without a new URDF."""
    from hand_tracker_ros import topics
    from hand_tracker_ros.model.hand import HandModel
    from hand_tracker_ros.model.shape import HandShape

    encoder = _encoder(hand_model, publish_mesh=True)
    larger = HandModel.build(HandShape(scale=1.05))
    result = _result(larger, TrackStatus.TRACKING)
    messages = dict(encoder.messages(result, 0.1))
    again = list(encoder.messages(result, 0.1))
    assert [t for t, _ in again] == list(topics.ESTIMATES)
    assert messages[topics.ROBOT_DESCRIPTION].data == \
        _encoder(larger).robot_description().data != \
        _encoder(hand_model).robot_description().data
    assert messages[topics.STATE].shape_parameters[0] == pytest.approx(1.05)
    assert messages[topics.TF] == _encoder(larger).tf(result)
    mesh = [m for m in messages[topics.MARKERS].markers if m.ns == 'mesh'][0]
    assert len(mesh.points) == larger.faces.size


def test_tf_chains_from_the_world_frame_to_every_bone(hand_model) -> None:
    result = _result(hand_model, TrackStatus.TRACKING)
    tf = _encoder(hand_model, frame='map').tf(result)
    poses = {'map': np.eye(4)}
    for t in tf.transforms:        # parents first
        assert t.header.stamp.nanosec == STAMP_NS % 10**9
        q = t.transform.rotation
        pose = np.eye(4)
        pose[:3, :3] = Rotation.from_quat([q.x, q.y, q.z, q.w]).as_matrix()
        v = t.transform.translation
        pose[:3, 3] = (v.x, v.y, v.z)
        poses[t.child_frame_id] = poses[t.header.frame_id] @ pose
    assert len(tf.transforms) == len(PARAM_NAMES)
    for b, name in enumerate(hand_model.part_names):
        np.testing.assert_allclose(poses[name], result.posed.bone_transforms[b], atol=1e-12)


def test_robot_description_is_the_urdf_rooted_at_the_world_frame(hand_model) -> None:
    from hand_tracker_ros.model.urdf import urdf_text

    text = _encoder(hand_model, frame='map').robot_description().data
    assert text == urdf_text(hand_model, root_link='map')
    repo_urdf = (Path(__file__).resolve().parents[2] / 'urdf' / 'hand.urdf').read_text()
    assert _encoder(hand_model).robot_description().data + '\n' == repo_urdf


def test_the_rclpy_and_the_rosbags_kit_build_the_same_messages(hand_model) -> None:
    """One conversion, two runtimes: the bag's CDR decodes to the node's message (both
    through CDR, which rounds the float32 fields)."""
    from rclpy.serialization import deserialize_message, serialize_message

    from hand_tracker_ros.bags.typestore import typestore
    from hand_tracker_ros.ros_io.estimates import EstimateEncoder
    from hand_tracker_ros.ros_io.message_kit import RosbagsKit, message_class

    bag = EstimateEncoder(RosbagsKit(), hand_model, 'world', publish_mesh=True)
    live = _encoder(hand_model, publish_mesh=True)
    for status in TrackStatus:
        result = _result(hand_model, status)
        pairs = list(zip(bag.messages(result, 0.5), live.messages(result, 0.5), strict=True))
        assert pairs and all(b[0] == lv[0] for b, lv in pairs)
        for (topic, from_bag), (_, from_node) in pairs:
            cls = message_class(topic.msgtype)
            raw = typestore().serialize_cdr(from_bag, topic.msgtype)
            assert deserialize_message(bytes(raw), cls) == \
                deserialize_message(serialize_message(from_node), cls)
    raw = typestore().serialize_cdr(bag.robot_description(), 'std_msgs/msg/String')
    assert deserialize_message(bytes(raw), message_class('std_msgs/msg/String')) == \
        live.robot_description()


def test_markers_have_stable_ids_and_deleteall_when_lost(hand_model) -> None:
    from visualization_msgs.msg import Marker

    result = _result(hand_model, TrackStatus.TRACKING)
    array = _encoder(hand_model).markers(result)
    assert [(m.ns, m.id, m.type) for m in array.markers] == [
        ('skeleton', 0, Marker.LINE_LIST), ('joints', 0, Marker.SPHERE_LIST),
        ('fingertips', 0, Marker.SPHERE_LIST)]
    skeleton, joints, tips = array.markers
    assert len(skeleton.points) == 2 * 20 and len(joints.points) == 21 and len(tips.points) == 5
    # The first bone runs from the wrist to the thumb CMC.
    first = np.array([(p.x, p.y, p.z) for p in skeleton.points[:2]])
    np.testing.assert_allclose(first, result.posed.keypoints_m[[0, 1]])
    assert all(m.header.stamp.nanosec == STAMP_NS % 10**9 for m in array.markers)
    assert all(m.pose.orientation.w == 1.0 for m in array.markers)
    with_mesh = _encoder(hand_model, publish_mesh=True).markers(result)
    mesh = with_mesh.markers[-1]
    assert (mesh.ns, mesh.type) == ('mesh', Marker.TRIANGLE_LIST)
    assert len(mesh.points) == 3 * len(hand_model.faces)
    lost = _encoder(hand_model).markers(_result(hand_model, TrackStatus.LOST))
    assert [m.action for m in lost.markers] == [Marker.DELETEALL]


def test_keypoint_parents_form_the_hand_tree() -> None:
    assert KEYPOINT_PARENTS[0] == -1
    names = dict(zip(KEYPOINT_NAMES, KEYPOINT_PARENTS))
    assert KEYPOINT_NAMES[names['index_mcp']] == 'wrist'
    assert KEYPOINT_NAMES[names['pinky_tip']] == 'pinky_dip'
    assert KEYPOINT_NAMES[names['thumb_mcp']] == 'thumb_cmc'


def test_diagnostics_report_rates_counters_and_status() -> None:
    from diagnostic_msgs.msg import DiagnosticStatus

    from hand_tracker_ros.ros_io import outputs
    from hand_tracker_ros.sync.approximate import ApproximateTimeSync

    sync = ApproximateTimeSync(['cam0', 'cam1'])
    for stamp in (10, 20):
        sync.add('cam0', stamp, None)
        sync.add('cam1', stamp, None)
    sync.add('cam0', 30, None)
    health = outputs.TrackerHealth(
        period_s=2.0, frames={'cam0': 6, 'cam1': 4}, camera_problems={'cam1': 'cam1: silent'},
        assembler_counts={'cam0': {'frames': 6}}, sync=sync.stats, processed=2, skipped=1,
        latencies_s=[0.1, 0.3], processing_s=[0.05], iterations=[10, 20],
        confidence=[0.9, 0.2], status=TrackStatus.LOST, reinitializations=0)
    msg = outputs.diagnostics_msg('tracker', health, STAMP_NS)
    cam0, cam1, tracking = msg.status
    values = {s.name: {kv.key: kv.value for kv in s.values} for s in msg.status}
    assert values['tracker: cam0 input']['input_rate_hz'] == '3.00'
    assert values['tracker: cam0 input']['received'] == '3'
    assert cam0.level == DiagnosticStatus.OK
    assert cam1.level == DiagnosticStatus.WARN and cam1.message == 'cam1: silent'
    assert tracking.level == DiagnosticStatus.WARN and tracking.message == 'lost'
    assert values['tracker: tracking']['latency_mean_ms'] == '200.0'
    assert values['tracker: tracking']['lm_iterations_mean'] == '15.0'
    assert values['tracker: tracking']['processing_mean_ms'] == '50.0'
    assert values['tracker: tracking']['emitted_sets'] == '2'
    assert values['tracker: tracking']['skipped_sets'] == '1'
    assert values['tracker: tracking']['confidence_last'] == '0.200'
    assert values['tracker: tracking']['confidence_min'] == '0.200'


def _image(pixels: np.ndarray, encoding: str, stamp_ns: int = 5):
    from std_msgs.msg import Header

    from hand_tracker_ros.ros_io.images import image_msg

    msg = image_msg(pixels, Header())
    msg.encoding = encoding
    msg.header.stamp.sec, msg.header.stamp.nanosec = divmod(stamp_ns, 10**9)
    return msg


def test_feature_images_decode_and_bad_ones_are_clear_errors() -> None:
    from hand_tracker_msgs.msg import SalientPoint, SalientPoints

    from hand_tracker_ros.errors import ImageFormatError, ShapeError
    from hand_tracker_ros.ros_io.observations import feature_image, part_value

    rng = np.random.default_rng(0)
    flow = rng.normal(size=(6, 8, 2)).astype(np.float32)
    flow[2, 3] = np.nan
    decoded = feature_image(_image(flow, '32FC2'), 'cam0', 'flow', (8, 6))
    np.testing.assert_array_equal(decoded, flow)
    edges = part_value(_image(np.eye(6, 8, dtype=np.uint8) * 255, 'mono8'), 'cam0', 'edges',
                       (8, 6))
    assert edges.dtype == bool and edges.sum() == 6
    with pytest.raises(ImageFormatError, match='cam0/mask: expected encoding mono8'):
        feature_image(_image(np.zeros((6, 8, 3), np.uint8), 'rgb8'), 'cam0', 'mask', (8, 6))
    with pytest.raises(ImageFormatError, match='image is 8x6 but the tracker works at 16x12'):
        feature_image(_image(np.zeros((6, 8), np.uint8), 'mono8'), 'cam0', 'mask', (16, 12))
    tips = SalientPoints(width=8, height=6,
                         points=[SalientPoint(u=1.0, v=2.0, score=0.5),
                                 SalientPoint(u=float('nan'), v=2.0, score=0.5)])
    with pytest.raises(ShapeError, match='cam1/salient_points: '):
        part_value(tips, 'cam1', 'salient_points', (8, 6))
    with pytest.raises(ImageFormatError, match='detections in a 8x6 image but the tracker '
                       'works at 16x12'):
        part_value(tips, 'cam1', 'salient_points', (16, 12))
    tips.points.pop()
    assert part_value(tips, 'cam1', 'salient_points', (8, 6)).uv_px.tolist() == [[1.0, 2.0]]
    bad = np.zeros((6, 8), np.float32)
    bad[0, 0] = np.inf
    with pytest.raises(ImageFormatError, match='1 non-finite'):
        feature_image(_image(bad, '32FC1'), 'cam0', 'edge_orientation', (8, 6))


def test_nan_flow_becomes_invalid_flow_in_the_observation(hand_model) -> None:
    from hand_tracker_ros.geometry.rig import CameraRig
    from hand_tracker_ros.ros_io.observations import CameraFrame, camera_observation

    camera = CameraRig.ring(1, 16, 12)[0]
    flow = np.ones((12, 16, 2), np.float32)
    flow[:, 8:] = np.nan
    edges = np.zeros((12, 16), bool)
    edges[6, 4] = True
    frame = CameraFrame('cam0', 7, edges, np.zeros((12, 16), np.float32),
                        np.ones((12, 16), bool), flow, None)
    obs = camera_observation(frame, camera)
    carried, valid = obs.features.flow.flow_at(np.array([[2.0, 3.0], [12.0, 3.0]]))
    np.testing.assert_array_equal(valid, [True, False])
    np.testing.assert_allclose(carried[0], [3.0, 4.0])
    near = edges_within(obs.features.edges, np.array([[4.0, 6.0], [6.0, 4.0]]), 0.0)
    np.testing.assert_array_equal(near, [True, False])     # (u, v): column 4, row 6
    assert obs.tips.uv_px.shape == (0, 2) and obs.features.roi_px == (0, 0, 16, 12)


def test_assembler_waits_only_for_optional_parts_it_has_seen() -> None:
    from hand_tracker_ros.ros_io.observations import FrameAssembler

    asm = FrameAssembler('cam0', wait_s=0.1, max_pending=2)
    req = {'edges': np.zeros((2, 2), bool), 'edge_orientation': np.zeros((2, 2), np.float32),
           'mask': np.ones((2, 2), bool)}
    # Frame 1: required parts only, no optional part ever seen -> released at once.
    frames = [asm.add(p, 1, v, 0.0) for p, v in req.items()]
    assert frames[:2] == [None, None] and frames[2].flow_px is None and frames[2].tips is None
    # Frame 2: flow arrives first; from now on flow is waited for.
    assert asm.add('flow', 2, np.zeros((2, 2, 2), np.float32), 0.0) is None
    done = [asm.add(p, 2, v, 0.0) for p, v in req.items()][-1]
    assert done is not None and done.flow_px is not None
    # Frame 3: no flow -> waits, released by expire after wait_s.
    assert [asm.add(p, 3, v, 1.0) for p, v in req.items()] == [None] * 3
    assert asm.expire(1.05) == []
    [late] = asm.expire(1.11)
    assert late.stamp_ns == 3 and late.flow_px is None
    assert asm.add('flow', 3, np.zeros((2, 2, 2), np.float32), 1.2) is None
    assert dict(asm.counts) == {'frames': 3, 'timed_out': 1, 'dropped': 0, 'late': 1}
    for stamp in (4, 5, 6):
        asm.add('mask', stamp, req['mask'], 2.0)
    assert asm.counts['dropped'] == 1


def test_overlay_draws_contour_and_skeleton() -> None:
    base = np.zeros((40, 50), np.uint8)
    base[10:30, 10:30] = 255
    mask = np.zeros((40, 50), bool)
    mask[12:28, 14:34] = True
    uv = np.full((len(KEYPOINT_PARENTS), 2), np.nan)
    uv[0] = (20.0, 20.0)
    uv[1] = (40.0, 5.0)
    out = draw_overlay(base, mask, uv)
    assert out.shape == (40, 50, 3) and out.dtype == np.uint8
    assert tuple(out[12, 20]) == (0, 255, 0)        # on the model contour
    assert out[12:28, 14:34].sum() > 0 and tuple(out[0, 0]) == (0, 0, 0)
    assert (tuple(out[12, 30]) == (255, 40, 40)) or (tuple(out[13, 30]) == (255, 40, 40))
    assert tuple(out[20, 20]) == (255, 40, 40)                   # the wrist keypoint
