"""The `tracker` node: synchronized multi-camera hand tracking.

Topics (relative names, so namespaces and remaps work)
------------------------------------------------------
Subscribed per camera ``<cam>`` of ``cameras`` (sensor-data QoS, depth ``queue_depth``):
with ``inputs:=images`` (default, the *composed* graph, :mod:`.composed`: the process also
hosts the features and salient_points nodes, data in memory) ``<cam>/<image_topic>``
(``image_transport`` raw or compressed); with ``inputs:=features`` (the *distributed* graph)
``<cam>/edges``, ``<cam>/edge_orientation``, ``<cam>/mask``, ``<cam>/flow`` and
``<cam>/salient_points`` from features and salient_points processes; and
``<cam>/camera_info``. Published (:mod:`hand_tracker_ros.topics`): ``hand/joint_states``
(JointState, only while TRACKING), ``hand/state`` (HandState, every processed set, LOST
included), ``hand/markers`` (MarkerArray, DELETEALL when not tracking), ``/tf`` (every URDF
joint, only while TRACKING; ``publish_tf``), ``hand/robot_description`` (the URDF rooted at
``world_frame``, transient local; sent again when the hand's scale is refined),
``/diagnostics`` (every ``diagnostics_period_s``)
and, with ``publish_overlay``, ``<cam>/overlay`` (rgb8, at the working resolution: images
wider than ``working_width_px`` are observed and fitted scaled down,
:mod:`hand_tracker_ros.vision.resolution`). The estimates are converted by
:class:`hand_tracker_ros.ros_io.estimates.EstimateEncoder`, the one conversion the offline
estimates bags use too. Output stamps are the input set's stamp, frame ids ``world_frame``
(overlays: ``<cam>`` + ``optical_frame_suffix``).

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
caps each main fit (:meth:`.TrackingSession.step`; 33 ms for the first set); played slowly,
every set gets every round. The search for the hand (at the start with ``initialization:
observations``, and after losses) is spread over the sets
(:mod:`hand_tracker_ros.tracking.acquisition`), LOST until found.

Tracking policy: the node drives a :class:`hand_tracker_ros.tracking.session.TrackingSession`,
the same one the offline pipeline uses (start, recovery, LOST, confidence; ``session.*``).
``initialization``: ``observations`` (default) searches the hand in the first complete set,
``initial_pose`` starts at that pose; after ``session.failure.reinit_after`` consecutive LOST
frames the node searches again, or with ``restart_at_initial_pose`` resets to the pose. The
camera intrinsics and extrinsics come from ``rig_file``; a camera_info whose size
contradicts the rig drops that camera's frames with a throttled error; a missing camera_info
is only reported (the rig is used; the policy is
:class:`hand_tracker_ros.sync.input_health.InputHealth`). Without a ``rig_file`` the node
refuses to start and says so. The hand's size comes from ``shape_file`` (the default hand
when empty), and the session follows its global scale while tracking (``session.scale``,
:mod:`hand_tracker_ros.tracking.scale`); HandState's ``shape_parameters``, the URDF, TF and
the markers follow the shape in use.
"""
from __future__ import annotations

import threading
import time
import traceback
from collections.abc import Callable, Hashable
from functools import partial
from types import MappingProxyType
from typing import Any

import numpy as np
import rclpy
from diagnostic_msgs.msg import DiagnosticArray
from hand_tracker_msgs.msg import SalientPoints
from rclpy.clock import Clock, ClockType
from rclpy.node import Node
from rclpy.publisher import Publisher
from rclpy.qos import DurabilityPolicy, QoSProfile
from sensor_msgs.msg import CameraInfo, CompressedImage, Image

