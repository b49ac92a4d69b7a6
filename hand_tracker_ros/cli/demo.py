"""`hand-tracker demo`: the product end to end on synthetic data.

1. Makes a synthetic 4-camera bag with ground truth (unless ``--bag`` is given).
2. Starts the graph as a user would (the composed tracker process hosting features and
   salient_points, and a recorder), shows from the ROS graph that all five nodes are up, and
   plays the bag through it; the tracker's outputs are recorded.
3. Prints the share of sets estimated and tracked, estimates per second, the latency and the
   accuracy, and where it wrote the output bag, the error plot and the overlay images.

Two settings. The default is the product as it is used: random hand motion played at 1.0x
(real time), the tracker finding the hand by itself. ``--slow`` plays a grasp at 0.1x from
the ground-truth first pose, so that every set is tracked on a 2-core machine: it shows the
accuracy without the live budget. Either way the demo exits 1 when fewer than
``--min-tracked`` (default 90 %) of the sets were tracked.
"""
from __future__ import annotations

import argparse
import shutil
from pathlib import Path
from typing import Any

import numpy as np

from hand_tracker_ros.errors import HandTrackerError
from hand_tracker_ros.evaluation.figures import error_plot, overlay_grid
from hand_tracker_ros.evaluation.replay import live_summary, replay
from hand_tracker_ros.graph_nodes import NODES as GRAPH
from hand_tracker_ros.launcher import GRAPH_MODES
from hand_tracker_ros.pipeline.frames import load_rig
from hand_tracker_ros.status import TrackStatus
from hand_tracker_ros.synthetic.sequence import SynthConfig, SyntheticSequence
from hand_tracker_ros.synthetic.writer import write_sequence


def add_parser(sub: Any) -> None:
    """Register the verb."""
    parser = sub.add_parser('demo', help='run the demo on built-in data', description=__doc__)
    parser.add_argument('--bag', help='a synthetic bag to use instead of making one')
    parser.add_argument('--out', default='out/demo', help='output directory (replaced)')
    parser.add_argument('--slow', action='store_true',
                        help='a grasp at 0.1x from the ground-truth pose instead of random '
                             'motion at 1.0x with automatic initialization (the product as '
                             'used)')
    parser.add_argument('--frames', type=int, help='frames of the made bag (default 150; '
                        'slow 45)')
    parser.add_argument('--seed', type=int, help="seed of the made bag (default: synth's)")
    parser.add_argument('--rate', type=float,
                        help='playback rate (default 1.0; slow 0.1)')
    parser.add_argument('--mode', choices=GRAPH_MODES, default='composed',
                        help='composed (default) or distributed tracking nodes')
    parser.add_argument('--min-tracked', type=float, default=0.9, metavar='SHARE',
                        help='fail below this share of tracked sets (default 0.9)')
    parser.set_defaults(run=run)


def _show_graph() -> None:
    from hand_tracker_ros.ros_io.graph import wait_for_nodes  # rclpy only when needed

    seen = wait_for_nodes(GRAPH, timeout_s=60.0)
    print('nodes up in the ROS graph: ' + ', '.join(f'/{n}' for n in GRAPH if n in seen))
    if seen != set(GRAPH):
        msg = f'nodes missing from the ROS graph: {sorted(set(GRAPH) - seen)}'
        raise HandTrackerError(msg)


def run(args: argparse.Namespace) -> int:
    """Make data if needed, replay it through the graph, report."""
    out = Path(args.out)
    if out.exists():
        shutil.rmtree(out)
    if args.bag:
        bag = Path(args.bag)
    else:
        config = SynthConfig(motion='grasp' if args.slow else 'random',
                             n_frames=args.frames or (45 if args.slow else 150),
                             n_cameras=4, **({} if args.seed is None else {'seed': args.seed}))
        bag = write_sequence(SyntheticSequence(config), out / 'synthetic')
        print(f'made a synthetic 4-camera bag: {bag}')
    rate = args.rate or (0.1 if args.slow else 1.0)
    outcome = replay(bag, out, rate=rate, on_started=_show_graph,
                     init_from_ground_truth=args.slow, mode=args.mode)
    s = outcome.scores
    print(live_summary(outcome))
    if s is None:
        print('demo: FAILED (no estimate matched the ground truth)')
        return 1
    print(f'accuracy vs ground truth: mean 3D joint error {s.joint_mean_mm:.2f} mm, median '
          f'{s.joint_median_mm:.2f}, max {s.joint_max_mm:.2f}; fingertips '
          f'{s.fingertip_mean_mm:.2f} mm; 2D reprojection {s.reprojection_px:.2f} px; '
          f'interpenetration <= {s.max_interpenetration_mm:.2f} mm; {s.failures} failures '
          '(the sets marked LOST included)')
    stamps = sorted(outcome.states)
    scored = np.asarray(outcome.scored_stamps_ns, dtype=np.int64)
    lost = [outcome.states[s].status == TrackStatus.LOST for s in outcome.scored_stamps_ns]
    error_plot((scored - stamps[0]) / 1e9, outcome.errors_mm, np.array(lost, dtype=bool),
               out / 'error.png', f'{bag}: mean 3D joint error per estimated set')
    picks = [stamps[i] for i in (0, len(stamps) // 2, -1)] if stamps else []
    overlay_grid(bag, load_rig(bag), outcome.states, picks, out / 'overlays.png',
                 dict(zip(outcome.scored_stamps_ns, outcome.errors_mm.tolist())))
    print(f'output bag: {outcome.recorded_bag}\nerror plot: {out / "error.png"}\n'
          f'overlay images (rows: frames, columns: cameras): {out / "overlays.png"}')
    if outcome.tracked_share < args.min_tracked:
        print(f'demo: FAILED: {100 * outcome.tracked_share:.0f} % of the sets tracked, below '
              f'{100 * args.min_tracked:.0f} %')
        return 1
    return 0
