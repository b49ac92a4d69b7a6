"""Process environment for ROS 2 nodes: our Fast DDS profile unless the user chose one.

Fast DDS reads ``FASTDDS_DEFAULT_PROFILES_FILE`` when a participant is created, so this must
run before ``rclpy.init``. See ``config/fastdds_large_data.xml`` for why the default transports
are not good enough for camera images between processes.
"""
from __future__ import annotations

import os
from collections.abc import MutableMapping

from hand_tracker_ros.ament import share_file

PROFILE = 'config/fastdds_large_data.xml'


def apply_ros_defaults(env: MutableMapping[str, str] | None = None) -> MutableMapping[str, str]:
    """Set the RMW and the large-data DDS profile in ``env`` (default ``os.environ``).

    Values the user already set are kept.
    """
    env = os.environ if env is None else env
    env.setdefault('RMW_IMPLEMENTATION', 'rmw_fastrtps_cpp')
    if 'FASTDDS_DEFAULT_PROFILES_FILE' not in env and 'FASTDDS_BUILTIN_TRANSPORTS' not in env:
        env['FASTDDS_DEFAULT_PROFILES_FILE'] = str(share_file(PROFILE))
    return env