from hand_tracker_ros import topics
from hand_tracker_ros.bags.convert import stamp_ns_of
from hand_tracker_ros.core.observations import FrameObservations
from hand_tracker_ros.core.result import TrackResult
from hand_tracker_ros.errors import ConfigError, HandTrackerError
from hand_tracker_ros.geometry.rig import CameraRig
from hand_tracker_ros.model.hand import HandModel
from hand_tracker_ros.model.layout import P
from hand_tracker_ros.model.shape_file import shape_or_default
from hand_tracker_ros.node_config import TrackerNodeConfig
from hand_tracker_ros.pipeline.live import LivePipeline
from hand_tracker_ros.pipeline.warmup import warm_up
from hand_tracker_ros.ros_io import outputs
from hand_tracker_ros.ros_io.estimates import EstimateEncoder
from hand_tracker_ros.ros_io.images import (
    image_input,
    image_msg,
    intrinsics_from_info,
    sensor_qos,
)
from hand_tracker_ros.ros_io.logging_bridge import bridge_core_logging
from hand_tracker_ros.ros_io.message_kit import RclpyKit, message_class
from hand_tracker_ros.ros_io.observations import (
    PARTS,
    FrameAssembler,
    frame_observations,
    part_value,
)
from hand_tracker_ros.ros_io.params import declare_config
from hand_tracker_ros.ros_io.plans import plan_msg
from hand_tracker_ros.status import TrackStatus
from hand_tracker_ros.sync.approximate import ApproximateTimeSync, SyncConfig, SyncedSet
from hand_tracker_ros.sync.input_health import InputHealth
from hand_tracker_ros.tracking.attention import Attention
from hand_tracker_ros.tracking.overlay import observation_overlays
from hand_tracker_ros.tracking.session import TrackingSession
from hand_tracker_ros.tracking.tracker import HandTracker
from hand_tracker_ros.vision.resolution import working_camera

DESCRIPTION = 'Synchronized multi-camera hand tracking (collision-aware Levenberg-Marquardt).'
THROTTLE_S = 5.0
FLUSH_PERIOD_S = 0.01
FIRST_PERIOD_S = 1.0 / 30.0     # the set period assumed until two sets were offered


