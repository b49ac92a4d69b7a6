"""`hand-tracker bag-info BAG`: what a rosbag2 holds (the `ros2 bag info` of this project).

Prints the path, storage plugin, size on disk, duration, start and end (bag time), message
count, and one line per topic with its type, message count and QoS (best effort or reliable).
"""
from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

from hand_tracker_ros.bags.reader import BagReader

NS_PER_S = 10**9


def add_parser(sub: Any) -> None:
    """Register the verb."""
    parser = sub.add_parser('bag-info', help='print the topics, types, counts and duration '
                            'of a bag', description=__doc__)
    parser.add_argument('bag', help='rosbag2 directory or .mcap file')
    parser.set_defaults(run=run)


def _size_bytes(path: Path) -> int:
    files = [path] if path.is_file() else [f for f in path.rglob('*') if f.is_file()]
    return sum(f.stat().st_size for f in files)


def _seconds(stamp_ns: int) -> str:
    """Exact decimal seconds of an int ns stamp (a float loses the last digits)."""
    return f'{stamp_ns // NS_PER_S}.{stamp_ns % NS_PER_S:09d}'


def bag_info_text(bag: str | Path) -> str:
    """The report of ``bag`` (raises BagFormatError for a missing or unreadable bag)."""
    with BagReader(bag) as reader:
        topics = reader.topics
        start_ns, end_ns = reader.start_ns, reader.end_ns
        lines = [f'path:      {reader.path}',
                 f'storage:   {reader.storage}',
                 f'size:      {_size_bytes(reader.path) / 2**20:.1f} MiB',
                 f'messages:  {sum(t.count for t in topics.values())}']
    if any(t.count for t in topics.values()):
        lines += [f'duration:  {(end_ns - 1 - start_ns) / NS_PER_S:.3f} s',
                  f'start:     {_seconds(start_ns)} s (bag time)',
                  f'end:       {_seconds(end_ns - 1)} s (bag time)']
    lines.append(f'topics:    {len(topics)}')
    width = max((len(name) for name in topics), default=0)
    type_width = max((len(t.msgtype) for t in topics.values()), default=0)
    for name in sorted(topics):
        summary = topics[name]
        qos = 'best effort' if summary.best_effort else 'reliable'
        lines.append(f'  {name:<{width}}  {summary.msgtype:<{type_width}}  '
                     f'{summary.count:>7} msgs  {qos}')
    return '\n'.join(lines)


def run(args: argparse.Namespace) -> int:
    """Print the report."""
    print(bag_info_text(args.bag))
    return 0
