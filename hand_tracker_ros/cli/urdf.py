"""`hand-tracker urdf [--out FILE]`: the hand's URDF, whose joints are the JointState names.

The repository's ``urdf/hand.urdf`` (installed to ``share/hand_tracker_ros/urdf/``) is this
command's output with the defaults (a test checks it). With ``--shape SHAPE.yaml`` (from
``hand-tracker calibrate``) the links and visuals have that hand's size. The tracker publishes
it itself on ``hand/robot_description`` (with its ``world_frame`` as root link) and the hand's
``/tf``; given to ``robot_state_publisher`` as ``robot_description``, the tracker's
``hand/joint_states`` pose it as well.
"""
from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

from hand_tracker_ros.model.hand import HandModel
from hand_tracker_ros.model.shape_file import shape_or_default
from hand_tracker_ros.model.urdf import urdf_text


def add_parser(sub: Any) -> None:
    """Register the verb."""
    parser = sub.add_parser('urdf', help="print the hand's URDF", description=__doc__)
    parser.add_argument('--out', metavar='FILE', help='write it to FILE instead of stdout')
    parser.add_argument('--root-link', default='world',
                        help='link the hand hangs from (default: world)')
    parser.add_argument('--shape', metavar='SHAPE.yaml',
                        help='hand shape file (default: the default hand)')
    parser.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    """Print or write the URDF."""
    model = HandModel.build(shape_or_default(args.shape))
    text = urdf_text(model, root_link=args.root_link) + '\n'
    if args.out:
        Path(args.out).write_text(text)
    else:
        print(text, end='')
    return 0