def _load_rig(config: TrackerNodeConfig) -> CameraRig:
    rig = CameraRig.from_yaml(config.rig_file)
    missing = [c for c in config.cameras if c not in rig.names]
    if missing:
        msg = f'cameras {missing} are not in the rig {config.rig_file} ({list(rig.names)})'
        raise ConfigError(msg)
    if len(config.initial_pose) != P:
        msg = f'`initial_pose` must have {P} numbers, got {len(config.initial_pose)}'
        raise ConfigError(msg)
    if config.restart_at_initial_pose and config.initialization != 'initial_pose':
        msg = '`restart_at_initial_pose` needs `initialization: initial_pose`'
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
        # What the tracker fits, at the working resolution: the composed graph observes the
        # images scaled to it, the distributed features and salient_points nodes do the same.
        self.working_cameras = tuple(working_camera(c, self.config.working_width_px)
                                     for c in self.cameras)
        self._working_by_name = {c.name: c for c in self.working_cameras}
        self._model = HandModel.build(shape)
        initial = (np.asarray(self.config.initial_pose, np.float64)
                   if self.config.initialization == 'initial_pose' else None)
        self._tracker = HandTracker(self._model, self.working_cameras, self.config.tracking)
        self._session = TrackingSession(self._tracker, self.config.session,
                                        initial_pose=initial,
                                        search=not self.config.restart_at_initial_pose)
        self._init_state()
        self._create_outputs()
        if self.config.inputs == 'features':
            self.start(lambda synced: frame_observations(synced.stamp_ns, synced.items,
                                                         self.working_cameras))

    @property
    def session(self) -> TrackingSession:
        """The tracking session (its status steers the in-process detection)."""
        return self._session

    def start(self, observe: Callable[[SyncedSet], FrameObservations],
              observe_kind: Callable[[], Hashable] | None = None) -> None:
        """Warm up, then subscribe to the inputs and track: ``observe`` turns a synchronized
        set (feature frames, or image messages with ``inputs:=images``) into observations;
        ``observe_kind`` tells the kind of the next observation (:class:`LivePipeline`; a
        fit's kind is the session's state as it starts)."""
        if self.config.warm_up:
            self.get_logger().info(f'JIT kernels loaded in {warm_up(self._model):.1f} s')
        self._pipeline = LivePipeline(lambda synced: self._prepared(observe(synced)),
                                      self._track, self._on_error,
                                      observe_kind=observe_kind, fit_kind=self._fit_kind)
        try:
            self._create_inputs()
        except BaseException:
            # E.g. a SIGTERM during the warm-up shut the context down. The pipeline's
            # threads would keep this node, and so the process's DDS participant, alive
            # past the exit, leaving its shared-memory segment (35 MB with the shipped Fast
            # DDS profile) in /dev/shm.
            self._pipeline.close()
            self._pipeline = None
            raise
        self.get_logger().info(f'ready: tracking with cameras {list(self.config.cameras)} '
                               f'from {self.config.inputs}')

    def _fit_kind(self) -> tuple[TrackStatus | None, bool]:
        """The kind of the fit about to start: the session's status and whether it searches
        (a live search's fits take several times a tracking fit's)."""
        return self._session.status, self._session.acquiring

    def _prepared(self, observations: FrameObservations) -> FrameObservations:
        """``observations`` with the tracker's per-frame work done (on the observer thread)."""
        self._tracker.prepare(observations)
        return observations

    def _init_state(self) -> None:
        cfg = self.config
        self._sync = ApproximateTimeSync(cfg.cameras, SyncConfig(
            slop_ns=round(cfg.sync_slop_ms * 1e6), queue_size=cfg.sync_queue_size))
        self._assemblers = {c: FrameAssembler(c, cfg.optional_wait_ms / 1e3,
                                              cfg.max_pending_frames) for c in cfg.cameras}
        self._lock = threading.Lock()
        self._inputs = InputHealth(self.cameras)
        self._period = self._new_period()
        self._status: TrackStatus | None = None
        self._reinits = 0
        self._estimated = 0     # sets tracked and published since the start
        self._failed = 0        # sets an error dropped (observing or tracking them)
        self._logged: dict[str, float] = {}

    def _create_outputs(self) -> None:
        cfg = self.config
        self._encoder = EstimateEncoder(RclpyKit(), self._model, cfg.world_frame,
                                        cfg.publish_mesh)
        self._pubs: dict[topics.Topic, Publisher[Any]] = {
            t: self.create_publisher(message_class(t.msgtype), t.name, 10)
            for t in topics.ESTIMATES if cfg.publish_tf or t != topics.TF}
        latched = QoSProfile(depth=1, durability=DurabilityPolicy.TRANSIENT_LOCAL)
        description = topics.ROBOT_DESCRIPTION
        # The encoder sends it again when the session refines the hand's scale.
        self._pubs[description] = self.create_publisher(message_class(description.msgtype),
                                                        description.name, latched)
        self._pubs[description].publish(self._encoder.robot_description())
        self._pub_diag = self.create_publisher(DiagnosticArray, topics.DIAGNOSTICS.name, 10)
        self._pub_overlay = {c: self.create_publisher(Image, topics.overlay_topic(c), 2)
                             for c in cfg.cameras} if cfg.publish_overlay else {}
        # Distributed, the features and salient_points processes follow the tracker's plan.
        self._attention = (Attention(cfg.attention, self.working_cameras)
                           if cfg.inputs == 'features' else None)
        self._pub_plan: Publisher[Any] | None = (self.create_publisher(
            message_class(topics.OBSERVATION_PLAN.msgtype), topics.OBSERVATION_PLAN.name,
            QoSProfile(depth=1)) if self._attention is not None else None)
        # Wall-clock timers: frame waits and diagnostics must run even when sim time pauses.
        self._steady = Clock(clock_type=ClockType.STEADY_TIME)
        self.create_timer(cfg.diagnostics_period_s, self._diagnose, clock=self._steady)

    def _create_inputs(self) -> None:
        cfg = self.config
        sensor = sensor_qos(cfg.queue_depth)
        image_type, image_topic = image_input(cfg.image_transport, cfg.image_topic)
        for cam in cfg.cameras:
            if cfg.inputs == 'images':
                self.create_subscription(image_type, f'{cam}/{image_topic}',
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
        if self._inputs.accepts(camera):
            self._on_camera_frame(camera, stamp_ns_of(msg.header), msg)

    def _on_part(self, camera: str, part: str, msg: Image | SalientPoints) -> None:
        if not self._inputs.accepts(camera):
            return
        cam = self._working_by_name[camera]
        try:
            value = part_value(msg, camera, part, (cam.width, cam.height))
        except HandTrackerError as err:
            self._log_throttled(f'{camera}/{part}', 'error', f'dropping a message: {err}')
            return
        frame = self._assemblers[camera].add(part, stamp_ns_of(msg.header), value,
                                             time.monotonic())
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
        self._inputs.frame(camera, now)
        for synced in self._sync.add(camera, stamp_ns, item):
            assert self._pipeline is not None
            self._pipeline.offer(synced, now)

    def _on_info(self, camera: str, msg: CameraInfo) -> None:
        try:
            width, height, K, _, _ = intrinsics_from_info(msg, camera)
        except HandTrackerError as err:
            self._log_throttled(f'{camera}/camera_info', 'error',
                                f'{err}; using the rig intrinsics')
            return
        verdict = self._inputs.camera_info(camera, width, height, K, time.monotonic())
        if verdict is not None:
            self._log_throttled(f'{camera}/camera_info', *verdict)

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
        problems = self._inputs.problems(time.monotonic())
        for problem in set(problems.values()) - set(self._inputs.mismatches.values()):
            self._log_throttled(problem, 'warning', problem)
        with self._lock:
            period, self._period = self._period, self._new_period()
            status, reinits = self._status, self._reinits
        health = outputs.TrackerHealth(
            period_s=self.config.diagnostics_period_s,
            frames=self._inputs.take_frame_counts(),
            camera_problems=MappingProxyType(problems),
            assembler_counts={c: dict(a.counts) for c, a in self._assemblers.items()},
            sync=self._sync.stats, processed=period['processed'],
            skipped=self._pipeline.skipped if self._pipeline else 0,
            latencies_s=period['latencies_s'],
            processing_s=period['processing_s'], iterations=period['iterations'],
            confidence=period['confidence'], status=status, reinitializations=reinits)
        self._pub_diag.publish(outputs.diagnostics_msg(
            self.get_name(), health, self.get_clock().now().nanoseconds))

    def _on_error(self, err: BaseException) -> None:
        """A pipeline thread's failure on one set: logged (throttled), the node goes on."""
        if not rclpy.ok(context=self.context):
            return
        with self._lock:
            self._failed += 1
        if isinstance(err, HandTrackerError):
            self._log_throttled('observe', 'error', f'dropping a set: {err}')
            return
        text = ''.join(traceback.format_exception(err))
        self._log_throttled('track', 'error', f'tracking a set failed:\n{text}')

    def _track(self, synced: SyncedSet, observations: FrameObservations,
               received_s: float) -> None:
        restarts = self._session.restarts
        assert self._pipeline is not None
        if self._attention is not None and self._pub_plan is not None:
            # The next set's plan, made from the estimate before this fit, as the composed
            # graph's observer makes it, so that its observation overlaps this fit.
            self._pub_plan.publish(plan_msg(self._attention.plan(self._session),
                                            outputs.header_at(synced.stamp_ns, ''),
                                            self.config.cameras))
        # Every live set has a deadline (it also makes the session search a slice per set);
        # the first set, before any gap was measured, assumes 30 Hz.
        budget_s = (self.config.budget_ms / 1e3 or self._pipeline.period_s
                    or FIRST_PERIOD_S)
        try:
            result = self._session.step(observations, deadline_s=time.monotonic() + budget_s)
        except HandTrackerError as err:
            self._log_throttled('initialize', 'warning', f'cannot find the hand yet: {err}')
            with self._lock:
                self._failed += 1
            return
        processing_s = time.monotonic() - received_s
        self._publish(result, observations, processing_s)
        latency_s = (self.get_clock().now().nanoseconds - synced.stamp_ns) / 1e9
        restarted = self._session.restarts - restarts
        if restarted:
            self.get_logger().warning(f'hand lost: re-initializing from '
                                      f'{self._session.restarts_from}')
        elif result.status != TrackStatus.TRACKING:
            self._log_throttled('lost', 'warning', f'hand lost (confidence '
                                f'{result.confidence:.2f}, {self._session.lost_frames} frames '
                                'in a row)')
        with self._lock:
            self._period['processed'] += 1
            self._estimated += 1
            self._period['latencies_s'].append(latency_s)
            self._period['processing_s'].append(processing_s)
            self._period['iterations'].append(result.iterations)
            self._period['confidence'].append(result.confidence)
            self._status = result.status
            self._reinits += restarted

    def _publish(self, result: TrackResult, observations: FrameObservations,
                 processing_s: float) -> None:
        for topic, msg in self._encoder.messages(result, processing_s):
            if topic in self._pubs:
                self._pubs[topic].publish(msg)
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
            self.get_logger().info(self._input_summary())
        super().destroy_node()

    def _input_summary(self) -> str:
        """Where the input sets went, for the log at shutdown: each camera's frames, the sets
        synchronized, those a newer set replaced before the tracker took them (the tracker
        was busy: :mod:`hand_tracker_ros.pipeline.live`), those estimated and those an error
        dropped."""
        assert self._pipeline is not None
        return (f'input: {self._sync.stats.summary()}, {self._pipeline.skipped} replaced by '
                f'a newer one before the tracker was free, {self._estimated} estimated, '
                f'{self._failed} dropped by an error (logged above)')

