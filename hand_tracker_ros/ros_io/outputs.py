"""The tracker's health -> ``/diagnostics`` (``diagnostic_msgs/DiagnosticArray``).

One status per camera input (rate, synchronizer and frame-assembly counters, the current
problem) and one for tracking (status, sets processed and skipped, latency, LM iterations,
confidence). The estimates themselves are converted by :mod:`.estimates`.
"""
from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
from std_msgs.msg import Header

from hand_tracker_ros.ros_io.estimates import header
from hand_tracker_ros.ros_io.message_kit import RclpyKit
from hand_tracker_ros.status import TrackStatus
from hand_tracker_ros.sync.approximate import SyncStats


def header_at(stamp_ns: int, frame_id: str) -> Header:
    """An rclpy Header with ``stamp_ns`` (int ns) and ``frame_id``."""
    return header(RclpyKit(), stamp_ns, frame_id)


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
