"""`hand-tracker topics {list,echo,hz}`: look at the live ROS graph (``ros2 topic``'s core).

``list`` prints every topic with its type; ``echo TOPIC`` prints its messages as YAML;
``hz TOPIC`` prints its receive rate every second. ``echo`` and ``hz`` run until Ctrl-C unless
``--count``/``--duration`` is given.
"""
from __future__ import annotations

import argparse
import sys
from typing import Any


def add_parser(sub: Any) -> None:
    """Register the verb and its three sub-verbs."""
    parser = sub.add_parser('topics', help='list, echo or measure the rate of live topics',
                            description=__doc__)
    tools = parser.add_subparsers(dest='tool', required=True, metavar='TOOL')
    listing = tools.add_parser('list', help='topics and types in the graph')
    listing.add_argument('-v', '--verbose', action='store_true',
                         help='also count publishers and subscribers')
    listing.add_argument('--wait', type=float, default=1.0, metavar='S',
                         help='discovery time before listing (default 1 s)')
    echo = tools.add_parser('echo', help='print the messages of a topic')
    echo.add_argument('topic')
    echo.add_argument('-n', '--count', type=int, help='stop after this many messages')
    echo.add_argument('--truncate-length', type=int, default=16, metavar='N',
                      help='print at most N items of each array (default 16)')
    rate = tools.add_parser('hz', help='print the receive rate of a topic')
    rate.add_argument('topic')
    rate.add_argument('-w', '--window', type=int, default=100,
                      help='messages the statistics use (default 100)')
    rate.add_argument('--duration', type=float, metavar='S', help='stop after S seconds')
    for tool in (echo, rate):
        tool.add_argument('--wait', type=float, default=10.0, metavar='S',
                          help='how long to wait for the topic to appear (default 10 s)')
    parser.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    """Run the chosen tool; errors of ours propagate to `hand-tracker` as one line."""
    # Imported here: the CLI must import without ROS (house rule 1); these tools need it.
    from hand_tracker_ros.ros_io import topic_tools

    if args.tool == 'list':
        for line in topic_tools.list_topics(wait_s=args.wait, verbose=args.verbose):
            print(line)
    elif args.tool == 'echo':
        topic_tools.echo(args.topic, sys.stdout, count=args.count, wait_s=args.wait,
                         max_items=args.truncate_length)
    else:
        topic_tools.hz(args.topic, sys.stdout, duration_s=args.duration, wait_s=args.wait,
                       window=args.window)
    return 0
