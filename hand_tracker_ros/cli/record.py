"""`hand-tracker record OUT`: record topics into a new rosbag2 (the `recorder` node).

Runs the node in this process until Ctrl-C or SIGTERM, then closes the bag. Topic types are
found in the graph when the topics appear; messages are stamped with their receive time.
"""
from __future__ import annotations

import argparse
from typing import Any


def add_parser(sub: Any) -> None:
    """Register the verb."""
    parser = sub.add_parser('record', help='record topics into a bag until Ctrl-C',
                            description=__doc__)
    parser.add_argument('output', help='bag directory to create (must not exist)')
    selection = parser.add_mutually_exclusive_group(required=True)
    selection.add_argument('--topics', nargs='+', metavar='TOPIC', help='topics to record')
    selection.add_argument('-a', '--all', action='store_true',
                           help='record every topic that appears')
    parser.add_argument('-x', '--exclude-regex', default='', metavar='REGEX',
                        help='do not record topics fully matching REGEX')
    parser.add_argument('-s', '--storage', default='mcap', choices=('mcap', 'sqlite3'))
    parser.add_argument('--queue-depth', type=int, default=1000,
                        help='subscription queue depth per topic')
    parser.set_defaults(run=run)


def overrides(args: argparse.Namespace) -> dict[str, Any]:
    """The `recorder` node parameters for the parsed options."""
    values: dict[str, Any] = {
        'output': args.output, 'all_topics': args.all, 'exclude_regex': args.exclude_regex,
        'storage': args.storage, 'queue_depth': args.queue_depth}
    if args.topics:
        values['topics'] = tuple(args.topics)
    return values


def run(args: argparse.Namespace) -> int:
    """Record until interrupted; errors of ours propagate to `hand-tracker` as one line."""
    # Imported here: the CLI must import without ROS (house rule 1); recording needs it.
    from hand_tracker_ros.nodes.recorder_node import run_recorder

    return run_recorder(overrides(args), ['hand-tracker record'])
