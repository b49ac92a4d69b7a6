"""Bag-replay evaluation: the live graph scored like the offline path.

1. Start the tracking graph (``mode`` ``composed``: one ``tracker`` process that also hosts
   ``features`` and ``salient_points``; ``distributed``: the three as processes) on sim time
   with the bag's rig and cameras, and a ``recorder`` of the tracker's outputs.
2. Play the bag with the ``player`` (``/clock`` once per bag time) at ``rate``, after every
   node has subscribed. Real time is ``rate = 1``; on a machine where one frame takes longer
   than a frame period the tracker skips sets (it always takes the newest), so for a
   comparison with the offline path the bag is played slower (no dropped sets).
3. When the player exits, give the graph ``drain_s`` to finish (less once the estimate of
   the bag's last set is out: :func:`_drain`), stop every process (SIGINT), and score the
   recorded ``HandState`` messages against the bag's ground truth by stamp with the offline
   metrics (:mod:`.metrics`).

The latency of a set is measured in the recorder, on the wall clock: from its receipt of the
played ground-truth ``HandState`` of the set (published with the set's images) to its receipt
of the tracker's ``HandState``. Sim time cannot measure it: it advances only with the
player's ``/clock``, once per frame, so it rounded every latency down to whole frame periods
(33 ms at 30 Hz), and ticking ``/clock`` at 200 Hz in between cost the composed tracker
process three quarters of its estimates (three sim-time nodes handle every tick).
"""
from __future__ import annotations

import logging
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from hand_tracker_ros._typing import FloatArray
from hand_tracker_ros.ament import share_file
from hand_tracker_ros.bags.convert import HandStateValues, hand_state_from_msg
from hand_tracker_ros.bags.reader import BagReader
from hand_tracker_ros.errors import HandTrackerError
from hand_tracker_ros.evaluation.metrics import (
    SequenceScores,
    deepest_interpenetration_m,
    joint_errors_mm,
    score_sequence,
)
from hand_tracker_ros.geometry.rig import CameraRig
from hand_tracker_ros.launcher import (
    TRACKING_PROCESSES,
    ProcessGroup,
    ProcessSpec,
    player_waits_for_image_consumers,
    ros_list,
    tracker_mode_args,
)
from hand_tracker_ros.model.hand import HandModel
from hand_tracker_ros.pipeline.frames import ground_truth, load_rig
from hand_tracker_ros.topics import GT_STATE, JOINT_STATES, STATE

if TYPE_CHECKING:
    from hand_tracker_ros.ros_io.graph import StampWatch

LOG = logging.getLogger(__name__)
OUTPUT_TOPICS = (JOINT_STATES.absolute, STATE.absolute)
# The recorder also records the played ground truth: its receive times give the latencies.
RECORDED_TOPICS = (*OUTPUT_TOPICS, GT_STATE.absolute)
# After the last set's HandState was heard: time for the recorder to hear it too, s.
RECORDER_GRACE_S = 1.0


@dataclass(frozen=True)
class ReplayOutcome:
    """What the live graph produced for one bag."""

    recorded_bag: Path
    input_sets: int          # frame sets in the bag (ground-truth stamps)
    joint_states: int        # JointState messages the tracker published (TRACKING sets)
    scores: SequenceScores | None
    states: dict[int, HandStateValues]   # recorded estimates by stamp (ns)
    errors_mm: FloatArray    # per scored frame, mean 3D joint error, in stamp order
    latencies_ms: FloatArray  # per HandState: input stamp to the recorder, wall-clock ms
    duration_s: float        # the bag's span of input sets, wall-clock s at the played rate
    scored_stamps_ns: tuple[int, ...] = ()   # the stamps of ``errors_mm``

    @property
    def estimates_per_s(self) -> float:
        """HandState messages (every processed set) per wall-clock second of playback."""
        return len(self.states) / self.duration_s if self.duration_s > 0 else 0.0

    @property
    def tracked_share(self) -> float:
        """Share of the input sets with a JointState (tracked, not LOST)."""
        return self.joint_states / self.input_sets if self.input_sets else 0.0


