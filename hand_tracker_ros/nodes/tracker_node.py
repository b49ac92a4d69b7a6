"""The `tracker` node: synchronized multi-camera hand tracking.

Topics (relative names, so namespaces and remaps work)
------------------------------------------------------
Subscribed per camera ``<cam>`` of ``cameras`` (sensor-data QoS, depth ``queue_depth``):
with ``inputs:=images`` (default, the *composed* graph, :mod:`.composed`: the process also
hosts the features and salient_points nodes, data in memory) ``<cam>/<image_topic>``
(``image_transport`` raw or compressed); with ``inputs:=features`` (the *distributed* graph)
``<cam>/edges``, ``<cam>/edge_orientation``, ``<cam>/mask``, ``<cam>/flow`` and
``<cam>/salient_points`` from features and salient_points processes; and
``<cam>/camera_info``. Published: ``joint_states`` (JointState, only while TRACKING),
``hand_state`` (HandState, every processed set, LOST included), ``markers`` (MarkerArray,
DELETEALL when not tracking), ``/diagnostics`` (every ``diagnostics_period_s``) and, with
``publish_overlay``, ``<cam>/overlay`` (rgb8). Output stamps are the input set's stamp,
frame ids ``world_frame`` (overlays: ``<cam>`` + ``optical_frame_suffix``).

Data flow and threading
-----------------------
The ROS callbacks only check and group: feature messages become arrays
(``ros_io.observations.part_value``) grouped per camera by stamp
(``ros_io.observations.FrameAssembler``, see there for ``optional_wait_ms``); image messages
are kept as they are. Camera frames go through our approximate-time synchronizer
(``sync.approximate``, slop ``sync_slop_ms``) and each complete set is offered to a
:class:`hand_tracker_ros.pipeline.live.LivePipeline`, which observes the newest set on one
thread and tracks and publishes on another. Skipped sets are counted; the session's
constant-velocity prediction spans them. ``budget_ms`` (0: the measured period between sets)
caps each main fit (:meth:`.TrackingSession.step`); played slowly, every set gets every round.

Tracking policy: the node drives a :class:`hand_tracker_ros.tracking.session.TrackingSession`,
the same one the offline pipeline uses (start, recovery, LOST, confidence; ``session.*``).
``initialization``: ``observations`` (default) searches the hand in the first complete set and
again after ``session.failure.reinit_after`` consecutive LOST frames; ``initial_pose`` starts
at, and resets to, that pose. The camera intrinsics and extrinsics come from
``rig_file``; a camera_info whose size contradicts the rig drops that camera's frames with
a throttled error; a missing camera_info is only reported (the rig is used). Without a
``rig_file`` the node refuses to start and says so. The hand's size comes from ``shape_file``
(the default hand when empty); HandState's ``shape_parameters`` and the markers follow it.
"""
from __future__ import annotations

import sys
import threading
import time
import traceback
from collections import Counter
from collections.abc import Callable, Sequence
from functools import partial
from types import MappingProxyType
from typing import Any

import numpy as np
import rclpy
from diagnostic_msgs.msg import DiagnosticArray
from hand_tracker_msgs.msg import HandState, SalientPoints
from rclpy.clock import Clock, ClockType
from rclpy.node import Node
from rclpy.qos import QoSProfile, qos_profile_sensor_data
from sensor_msgs.msg import CameraInfo, CompressedImage, Image, JointState
from visualization_msgs.msg import MarkerArray

from hand_tracker_ros.errors import ConfigError, HandTrackerError
from hand_tracker_ros.geometry.rig import CameraRig
from hand_tracker_ros.model.hand import HandModel
from hand_tracker_ros.model.layout import P
from hand_tracker_ros.model.shape_file import shape_or_default
from hand_tracker_ros.node_config import TrackerNodeConfig
from hand_tracker_ros.nodes._runner import run_node
from hand_tracker_ros.ros_io import outputs
from hand_tracker_ros.ros_io.images import image_msg, intrinsics_from_info
from hand_tracker_ros.ros_io.logging_bridge import bridge_core_logging
from hand_tracker_ros.ros_io.observations import (PARTS, FrameAssembler,
                                                  frame_observations, part_value, stamp_ns_of)
