"""`hand-tracker play BAG`: replay a rosbag2 on its original topics (the `player` node).

The options mirror ``ros2 bag play``; they become the node's parameters and the node runs in
this process until the bag ends (exit code 0) or Ctrl-C. A missing or corrupt bag is one
error line naming the file (exit code 2). Resume a ``--start-paused`` player by publishing
``false`` (std_msgs/Bool) on ``/player/pause``.
"""
from __future__ import annotations

import argparse
from typing import Any


def add_parser(sub: Any) -> None:
    """Register the verb."""
    parser = sub.add_parser('play', help='replay a bag on its original topics',
                            description=__doc__)
    parser.add_argument('bag', help='bag directory (sqlite3 or mcap) or .mcap file')
    parser.add_argument('-r', '--rate', type=float, default=1.0, help='speed factor')
    parser.add_argument('-l', '--loop', action='store_true', help='play the bag endlessly')
    parser.add_argument('--start-offset', type=float, default=0.0, metavar='S',
                        help='bag seconds skipped at the start')
    parser.add_argument('--playback-duration', type=float, default=-1.0, metavar='S',
                        help='bag seconds played (negative: to the end)')
    parser.add_argument('-d', '--delay', type=float, default=0.0, metavar='S',
                        help='wall seconds waited before each pass')
    parser.add_argument('--topics', nargs='+', default=[], metavar='TOPIC',
                        help='play only these bag topics')
    parser.add_argument('-x', '--exclude-regex', default='', metavar='REGEX',
                        help='do not play bag topics fully matching REGEX')
    parser.add_argument('-m', '--remap', nargs='+', default=[], metavar='OLD:=NEW',
                        help='publish bag topic OLD on NEW')
    parser.add_argument('--no-clock', action='store_true',
                        help='do not publish /clock (once per bag time, before its messages)')
    parser.add_argument('-p', '--start-paused', action='store_true',
                        help='wait for false on /player/pause before playing')
    parser.add_argument('--wait-for-subscribers', type=float, default=5.0, metavar='S',
                        help='wait up to S s for subscribers before playing (0: no wait)')
    parser.add_argument('--wait-topics', nargs='+', default=[], metavar='TOPIC',
                        help='output topics to wait for (default: every played topic)')
    parser.add_argument('--wait-subscriber-count', type=int, default=1, metavar='N',
                        help='subscribers each waited-for topic must have (default: 1)')
    parser.add_argument('--qos-reliability', default='bag',
                        choices=('bag', 'reliable', 'best_effort'),
                        help='publisher reliability (default: as recorded)')
    parser.set_defaults(run=run)


def overrides(args: argparse.Namespace) -> dict[str, Any]:
    """The `player` node parameters for the parsed options (empty lists left out)."""
    values: dict[str, Any] = {
        'bag': args.bag, 'playback.rate': args.rate, 'playback.loop': args.loop,
        'playback.start_offset_s': args.start_offset,
        'playback.duration_s': args.playback_duration, 'playback.delay_s': args.delay,
        'playback.exclude_regex': args.exclude_regex, 'publish_clock': not args.no_clock,
        'start_paused': args.start_paused, 'wait_for_subscribers_s': args.wait_for_subscribers,
        'wait_subscriber_count': args.wait_subscriber_count,
        'qos_reliability': args.qos_reliability,
        'playback.topics': tuple(args.topics), 'playback.remap': tuple(args.remap),
        'wait_topics': tuple(args.wait_topics)}
    # ROS cannot type an empty list parameter; the node's default is the empty list anyway.
    return {name: value for name, value in values.items() if value != ()}


def run(args: argparse.Namespace) -> int:
    """Play the bag; errors of ours propagate to `hand-tracker` as one line."""
    # Imported here: the CLI must import without ROS (house rule 1); playing needs it.
    from hand_tracker_ros.nodes.player_node import run_player

    return run_player(overrides(args), ['hand-tracker play'])
