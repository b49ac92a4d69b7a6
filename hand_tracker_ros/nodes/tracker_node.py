"""`ros2 run hand_tracker_ros tracker`: the tracker node (:mod:`.tracker`), with
``inputs:=images`` composed with the features and salient_points nodes in one process
(:mod:`.composed`)."""
from __future__ import annotations

import sys
from collections.abc import Sequence

from hand_tracker_ros.errors import HandTrackerError
from hand_tracker_ros.node_config import TrackerNodeConfig
from hand_tracker_ros.nodes._runner import run_node
from hand_tracker_ros.nodes.composed import compose
from hand_tracker_ros.nodes.tracker import DESCRIPTION


def main(args: Sequence[str] | None = None) -> int:
    """Console entry point (`ros2 run hand_tracker_ros tracker`)."""
    try:
        return run_node('tracker', DESCRIPTION, TrackerNodeConfig, compose, args)
    except HandTrackerError as err:     # a rig or parameters it cannot run with
        print(f'tracker: error: {err}', file=sys.stderr)
        return 2


if __name__ == '__main__':
    raise SystemExit(main())
