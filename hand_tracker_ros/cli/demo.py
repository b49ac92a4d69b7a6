"""`hand-tracker demo`: run the node graph and show, from the ROS graph, that it is up."""
from __future__ import annotations

import argparse
from typing import Any

from hand_tracker_ros.cli.launch import NODES, graph_specs
from hand_tracker_ros.launcher import ProcessGroup


def add_parser(sub: Any) -> None:
    """Register the verb."""
    parser = sub.add_parser('demo', help='run the demo on built-in data', description=__doc__)
    parser.add_argument('--timeout', type=float, default=60.0,
                        help='seconds to wait for every node to appear (default 60)')
    parser.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    """Start the five nodes, wait until the ROS graph lists them all, stop them cleanly."""
    from hand_tracker_ros.ros_io.graph import wait_for_nodes  # rclpy only when needed

    group = ProcessGroup(graph_specs())
    group.start()
    try:
        seen = wait_for_nodes(NODES, timeout_s=args.timeout)
    finally:
        codes = group.stop()
    print('\nnodes seen in the ROS graph:')
    for name in NODES:
        print(f"  /{name:<16} {'up' if name in seen else 'NOT SEEN'}   exit code {codes[name]}")
    ok = seen == set(NODES) and all(c == 0 for c in codes.values())
    print('demo: ' + ('all nodes came up and shut down cleanly' if ok else 'FAILED'))
    return 0 if ok else 1