def graph_specs(bag: Path, rig_path: Path, cameras: list[str], out: Path, rate: float,
                initial_pose: np.ndarray | None, mode: str = 'composed'
                ) -> tuple[list[ProcessSpec], ProcessSpec]:
    """The node processes and the player process of one replay."""
    sim = ('-p', 'use_sim_time:=true')
    cams = ('-p', f'cameras:={ros_list(cameras)}')
    # The parameter file first: later -p values override it.
    tracker_args = ['--params-file', str(share_file('config/tracker.yaml')), *sim, *cams,
                    '-p', f'rig_file:={rig_path}', *tracker_mode_args(mode)]
    if initial_pose is not None:
        pose = ros_list(repr(float(v)) for v in initial_pose)
        tracker_args += ['-p', f'initial_pose:={pose}', '-p', 'initialization:=initial_pose']
    args = {'features': (*sim, *cams), 'salient_points': (*sim, *cams),
            'tracker': tuple(tracker_args)}
    nodes = [ProcessSpec(name, name, args[name]) for name in TRACKING_PROCESSES[mode]]
    # The recorder keeps the wall clock (module docstring: latency).
    nodes.append(ProcessSpec('recorder', 'recorder', (
        '-p', f'output:={out}', '-p', f'topics:={ros_list(RECORDED_TOPICS)}')))
    player = ProcessSpec('player', 'player', (
        '-p', f'bag:={bag}', '-p', f'playback.rate:={rate}', '-p', 'publish_clock:=true',
        *player_waits_for_image_consumers(cameras, mode)))
    return nodes, player


def replay(bag: str | Path, out_dir: str | Path, *, rate: float = 0.1,
           rig_path: str | Path | None = None, init_from_ground_truth: bool = True,
           startup_s: float = 120.0, drain_s: float = 5.0, timeout_s: float = 3600.0,
           on_started: Callable[[], None] | None = None, mode: str = 'composed'
           ) -> ReplayOutcome:
    """Play ``bag`` through the live graph (``mode``), record the outputs and score them.

    The player starts once the graph is connected: the tracker subscribes to every camera's
    features and the recorder to the outputs (at most ``startup_s``; a loaded machine can need
    more than 8 s to start the tracker, and the frames sent before it listens are lost).
    ``on_started`` is called once the graph and the player run (e.g. to show the graph).
    """
    bag, out_dir = Path(bag), Path(out_dir)
    rig_file = Path(rig_path) if rig_path else bag.parent / 'rig.yaml'
    rig = load_rig(bag, rig_file)
    truth = ground_truth(bag)
    pose = (np.asarray(truth[min(truth)].joint_positions) if init_from_ground_truth and truth
            else None)
    out_dir.mkdir(parents=True, exist_ok=True)
    recorded = out_dir / 'recorded'
    if recorded.exists():
        msg = f'{recorded} exists: choose another output directory'
        raise HandTrackerError(msg)
    nodes, player = graph_specs(bag, rig_file, list(rig.names), recorded, rate, pose, mode)
    graph = ProcessGroup(nodes)
    graph.start()
    try:
        # rclpy only here
        from hand_tracker_ros.ros_io.graph import StampWatch, wait_for_tracking_graph
        wait_for_tracking_graph(rig.names, OUTPUT_TOPICS, timeout_s=startup_s, mode=mode)
        with StampWatch(STATE.absolute, STATE.msgtype) as estimates:
            playback = ProcessGroup([player])
            playback.start()
            try:
                if on_started is not None:
                    on_started()
                if playback.wait_any(timeout_s) is None:
                    msg = f'player did not finish {bag} within {timeout_s:.0f} s'
                    raise HandTrackerError(msg)
            finally:
                playback.stop()
            _drain(estimates, max(truth) if truth else None, drain_s)
    finally:
        codes = graph.stop()
    LOG.info('graph exit codes: %s', codes)
    return score_recording(recorded, truth, rig, rate=rate,
                           skip_first=init_from_ground_truth)