from hand_tracker_ros.ros_io.params import declare_config
from hand_tracker_ros.pipeline.live import LivePipeline
from hand_tracker_ros.pipeline.warmup import warm_up
from hand_tracker_ros.sync.approximate import ApproximateTimeSync, SyncConfig, SyncedSet
from hand_tracker_ros.tracking.observations import FrameObservations
from hand_tracker_ros.tracking.overlay import observation_overlays
from hand_tracker_ros.tracking.result import TrackResult, TrackStatus
from hand_tracker_ros.tracking.session import TrackingSession
from hand_tracker_ros.tracking.tracker import HandTracker

DESCRIPTION = 'Synchronized multi-camera hand tracking (collision-aware Levenberg-Marquardt).'
THROTTLE_S = 5.0
FLUSH_PERIOD_S = 0.01
INFO_GRACE_S = 2.0
SILENT_S = 1.0


def _load_rig(config: TrackerNodeConfig) -> CameraRig:
    rig = CameraRig.from_yaml(config.rig_file)
    missing = [c for c in config.cameras if c not in rig.names]
    if missing:
        msg = f'cameras {missing} are not in the rig {config.rig_file} ({list(rig.names)})'
        raise ConfigError(msg)
    if len(config.initial_pose) != P:
        msg = f'`initial_pose` must have {P} numbers, got {len(config.initial_pose)}'
        raise ConfigError(msg)
    return rig


