"""The `tracker` node: synchronized multi-camera hand tracking.

Topics (relative names, so namespaces and remaps work)
------------------------------------------------------
Subscribed per camera ``<cam>`` of the ``cameras`` parameter (sensor-data QoS, depth
``queue_depth``): ``<cam>/edges``, ``<cam>/edge_orientation``, ``<cam>/mask``, ``<cam>/flow``
(from the ``features`` node), ``<cam>/salient_points`` (from ``salient_points``) and
``<cam>/camera_info``. Published: ``joint_states`` (JointState, only while TRACKING),
``hand_state`` (HandState, every processed set, LOST included), ``markers`` (MarkerArray,
DELETEALL when not tracking), ``/diagnostics`` (every ``diagnostics_period_s``) and, with
``publish_overlay``, ``<cam>/overlay`` (rgb8). Output stamps are the input set's stamp,
frame ids ``world_frame`` (overlays: ``<cam>`` + ``optical_frame_suffix``).

Data flow and threading
-----------------------
The ROS callbacks only decode: each message is checked and turned into arrays
(``ros_io.observations.part_value``), grouped per camera by stamp
(``ros_io.observations.FrameAssembler``; flow and salient points are optional, see there
for the ``optional_wait_ms`` rule), and the camera frames go through our approximate-time
synchronizer (``sync.approximate``, slop ``sync_slop_ms``). A complete set is put into a
one-slot mailbox. A dedicated processing thread takes the set, builds the observations
(edge lookup tables), runs the tracker and publishes. If a new set arrives before the thread
took the previous one, the previous one is replaced and counted as skipped, so the node
always works on the newest set and never queues more than one set beyond the one in
progress. A plain thread was chosen over a MultiThreadedExecutor with callback groups
because the one-slot mailbox states the "newest set wins" policy directly and the
executor thread stays free for callbacks and timers whatever the tracker costs.

Tracking policy: the node drives a :class:`hand_tracker_ros.tracking.session.TrackingSession`,
the same one the offline pipeline uses (start, recovery, LOST, confidence; ``session.*``).
``initialization``: ``observations`` (default) searches the hand in the first complete set and
again after ``session.failure.reinit_after`` consecutive LOST frames; ``initial_pose`` starts
at, and resets to, that pose. The camera intrinsics and extrinsics come from
``rig_file``; a camera_info whose size contradicts the rig drops that camera's frames with
a throttled error; a missing camera_info is only reported (the rig is used). Without a
``rig_file`` the node stays idle and says so.
"""
from __future__ import annotations

import threading
import time
import traceback
from collections import Counter
from collections.abc import Sequence
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
from sensor_msgs.msg import CameraInfo, Image, JointState
from visualization_msgs.msg import MarkerArray

from hand_tracker_ros.errors import ConfigError, HandTrackerError
from hand_tracker_ros.geometry.rig import CameraRig
from hand_tracker_ros.model.hand import HandModel
from hand_tracker_ros.model.layout import P
from hand_tracker_ros.node_config import TrackerNodeConfig
from hand_tracker_ros.nodes._runner import run_node
from hand_tracker_ros.ros_io import outputs
from hand_tracker_ros.ros_io.images import image_msg, intrinsics_from_info
from hand_tracker_ros.ros_io.logging_bridge import bridge_core_logging
from hand_tracker_ros.ros_io.observations import (PARTS, CameraFrame, FrameAssembler,
                                                  frame_observations, part_value, stamp_ns_of)
from hand_tracker_ros.ros_io.params import declare_config
from hand_tracker_ros.sync.approximate import ApproximateTimeSync, SyncConfig, SyncedSet
from hand_tracker_ros.tracking.overlay import draw_overlay
from hand_tracker_ros.tracking.result import TrackResult, TrackStatus
from hand_tracker_ros.tracking.session import TrackingSession
from hand_tracker_ros.tracking.tracker import HandTracker

