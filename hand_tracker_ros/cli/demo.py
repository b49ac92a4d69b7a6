"""`hand-tracker demo`: the main job end to end on synthetic data.

1. Makes a synthetic 4-camera bag with ground truth (unless ``--bag`` is given).
2. Starts the node graph (features, salient_points, tracker, recorder) and the player, shows
   from the ROS graph that all five nodes are up, and plays the bag through the graph; the
   tracker's outputs are recorded.
3. Prints the accuracy summary and where it wrote the output bag, the error plot and the
   overlay images.
"""
from __future__ import annotations

import argparse
import shutil
from pathlib import Path
from typing import Any

from hand_tracker_ros.errors import HandTrackerError
from hand_tracker_ros.evaluation.figures import error_plot, overlay_grid
from hand_tracker_ros.evaluation.replay import replay
from hand_tracker_ros.pipeline.frames import load_rig
from hand_tracker_ros.synthetic.sequence import SynthConfig, SyntheticSequence
from hand_tracker_ros.synthetic.writer import write_sequence

GRAPH = ('player', 'features', 'salient_points', 'tracker', 'recorder')


def add_parser(sub: Any) -> None:
    """Register the verb."""
    parser = sub.add_parser('demo', help='run the demo on built-in data', description=__doc__)
    parser.add_argument('--bag', help='a synthetic bag to use instead of making one')
    parser.add_argument('--out', default='out/demo', help='output directory (replaced)')
    parser.add_argument('--frames', type=int, default=45, help='frames of the made bag')
    parser.add_argument('--rate', type=float, default=0.1,
                        help='playback rate (0.1: the tracker keeps up on 2 cores)')
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
        config = SynthConfig(motion='grasp', n_frames=args.frames, n_cameras=4)
        bag = write_sequence(SyntheticSequence(config), out / 'synthetic')
        print(f'made a synthetic 4-camera bag: {bag}')
    outcome = replay(bag, out, rate=args.rate, on_started=_show_graph)
    s = outcome.scores
    print(f'tracker published JointState for {outcome.joint_states} of {outcome.input_sets} '
          'frame sets')
    if s is None:
        print('demo: FAILED (no estimate matched the ground truth)')
        return 1
    print(f'accuracy vs ground truth: mean 3D joint error {s.joint_mean_mm:.2f} mm, median '
          f'{s.joint_median_mm:.2f}, max {s.joint_max_mm:.2f}; fingertips '
          f'{s.fingertip_mean_mm:.2f} mm; 2D reprojection {s.reprojection_px:.2f} px; '
          f'interpenetration <= {s.max_interpenetration_mm:.2f} mm; {s.failures} failures')
    error_plot(outcome.errors_mm, out / 'error.png', f'{bag}: mean 3D joint error')
    stamps = sorted(outcome.states)
    picks = [stamps[i] for i in (0, len(stamps) // 2, -1)] if stamps else []
    overlay_grid(bag, load_rig(bag), outcome.states, picks, out / 'overlays.png')
    print(f'output bag: {outcome.recorded_bag}\nerror plot: {out / "error.png"}\n'
          f'overlay images (rows: frames, columns: cameras): {out / "overlays.png"}')
    return 0