def _drain(estimates: StampWatch, last_stamp_ns: int | None, drain_s: float) -> None:
    """Give the graph ``drain_s`` (s) to finish the sets in flight after the bag ended, or
    less: once the estimate of the bag's last set (``last_stamp_ns``) was published, the
    tracker has nothing left (it always takes the newest set), and the recorder gets
    ``RECORDER_GRACE_S`` to hear it too (it also takes what is queued when it is stopped)."""
    if last_stamp_ns is not None and estimates.wait_for(last_stamp_ns, drain_s):
        time.sleep(min(RECORDER_GRACE_S, drain_s))
    elif last_stamp_ns is None:
        time.sleep(drain_s)


def score_recording(recorded: Path, truth: dict[int, HandStateValues], rig: CameraRig, *,
                    rate: float = 1.0, skip_first: bool = True) -> ReplayOutcome:
    """Score the ``/hand/state`` messages of the bag ``recorded`` against ``truth`` (by
    stamp); ``skip_first``: the first set is where the tracker was put (not scored). The
    latencies pair each estimate with the recorded ground truth of its set (module
    docstring); sets without one have none."""
    with BagReader(recorded) as reader:
        topics = reader.topics
        # By header stamp (the input set's), never by receive time: an estimate arrives
        # after its set, one or more frames late when the tracker is slow.
        states: dict[int, HandStateValues] = {}
        received: dict[int, int] = {}
        played: dict[int, int] = {}
        wanted = [t for t in (STATE.absolute, GT_STATE.absolute) if t in topics]
        for topic, _, recv_ns, msg in reader.decoded(topics=wanted) if wanted else ():
            state = hand_state_from_msg(msg)
            if topic == STATE.absolute:
                states[state.stamp_ns], received[state.stamp_ns] = state, recv_ns
            else:
                played.setdefault(state.stamp_ns, recv_ns)
        n_joint_states = (topics[JOINT_STATES.absolute].count
                          if JOINT_STATES.absolute in topics else 0)
    latencies = np.array([(recv - played[stamp]) / 1e6 for stamp, recv in received.items()
                          if stamp in played])
    # n sets, one period each: the span of their stamps plus one period, at the played rate.
    span_s = (max(truth) - min(truth)) / 1e9 if len(truth) > 1 else 0.0
    duration_s = span_s * len(truth) / max(len(truth) - 1, 1) / rate
    common = sorted(set(states) & set(truth)
                    - ({min(truth, default=None)} if skip_first else set()))
    if not common:
        return ReplayOutcome(recorded, len(truth), n_joint_states, None, states, np.zeros(0),
                             latencies, duration_s)
    estimate = np.array([states[s].keypoints_m for s in common])
    depth = [deepest_interpenetration_m(HandModel.build(states[s].shape).pose(
        states[s].joint_positions, jacobian=False)) for s in common]
    true = np.array([truth[s].keypoints_m for s in common])
    scores = score_sequence(estimate, true, [states[s].status == 2 for s in common],
                            rig.cameras, depth, [states[s].processing_time_s for s in common])
    return ReplayOutcome(recorded, len(truth), n_joint_states, scores, states,
                         joint_errors_mm(estimate, true), latencies, duration_s, tuple(common))


def live_summary(outcome: ReplayOutcome) -> str:
    """One paragraph: sets estimated and tracked, estimates per second, latency."""
    latency = outcome.latencies_ms
    # The latency spans play to record (module docstring); the tracker's own time from the
    # complete set to its outputs (HandState.processing_time) is printed beside it.
    processing = [1e3 * s.processing_time_s for s in outcome.states.values()]
    timing = (f'latency (input stamp to recorded estimate) median {np.median(latency):.0f} ms, '
              f'p95 {np.percentile(latency, 95):.0f} ms; in the tracker median '
              f'{np.median(processing):.0f} ms' if latency.size else 'no latency')
    return (f'recorded {outcome.recorded_bag}: {len(outcome.states)} of {outcome.input_sets} '
            f'input sets estimated ({100.0 * len(outcome.states) / max(outcome.input_sets, 1):.0f}'
            f' %), {outcome.joint_states} tracked ({100.0 * outcome.tracked_share:.0f} %; '
            f'{len(outcome.states) - outcome.joint_states} LOST), '
            f'{outcome.estimates_per_s:.1f} estimates/s; {timing}')
