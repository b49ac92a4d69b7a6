"""The tracking status codes: the Python side of ``hand_tracker_msgs/HandState``'s constants.

The message definition (``msg_defs/hand_tracker_msgs/msg/HandState.msg``) is the source; this
enum mirrors its ``STATUS_*`` constants and ``test/test_status.py`` checks that they are equal
(the .msg file, the generated message class and the rosbags typestore).
"""
from __future__ import annotations

from enum import IntEnum


class TrackStatus(IntEnum):
    """``HandState.status``: ``STATUS_<name> = value`` for every member."""

    INITIALIZING = 0
    TRACKING = 1
    LOST = 2
