"""The rosbags type store: ROS 2 Kilted types plus our ``hand_tracker_msgs`` types.

The ``.msg`` files in ``msg_defs/hand_tracker_msgs/msg`` are the single source of the
custom types. They are parsed with rosbags' ``get_types_from_msg``, so the definitions and
the RIHS01 type hashes written into bags equal the ones colcon's rosidl build produces,
without needing the built package (or rclpy) at run time. ``tf2_msgs/msg/TFMessage`` (the
``/tf`` of the estimates bags) comes with the Kilted store; ``msg_defs/tf2_msgs`` holds the same
definition for installs without tf2_msgs (a test checks that the type hashes agree).

Search order for the ``.msg`` directory (first hit wins):

1. the source tree, ``<repo>/msg_defs/hand_tracker_msgs/msg`` relative to this file;
2. ``<prefix>/share/hand_tracker_msgs/msg`` for each prefix in ``AMENT_PREFIX_PATH``
   (an installed interface package; parsed here so the core needs no ament_index_python);
3. ``<prefix>/share/hand_tracker_ros/msg_defs/hand_tracker_msgs/msg`` for the same prefixes
   and for the Python prefix this package is installed under.
"""
from __future__ import annotations

import functools
import os
import sys
from pathlib import Path

from rosbags.typesys import Stores, get_types_from_msg, get_typestore
from rosbags.typesys.store import Typestore

from hand_tracker_ros.errors import BagFormatError

PACKAGE = 'hand_tracker_msgs'
# Nested types first: registering SalientPoints needs SalientPoint to be known.
MSG_NAMES = ('SalientPoint', 'SalientPoints', 'HandState')


def msg_dir_candidates(repo_root: Path, ament_prefix_path: str) -> list[Path]:
    """Return the directories searched for the ``.msg`` files, in search order.

    Parameters
    ----------
    repo_root : Path
        Root of a source checkout (holding ``msg_defs/``).
    ament_prefix_path : str
        Value of ``AMENT_PREFIX_PATH`` (``os.pathsep``-separated install prefixes).
    """
    prefixes = [Path(p) for p in ament_prefix_path.split(os.pathsep) if p]
    dirs = [repo_root / 'msg_defs' / PACKAGE / 'msg']
    dirs += [p / 'share' / PACKAGE / 'msg' for p in prefixes]
    dirs += [p / 'share' / 'hand_tracker_ros' / 'msg_defs' / PACKAGE / 'msg'
             for p in [*prefixes, Path(sys.prefix)]]
    return dirs


def find_msg_dir(candidates: list[Path] | None = None) -> Path:
    """Return the first directory holding every ``.msg`` file of ``MSG_NAMES``.

    Parameters
    ----------
    candidates : list of Path, optional
        Directories to try; by default :func:`msg_dir_candidates` of this source tree and
        the ``AMENT_PREFIX_PATH`` environment variable.

    Raises
    ------
    BagFormatError
        If no candidate holds them all; the message lists the directories searched.
    """
    if candidates is None:
        candidates = msg_dir_candidates(Path(__file__).resolve().parents[2],
                                        os.environ.get('AMENT_PREFIX_PATH', ''))
    for directory in candidates:
        if all((directory / f'{name}.msg').is_file() for name in MSG_NAMES):
            return directory
    searched = ', '.join(str(d) for d in candidates)
    msg = (f'cannot find the {PACKAGE} .msg files ({", ".join(MSG_NAMES)}); searched: '
           f'{searched}. Run from the source tree or source an install with AMENT_PREFIX_PATH')
    raise BagFormatError(msg)


def register_msgs(store: Typestore, msg_dir: Path) -> None:
    """Register every type of ``MSG_NAMES`` from ``msg_dir`` into ``store``, nested first."""
    for name in MSG_NAMES:
        path = msg_dir / f'{name}.msg'
        store.register(get_types_from_msg(path.read_text(), f'{PACKAGE}/msg/{name}'))


@functools.cache
def typestore() -> Typestore:
    """Return the shared type store (cached): ``Stores.ROS2_KILTED`` + ``hand_tracker_msgs``.

    Named explicitly rather than ``Stores.LATEST``, whose meaning moves with rosbags releases.

    Raises
    ------
    BagFormatError
        If the ``.msg`` files cannot be found (see :func:`find_msg_dir`).
    """
    store = get_typestore(Stores.ROS2_KILTED)
    register_msgs(store, find_msg_dir())
    return store
