"""TrackResult -> JointState, HandState, MarkerArray and DiagnosticArray messages.

Every output carries ``header.stamp`` = the input set's stamp and ``header.frame_id`` = the
world frame parameter. Markers follow a stable scheme, one list marker per kind (never one
marker per point), all with ``id`` 0 in their namespace:

============  =============  ===========================================================
ns            type           content
============  =============  ===========================================================
skeleton      LINE_LIST      the 20 bones between the 21 keypoints
joints        SPHERE_LIST    the 21 keypoints
fingertips    SPHERE_LIST    the 5 fingertip surface points (thumb .. pinky)
mesh          TRIANGLE_LIST  the posed mesh (only with ``publish_mesh``)
============  =============  ===========================================================

When a frame is not TRACKING the array holds one ``DELETEALL`` marker instead.
"""
from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np
from builtin_interfaces.msg import Time
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
from geometry_msgs.msg import Point
from hand_tracker_msgs.msg import HandState
from sensor_msgs.msg import JointState
from std_msgs.msg import ColorRGBA, Header
from visualization_msgs.msg import Marker, MarkerArray

from hand_tracker_ros._typing import FloatArray
from hand_tracker_ros.core.result import TrackResult
from hand_tracker_ros.model.hand import HandModel
from hand_tracker_ros.model.layout import PARAM_NAMES
from hand_tracker_ros.model.shape import SHAPE_NAMES
from hand_tracker_ros.model.skeleton import KEYPOINT_NAMES
from hand_tracker_ros.status import TrackStatus
from hand_tracker_ros.sync.approximate import SyncStats
from hand_tracker_ros.tracking.overlay import KEYPOINT_PARENTS

BONE_WIDTH_M = 0.003
JOINT_DIAMETER_M = 0.008
FINGERTIP_DIAMETER_M = 0.012


def header_at(stamp_ns: int, frame_id: str) -> Header:
    """A Header with ``stamp_ns`` (int ns) and ``frame_id``."""
    sec, nanosec = divmod(int(stamp_ns), 10**9)
    return Header(stamp=Time(sec=sec, nanosec=nanosec), frame_id=frame_id)


def _points(xyz_m: FloatArray) -> list[Point]:
    return [Point(x=float(x), y=float(y), z=float(z)) for x, y, z in xyz_m]


def joint_state_msg(result: TrackResult, frame_id: str) -> JointState:
    """The estimate as a JointState named as the URDF joints (PARAM_NAMES; m and rad)."""
    return JointState(header=header_at(result.stamp_ns, frame_id), name=list(PARAM_NAMES),
                      position=[float(v) for v in result.theta])


def hand_state_msg(result: TrackResult, model: HandModel, frame_id: str,
                   processing_time_s: float) -> HandState:
    """Every field of HandState from one result (also for LOST: the rejected estimate)."""
    energy_names = sorted(result.energy_costs)
    return HandState(
        header=header_at(result.stamp_ns, frame_id), status=int(result.status),
        confidence=float(result.confidence), joint_names=list(PARAM_NAMES), joint_positions=[float(v) for v in result.theta],
        keypoint_names=list(KEYPOINT_NAMES), keypoints=_points(result.posed.keypoints_m),
        fingertips=_points(result.posed.fingertips_m), shape_names=list(SHAPE_NAMES),
        shape_parameters=[float(v) for v in model.shape.to_vector()],
        energy_names=energy_names,
        energy_costs=[float(result.energy_costs[n]) for n in energy_names],
        iterations=int(result.iterations), processing_time=float(processing_time_s))


def _marker(header: Header, ns: str, kind: int, scale_m: float,
            rgba: tuple[float, float, float, float]) -> Marker:
    marker = Marker(header=header, ns=ns, id=0, type=kind, action=Marker.ADD)
    marker.pose.orientation.w = 1.0
    marker.scale.x = marker.scale.y = marker.scale.z = scale_m
    marker.color = ColorRGBA(r=rgba[0], g=rgba[1], b=rgba[2], a=rgba[3])
    return marker


def marker_array_msg(result: TrackResult, faces: np.ndarray | None, frame_id: str
                     ) -> MarkerArray:
    """Skeleton, joints, fingertips (and the mesh if ``faces`` (F, 3) is given); DELETEALL
    when the result is not TRACKING."""
    header = header_at(result.stamp_ns, frame_id)
    if result.status != TrackStatus.TRACKING:
        return MarkerArray(markers=[Marker(header=header, action=Marker.DELETEALL)])
    keypoints = result.posed.keypoints_m
    skeleton = _marker(header, 'skeleton', Marker.LINE_LIST, BONE_WIDTH_M, (0.9, 0.9, 0.9, 1.0))
    pairs = [(p, k) for k, p in enumerate(KEYPOINT_PARENTS) if p >= 0]
    skeleton.points = _points(keypoints[np.ravel(pairs)])
    joints = _marker(header, 'joints', Marker.SPHERE_LIST, JOINT_DIAMETER_M,
                     (0.9, 0.2, 0.2, 1.0))
    joints.points = _points(keypoints)
    tips = _marker(header, 'fingertips', Marker.SPHERE_LIST, FINGERTIP_DIAMETER_M,
                   (0.2, 0.8, 0.2, 1.0))
    tips.points = _points(result.posed.fingertips_m)
    markers = [skeleton, joints, tips]
    if faces is not None:
        mesh = _marker(header, 'mesh', Marker.TRIANGLE_LIST, 1.0, (0.95, 0.75, 0.6, 0.6))
        mesh.points = _points(result.posed.vertices_m[np.ravel(faces)])
        markers.append(mesh)
    return MarkerArray(markers=markers)


