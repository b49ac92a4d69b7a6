"""`hand-tracker synth`: render a synthetic multi-camera sequence into a rosbag2.

With ``--shape SHAPE.yaml`` the hand has that shape: the ground-truth HandState carries it
(``shape_parameters``) and the file is copied to ``shape.yaml`` beside ``rig.yaml``.
"""
from __future__ import annotations

import argparse
import time
from typing import Any

from hand_tracker_ros.model.hand import HandModel
from hand_tracker_ros.model.shape_file import shape_or_default
from hand_tracker_ros.synthetic.motions import ALL_MOTIONS
from hand_tracker_ros.synthetic.sequence import SynthConfig, SyntheticSequence
from hand_tracker_ros.synthetic.writer import IMAGE_FORMATS, write_sequence


def add_parser(sub: Any) -> None:
    """Register the verb."""
    parser = sub.add_parser('synth', help='write a synthetic sequence with ground truth',
                            description=__doc__)
    parser.add_argument('--out', required=True, help='output directory (bag/ and rig.yaml)')
    parser.add_argument('--motion', default='grasp', choices=ALL_MOTIONS)
    parser.add_argument('--cameras', type=int, default=4, help='1-8 cameras (default 4)')
    parser.add_argument('--frames', type=int, default=120)
    parser.add_argument('--fps', type=float, default=30.0)
    parser.add_argument('--width', type=int, default=320)
    parser.add_argument('--height', type=int, default=240)
    parser.add_argument('--noise', type=float, default=3.0, help='image noise std (gray levels)')
    parser.add_argument('--clutter', type=int, default=6, help='clutter shapes per background')
    parser.add_argument('--seed', type=int, default=0)
    parser.add_argument('--shape', metavar='SHAPE.yaml',
                        help='hand shape file (default: the default hand)')
    parser.add_argument('--storage', default='mcap', choices=('mcap', 'sqlite3'))
    parser.add_argument('--image-format', default='raw', choices=IMAGE_FORMATS,
                        help='raw: sensor_msgs/Image rgb8 on /camK/image_raw; jpeg, png: '
                             'sensor_msgs/CompressedImage on /camK/image_raw/compressed')
    parser.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    """Render and write the sequence; print where it went."""
    config = SynthConfig(motion=args.motion, n_frames=args.frames, fps=args.fps,
                         n_cameras=args.cameras, width=args.width, height=args.height,
                         noise_sigma=args.noise, clutter=args.clutter, seed=args.seed)
    start = time.monotonic()
    model = HandModel.build(shape_or_default(args.shape))
    bag = write_sequence(SyntheticSequence(config, model), args.out, storage=args.storage,
                         image_format=args.image_format)
    elapsed = time.monotonic() - start
    print(f'wrote {bag} ({args.frames} frames x {args.cameras} cameras, '
          f'{args.frames / elapsed:.1f} frames/s) and {bag.parent / "rig.yaml"}')
    return 0
