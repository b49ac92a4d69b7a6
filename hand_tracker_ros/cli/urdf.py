"""`hand-tracker urdf [--out FILE] [--shape NAME=VALUE ...]`: the hand's URDF, whose joints are
the JointState names; ``--shape`` gives the URDF of a hand of another size (HandShape fields).

The repository's ``urdf/hand.urdf`` (installed to ``share/hand_tracker_ros/urdf/``) is this
command's output with the defaults (a test checks it). The tracker publishes it itself on
``hand/robot_description`` (with its ``world_frame`` as root link) and the hand's ``/tf``; given
to ``robot_state_publisher`` as ``robot_description``, the tracker's ``hand/joint_states`` pose
it as well.
"""
from __future__ import annotations

import argparse
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from hand_tracker_ros.errors import ConfigError
from hand_tracker_ros.model.hand import HandModel
from hand_tracker_ros.model.shape import SHAPE_NAMES, HandShape
from hand_tracker_ros.model.urdf import urdf_text


def add_parser(sub: Any) -> None:
    """Register the verb."""
    parser = sub.add_parser('urdf', help="print the hand's URDF", description=__doc__)
    parser.add_argument('--out', metavar='FILE', help='write it to FILE instead of stdout')
    parser.add_argument('--root-link', default='world',
                        help='link the hand hangs from (default: world)')
    parser.add_argument('--shape', nargs='+', default=(), metavar='NAME=VALUE',
                        help='a hand of another size: shape parameters that differ from the '
                             f'default (m, or a factor): {", ".join(SHAPE_NAMES)}')
    parser.set_defaults(run=run)


def shape_from(items: Sequence[str]) -> HandShape:
    """The default HandShape with ``NAME=VALUE`` items (SHAPE_NAMES) changed.

    Raises
    ------
    ConfigError
        For an item that is not ``NAME=VALUE`` with a known name and a positive number.
    """
    values = HandShape().to_vector()
    for item in items:
        name, _, value = item.partition('=')
        if name not in SHAPE_NAMES:
            msg = f'unknown shape parameter {name!r} in {item!r}; known: {", ".join(SHAPE_NAMES)}'
            raise ConfigError(msg)
        try:
            values[SHAPE_NAMES.index(name)] = float(value)
        except ValueError as err:
            msg = f'shape parameter {name!r} needs a number, got {value!r}'
            raise ConfigError(msg) from err
    return HandShape.from_vector(np.asarray(values))


def run(args: argparse.Namespace) -> int:
    """Print or write the URDF."""
    text = urdf_text(HandModel.build(shape_from(args.shape)), root_link=args.root_link) + '\n'
    if args.out:
        Path(args.out).write_text(text)
    else:
        print(text, end='')
    return 0