DESCRIPTION = 'Synchronized multi-camera hand tracking (collision-aware Levenberg-Marquardt).'
THROTTLE_S = 5.0
FLUSH_PERIOD_S = 0.01
INFO_GRACE_S = 2.0
SILENT_S = 1.0


class LatestSet:
    """A one-slot mailbox between the executor and the processing thread (newest wins)."""

    def __init__(self) -> None:
        self._cond = threading.Condition()
        self._item: tuple[SyncedSet, float] | None = None
        self.skipped = 0

    def put(self, synced: SyncedSet, received_s: float) -> None:
        """Offer a set (received at monotonic ``received_s``); replaces an untaken one."""
        with self._cond:
            self.skipped += self._item is not None
            self._item = (synced, received_s)
            self._cond.notify()

    def take(self, timeout_s: float) -> tuple[SyncedSet, float] | None:
        """The newest set, or None after ``timeout_s``."""
        with self._cond:
            if self._item is None:
                self._cond.wait(timeout_s)
            item, self._item = self._item, None
            return item


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
        self._stop = threading.Event()
        self._worker: threading.Thread | None = None
        if not self.config.rig_file:
            self.get_logger().error('no `rig_file` parameter: the tracker needs the camera '
                                    'rig (intrinsics + extrinsics); staying idle')
            return
        try:
            rig = _load_rig(self.config)
        except HandTrackerError as err:
            self.get_logger().fatal(str(err))
            raise
        if rig.world_frame != self.config.world_frame:
            self.get_logger().warning(f'rig extrinsics are in {rig.world_frame!r}; outputs are '
                                      f'labelled world_frame={self.config.world_frame!r}')
        self._cameras = tuple(rig[c] for c in self.config.cameras)
        self._by_name = {c.name: c for c in self._cameras}
        self._model = HandModel.build()
        initial = (np.asarray(self.config.initial_pose, np.float64)
                   if self.config.initialization == 'initial_pose' else None)
        self._tracker = HandTracker(self._model, self._cameras, self.config.tracking)
        self._session = TrackingSession(self._tracker, self.config.session,
                                        initial_pose=initial)
        self._init_state()
        self._create_interfaces()
        self._worker = threading.Thread(target=self._work, name='tracker', daemon=True)
        self._worker.start()
        self.get_logger().info(f'tracking with cameras {list(self.config.cameras)}')

    def _init_state(self) -> None:
        cfg = self.config
        self._sync = ApproximateTimeSync(cfg.cameras, SyncConfig(
            slop_ns=round(cfg.sync_slop_ms * 1e6), queue_size=cfg.sync_queue_size))
        self._assemblers = {c: FrameAssembler(c, cfg.optional_wait_ms / 1e3,
                                              cfg.max_pending_frames) for c in cfg.cameras}
        self._mailbox = LatestSet()
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
        self._start_s = time.monotonic()
        self._logged: dict[str, float] = {}

    def _create_interfaces(self) -> None:
        cfg = self.config
        sensor = QoSProfile(depth=cfg.queue_depth,
                            reliability=qos_profile_sensor_data.reliability,
                            history=qos_profile_sensor_data.history)
        for cam in cfg.cameras:
            for part in PARTS:
                kind = SalientPoints if part == 'salient_points' else Image
                self.create_subscription(kind, f'{cam}/{part}', partial(self._on_part, cam, part),
                                         sensor)
            self.create_subscription(CameraInfo, f'{cam}/camera_info',
                                     partial(self._on_info, cam), sensor)
        self._pub_joints = self.create_publisher(JointState, 'joint_states', 10)
        self._pub_state = self.create_publisher(HandState, 'hand_state', 10)
        self._pub_markers = self.create_publisher(MarkerArray, 'markers', 10)
        self._pub_diag = self.create_publisher(DiagnosticArray, '/diagnostics', 10)
        self._pub_overlay = {c: self.create_publisher(Image, f'{c}/overlay', 2)
                             for c in cfg.cameras} if cfg.publish_overlay else {}
        # Wall-clock timers: frame waits and diagnostics must run even when sim time pauses.
        steady = Clock(clock_type=ClockType.STEADY_TIME)
        self.create_timer(FLUSH_PERIOD_S, self._flush, clock=steady)
        self.create_timer(cfg.diagnostics_period_s, self._diagnose, clock=steady)

    # --- executor thread: decode, assemble, synchronize -----------------------------------

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
            self._on_frame(frame)

    def _flush(self) -> None:
        now = time.monotonic()
        for assembler in self._assemblers.values():
            for frame in assembler.expire(now):
                self._on_frame(frame)

    def _on_frame(self, frame: CameraFrame) -> None:
        now = time.monotonic()
        self._frames[frame.camera_name] += 1
        self._last_frame_s[frame.camera_name] = now
        self._first_frame_s.setdefault(frame.camera_name, now)
        for synced in self._sync.add(frame.camera_name, frame.stamp_ns, frame):
            self._mailbox.put(synced, now)

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
            skipped=self._mailbox.skipped, latencies_s=period['latencies_s'],
            processing_s=period['processing_s'], iterations=period['iterations'],
            confidence=period['confidence'], status=status, reinitializations=reinits)
        self._frames.clear()
        self._pub_diag.publish(outputs.diagnostics_msg(
            self.get_name(), health, self.get_clock().now().nanoseconds))

    # --- processing thread: observations -> tracker -> outputs ----------------------------

    def _work(self) -> None:
        while not self._stop.is_set():
            item = self._mailbox.take(timeout_s=0.2)
            if item is None:
                continue
            try:
                self._process(*item)
            except Exception:  # noqa: BLE001 - the thread must outlive one bad set
                if self._stop.is_set() or not rclpy.ok(context=self.context):
                    return
                self.get_logger().error(f'tracking a set failed:\n{traceback.format_exc()}',
                                        throttle_duration_sec=THROTTLE_S)

    def _process(self, synced: SyncedSet, received_s: float) -> None:
        observations = frame_observations(synced.stamp_ns, synced.items, self._cameras)
        restarts = self._session.restarts
        try:
            result = self._session.step(observations)
        except HandTrackerError as err:
            self._log_throttled('initialize', 'warning', f'cannot find the hand yet: {err}')
            return
        processing_s = time.monotonic() - received_s
        self._publish(result, synced, processing_s)
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

    def _publish(self, result: TrackResult, synced: SyncedSet, processing_s: float) -> None:
        frame_id = self.config.world_frame
        if result.status == TrackStatus.TRACKING:
            self._pub_joints.publish(outputs.joint_state_msg(result, frame_id))
        faces = self._model.faces if self.config.publish_mesh else None
        self._pub_markers.publish(outputs.marker_array_msg(result, faces, frame_id))
        self._pub_state.publish(outputs.hand_state_msg(result, self._model, frame_id,
                                                       processing_s))
        if self._pub_overlay:
            self._publish_overlays(result, synced)

    def _publish_overlays(self, result: TrackResult, synced: SyncedSet) -> None:
        views = self._tracker.views(result.posed)
        for camera, view in zip(self._cameras, views):
            frame = synced.items[camera.name]
            base = frame.mask if self.config.overlay_source == 'mask' else frame.edges
            uv, _ = camera.project(result.posed.keypoints_m)
            rgb = draw_overlay(np.where(base, np.uint8(255), np.uint8(0)), view.raster.mask, uv)
            header = outputs.header_at(synced.stamp_ns,
                                       camera.name + self.config.optical_frame_suffix)
            self._pub_overlay[camera.name].publish(image_msg(rgb, header))

    def destroy_node(self) -> None:
        """Stop the processing thread, then the node."""
        self._stop.set()
        if self._worker is not None:
            self._worker.join(timeout=10.0)
        super().destroy_node()


def main(args: Sequence[str] | None = None) -> int:
    """Console entry point (`ros2 run hand_tracker_ros tracker`)."""
    return run_node('tracker', DESCRIPTION, TrackerNodeConfig, TrackerNode, args)


if __name__ == '__main__':
    raise SystemExit(main())