class TrackerNode(Node):
    """Synchronized multi-camera hand tracking (collision-aware Levenberg-Marquardt)."""

    def __init__(self) -> None:
        super().__init__('tracker')
        bridge_core_logging(self)
        self.config = declare_config(self, TrackerNodeConfig)
        self._pipeline: LivePipeline[SyncedSet, FrameObservations] | None = None
        try:
            if not self.config.rig_file:
                msg = ('no `rig_file` parameter: the tracker needs the camera rig (intrinsics '
                       '+ extrinsics), e.g. -p rig_file:=rig.yaml (schema: '
                       'config/rig_example.yaml)')
                raise ConfigError(msg)
            rig = _load_rig(self.config)
            shape = shape_or_default(self.config.shape_file)
        except HandTrackerError as err:
            self.get_logger().fatal(str(err))
            raise
        if rig.world_frame != self.config.world_frame:
            self.get_logger().warning(f'rig extrinsics are in {rig.world_frame!r}; outputs are '
                                      f'labelled world_frame={self.config.world_frame!r}')
        self.cameras = tuple(rig[c] for c in self.config.cameras)
        self._by_name = {c.name: c for c in self.cameras}
        self._model = HandModel.build(shape)
        initial = (np.asarray(self.config.initial_pose, np.float64)
                   if self.config.initialization == 'initial_pose' else None)
        self._tracker = HandTracker(self._model, self.cameras, self.config.tracking)
        self._session = TrackingSession(self._tracker, self.config.session,
                                        initial_pose=initial)
        self._init_state()
        self._create_outputs()
        if self.config.inputs == 'features':
            self.start(lambda synced: frame_observations(synced.stamp_ns, synced.items,
                                                         self.cameras))

    @property
    def session(self) -> TrackingSession:
        """The tracking session (its status steers the in-process detection)."""
        return self._session

    def start(self, observe: Callable[[SyncedSet], FrameObservations]) -> None:
        """Warm up, then subscribe to the inputs and track: ``observe`` turns a synchronized
        set (feature frames, or image messages with ``inputs:=images``) into observations."""
        if self.config.warm_up:
            self.get_logger().info(f'JIT kernels loaded in {warm_up(self._model):.1f} s')
        self._pipeline = LivePipeline(observe, self._track, self._on_error)
        self._create_inputs()
        self.get_logger().info(f'ready: tracking with cameras {list(self.config.cameras)} '
                               f'from {self.config.inputs}')

    def _init_state(self) -> None:
        cfg = self.config
        self._sync = ApproximateTimeSync(cfg.cameras, SyncConfig(
            slop_ns=round(cfg.sync_slop_ms * 1e6), queue_size=cfg.sync_queue_size))
        self._assemblers = {c: FrameAssembler(c, cfg.optional_wait_ms / 1e3,
                                              cfg.max_pending_frames) for c in cfg.cameras}
        self._lock = threading.Lock()
        self._frames: Counter[str] = Counter()
        self._last_frame_s: dict[str, float] = {}
        self._first_frame_s: dict[str, float] = {}
        self._info_s: dict[str, float] = {}
        self._problems: dict[str, str] = {}
        self._size_mismatch: set[str] = set()
        self._period = self._new_period()
        self._status: TrackStatus | None = None
        self._reinits = 0
        self._logged: dict[str, float] = {}

    def _create_outputs(self) -> None:
        cfg = self.config
        self._pub_joints = self.create_publisher(JointState, 'joint_states', 10)
        self._pub_state = self.create_publisher(HandState, 'hand_state', 10)
        self._pub_markers = self.create_publisher(MarkerArray, 'markers', 10)
        self._pub_diag = self.create_publisher(DiagnosticArray, '/diagnostics', 10)
        self._pub_overlay = {c: self.create_publisher(Image, f'{c}/overlay', 2)
                             for c in cfg.cameras} if cfg.publish_overlay else {}
        # Wall-clock timers: frame waits and diagnostics must run even when sim time pauses.
        self._steady = Clock(clock_type=ClockType.STEADY_TIME)
        self.create_timer(cfg.diagnostics_period_s, self._diagnose, clock=self._steady)

    def _create_inputs(self) -> None:
        cfg = self.config
        sensor = QoSProfile(depth=cfg.queue_depth,
                            reliability=qos_profile_sensor_data.reliability,
                            history=qos_profile_sensor_data.history)
        for cam in cfg.cameras:
            if cfg.inputs == 'images':
                kind, suffix = ((Image, '') if cfg.image_transport == 'raw'
                                else (CompressedImage, '/compressed'))
                self.create_subscription(kind, f'{cam}/{cfg.image_topic}{suffix}',
                                         partial(self._on_image, cam), sensor)
            else:
                for part in PARTS:
                    kind = SalientPoints if part == 'salient_points' else Image
                    self.create_subscription(kind, f'{cam}/{part}',
                                             partial(self._on_part, cam, part), sensor)
            self.create_subscription(CameraInfo, f'{cam}/camera_info',
                                     partial(self._on_info, cam), sensor)
        if cfg.inputs == 'features':
            self.create_timer(FLUSH_PERIOD_S, self._flush, clock=self._steady)

    def _on_image(self, camera: str, msg: Image | CompressedImage) -> None:
        if camera not in self._size_mismatch:
            self._on_camera_frame(camera, stamp_ns_of(msg), msg)

    def _on_part(self, camera: str, part: str, msg: Image | SalientPoints) -> None:
        if camera in self._size_mismatch:
            return
        cam = self._by_name[camera]
        try:
            value = part_value(msg, camera, part, (cam.width, cam.height))
        except HandTrackerError as err:
            self._log_throttled(f'{camera}/{part}', 'error', f'dropping a message: {err}')
            return
        frame = self._assemblers[camera].add(part, stamp_ns_of(msg), value, time.monotonic())
        if frame is not None:
            self._on_camera_frame(camera, frame.stamp_ns, frame)

    def _flush(self) -> None:
        now = time.monotonic()
        for assembler in self._assemblers.values():
            for frame in assembler.expire(now):
                self._on_camera_frame(frame.camera_name, frame.stamp_ns, frame)

    def _on_camera_frame(self, camera: str, stamp_ns: int, item: Any) -> None:
        """(Executor thread.) One camera's frame, image message or assembled features, into
        the synchronizer; complete sets go to the pipeline threads."""
        now = time.monotonic()
        self._frames[camera] += 1
        self._last_frame_s[camera] = now
        self._first_frame_s.setdefault(camera, now)
        for synced in self._sync.add(camera, stamp_ns, item):
            assert self._pipeline is not None
            self._pipeline.offer(synced, now)

    def _on_info(self, camera: str, msg: CameraInfo) -> None:
        self._info_s[camera] = time.monotonic()
        cam = self._by_name[camera]
        try:
            width, height, K, _, _ = intrinsics_from_info(msg, camera)
        except HandTrackerError as err:
            self._log_throttled(f'{camera}/camera_info', 'error',
                                f'{err}; using the rig intrinsics')
            return
        if (width, height) != (cam.width, cam.height):
            problem = (f'{camera}: camera_info says {width}x{height} but the rig says '
                       f'{cam.width}x{cam.height}; dropping {camera} frames')
            self._problems[camera] = problem
            self._size_mismatch.add(camera)
            self._log_throttled(f'{camera}/camera_info', 'error', problem)
            return
        self._size_mismatch.discard(camera)
        self._problems.pop(camera, None)
        if not np.allclose(K, cam.K, rtol=1e-3, atol=1e-3):
            self._log_throttled(f'{camera}/camera_info', 'warning',
                                f'{camera}: camera_info K differs from the rig; using the rig')

    def _input_problems(self, now: float) -> dict[str, str]:
        """Per camera: size mismatch, frames without camera_info, silent while others send."""
        problems = dict(self._problems)
        newest = max(self._last_frame_s.values(), default=None)
        for cam in self.config.cameras:
            if cam not in self._info_s and now - self._first_frame_s.get(cam, now) > \
                    INFO_GRACE_S:
                problems.setdefault(cam, f'no camera_info on {cam}/camera_info; using the '
                                         'rig intrinsics')
            last = self._last_frame_s.get(cam)
            if newest is not None and (last is None or newest - last > SILENT_S):
                problems.setdefault(cam, f'{cam}: no frames for more than {SILENT_S:.0f} s '
                                         'while other cameras send; no sets can be formed')
        return problems

    @staticmethod
    def _new_period() -> dict[str, Any]:
        """Counters of one diagnostics period (filled by the processing thread)."""
        return {'processed': 0, 'latencies_s': [], 'processing_s': [], 'iterations': [],
                'confidence': []}

    def _log_throttled(self, key: str, level: str, text: str) -> None:
        """Log ``text`` at most every THROTTLE_S per ``key`` (rclpy throttles per call site,
        which would let one camera's message hide another's)."""
        now = time.monotonic()
        if now - self._logged.get(key, -THROTTLE_S) < THROTTLE_S:
            return
        self._logged[key] = now
        # One call site per severity: an rclpy logger call site may not change severity.
        if level == 'error':
            self.get_logger().error(text)
        else:
            self.get_logger().warning(text)

    def _diagnose(self) -> None:
        now = time.monotonic()
        problems = self._input_problems(now)
        for problem in set(problems.values()) - set(self._problems.values()):
            self._log_throttled(problem, 'warning', problem)
        with self._lock:
            period, self._period = self._period, self._new_period()
            status, reinits = self._status, self._reinits
        health = outputs.TrackerHealth(
            period_s=self.config.diagnostics_period_s,
            frames={c: self._frames[c] for c in self.config.cameras},
            camera_problems=MappingProxyType(problems),
            assembler_counts={c: dict(a.counts) for c, a in self._assemblers.items()},
            sync=self._sync.stats, processed=period['processed'],
            skipped=self._pipeline.skipped if self._pipeline else 0,
            latencies_s=period['latencies_s'],
            processing_s=period['processing_s'], iterations=period['iterations'],
            confidence=period['confidence'], status=status, reinitializations=reinits)
        self._frames.clear()
        self._pub_diag.publish(outputs.diagnostics_msg(
            self.get_name(), health, self.get_clock().now().nanoseconds))

    def _on_error(self, err: BaseException) -> None:
        """A pipeline thread's failure on one set: logged (throttled), the node goes on."""
        if not rclpy.ok(context=self.context):
            return
        if isinstance(err, HandTrackerError):
            self._log_throttled('observe', 'error', f'dropping a set: {err}')
            return
        text = ''.join(traceback.format_exception(err))
        self._log_throttled('track', 'error', f'tracking a set failed:\n{text}')

    def _track(self, synced: SyncedSet, observations: FrameObservations,
               received_s: float) -> None:
        restarts = self._session.restarts
        assert self._pipeline is not None
        budget_s = self.config.budget_ms / 1e3 or self._pipeline.period_s
        try:
            result = self._session.step(observations, deadline_s=time.monotonic() + budget_s
                                        if budget_s else None)
        except HandTrackerError as err:
            self._log_throttled('initialize', 'warning', f'cannot find the hand yet: {err}')
            return
        processing_s = time.monotonic() - received_s
        self._publish(result, observations, processing_s)
        latency_s = (self.get_clock().now().nanoseconds - synced.stamp_ns) / 1e9
        restarted = self._session.restarts - restarts
        if restarted:
            self.get_logger().warning(f'hand lost: re-initializing from '
                                      f'{self.config.initialization}')
        elif result.status != TrackStatus.TRACKING:
            self._log_throttled('lost', 'warning', f'hand lost (confidence '
                                f'{result.confidence:.2f}, {self._session.lost_frames} frames '
                                'in a row)')
        with self._lock:
            self._period['processed'] += 1
            self._period['latencies_s'].append(latency_s)
            self._period['processing_s'].append(processing_s)
            self._period['iterations'].append(result.iterations)
            self._period['confidence'].append(result.confidence)
            self._status = result.status
            self._reinits += restarted

    def _publish(self, result: TrackResult, observations: FrameObservations,
                 processing_s: float) -> None:
        frame_id = self.config.world_frame
        if result.status == TrackStatus.TRACKING:
            self._pub_joints.publish(outputs.joint_state_msg(result, frame_id))
        faces = self._model.faces if self.config.publish_mesh else None
        self._pub_markers.publish(outputs.marker_array_msg(result, faces, frame_id))
        self._pub_state.publish(outputs.hand_state_msg(result, self._model, frame_id,
                                                       processing_s))
        if self._pub_overlay:
            self._publish_overlays(result, observations)

    def _publish_overlays(self, result: TrackResult, observations: FrameObservations) -> None:
        images = observation_overlays(result.posed, self._tracker.views(result.posed),
                                      observations, self.config.overlay_source)
        for obs, rgb in zip(observations.cameras, images):
            header = outputs.header_at(observations.stamp_ns,
                                       obs.camera.name + self.config.optical_frame_suffix)
            self._pub_overlay[obs.camera.name].publish(image_msg(rgb, header))

    def destroy_node(self) -> None:
        """Stop the pipeline threads, then the node."""
        if self._pipeline is not None:
            self._pipeline.close()
        super().destroy_node()


def main(args: Sequence[str] | None = None) -> int:
    """Console entry point (`ros2 run hand_tracker_ros tracker`): the tracker, with
    ``inputs:=images`` composed with the features and salient_points nodes."""
    from hand_tracker_ros.nodes.composed import compose  # the other two nodes' imports

    try:
        return run_node('tracker', DESCRIPTION, TrackerNodeConfig, compose, args)
    except HandTrackerError as err:     # a rig or parameters it cannot run with
        print(f'tracker: error: {err}', file=sys.stderr)
        return 2


if __name__ == '__main__':
    raise SystemExit(main())