@dataclass(frozen=True)
class TrackerHealth:
    """What the tracker node reports on /diagnostics for one period.

    Attributes
    ----------
    period_s : float
        Length of the period (s).
    frames : Mapping[str, int]
        Per camera: frames assembled in the period.
    camera_problems : Mapping[str, str]
        Per camera: '' or the current problem (no camera_info, size mismatch, silent).
    assembler_counts : Mapping[str, Mapping[str, int]]
        Per camera: cumulative complete / partial / dropped / late frame counts.
    sync : SyncStats
        Cumulative synchronizer counters.
    processed, skipped : int
        Sets tracked in the period; sets replaced by a newer one before processing (total).
    latencies_s : sequence of float
        Input stamp -> publish delay of each set published in the period (s), on the node's
        clock (meaningful for live cameras or sim time; not for re-stamped old data).
    processing_s : sequence of float
        Wall time from a set's completion to its publication, per set of the period (s).
    iterations : sequence of int
        LM iterations of each set tracked in the period.
    confidence : sequence of float
        Confidence (0-1) of each set tracked in the period.
    status : TrackStatus or None
        Status of the last result (None: nothing tracked yet).
    reinitializations : int
        Starts after lost frames (initial pose or search; total).
    """

    period_s: float
    frames: Mapping[str, int]
    camera_problems: Mapping[str, str]
    assembler_counts: Mapping[str, Mapping[str, int]]
    sync: SyncStats
    processed: int
    skipped: int
    latencies_s: Sequence[float]
    processing_s: Sequence[float]
    iterations: Sequence[int]
    confidence: Sequence[float]
    status: TrackStatus | None
    reinitializations: int


def _status(name: str, level: bytes, message: str, values: Mapping[str, object]
            ) -> DiagnosticStatus:
    return DiagnosticStatus(level=level, name=name, message=message, hardware_id=name,
                            values=[KeyValue(key=k, value=str(v)) for k, v in values.items()])


def _camera_status(node: str, camera: str, health: TrackerHealth) -> DiagnosticStatus:
    problem = health.camera_problems.get(camera, '')
    rate = health.frames.get(camera, 0) / health.period_s
    sync = health.sync.inputs.get(camera)
    values = {'input_rate_hz': f'{rate:.2f}', **health.assembler_counts.get(camera, {})}
    if sync is not None:
        values.update(received=sync.received, dropped=sync.dropped, late=sync.late,
                      unmatched=sync.unmatched, overflow=sync.overflow)
    level = DiagnosticStatus.WARN if problem else DiagnosticStatus.OK
    return _status(f'{node}: {camera} input', level, problem or 'ok', values)


def _tracking_status(node: str, health: TrackerHealth) -> DiagnosticStatus:
    latency = np.asarray(health.latencies_s, np.float64) * 1e3
    processing = np.asarray(health.processing_s, np.float64) * 1e3
    iterations = np.asarray(health.iterations, np.float64)
    confidence = np.asarray(health.confidence, np.float64)
    status = 'no input yet' if health.status is None else health.status.name.lower()
    values = {
        'status': status, 'processed_sets': health.processed, 'skipped_sets': health.skipped,
        'emitted_sets': health.sync.emitted, 'unmatched_sets': health.sync.unmatched_sets,
        'sync_resets': health.sync.resets, 'reinitializations': health.reinitializations,
        'latency_mean_ms': f'{latency.mean():.1f}' if latency.size else 'n/a',
        'latency_max_ms': f'{latency.max():.1f}' if latency.size else 'n/a',
        'processing_mean_ms': f'{processing.mean():.1f}' if processing.size else 'n/a',
        'lm_iterations_mean': f'{iterations.mean():.1f}' if iterations.size else 'n/a',
        'confidence_last': f'{confidence[-1]:.3f}' if confidence.size else 'n/a',
        'confidence_min': f'{confidence.min():.3f}' if confidence.size else 'n/a',
    }
    level = DiagnosticStatus.OK if health.status == TrackStatus.TRACKING else \
        DiagnosticStatus.WARN
    return _status(f'{node}: tracking', level, status, values)


def diagnostics_msg(node: str, health: TrackerHealth, stamp_ns: int) -> DiagnosticArray:
    """One status per camera (input) and one for tracking."""
    statuses = [_camera_status(node, c, health) for c in health.frames]
    statuses.append(_tracking_status(node, health))
    return DiagnosticArray(header=header_at(stamp_ns, ''), status=statuses)
