"""`hand-tracker launch`: start the node graph as processes and stop it cleanly.

Without ``--bag`` the five nodes run until Ctrl-C/SIGTERM (the player idles, the recorder
records nothing): live cameras publish ``<cam>/image_raw`` and ``<cam>/camera_info``. With
``--bag`` the player plays it (``/clock`` on, every node on sim time; with a rig, playback
starts once ``features`` and ``salient_points`` listen to every camera, or after 60 s), the
recorder writes the tracker's outputs to ``--record`` (default ``<bag>_tracked``), and the
graph stops when the bag ends. Every process gets the shipped Fast DDS profile and its
``config/<node>.yaml``, then the user's ``--params`` file, then the rig, camera and bag
settings.
"""
from __future__ import annotations

import argparse
import signal
from pathlib import Path
from typing import Any

from hand_tracker_ros.ament import share_file
from hand_tracker_ros.geometry.rig import CameraRig
from hand_tracker_ros.launcher import ProcessGroup, ProcessSpec

NODES = ('features', 'salient_points', 'tracker', 'player', 'recorder')
RECORDED = ('/joint_states', '/hand_state', '/markers', '/diagnostics')


def _list(values: list[str]) -> str:
    return '[' + ','.join(values) + ']'


def graph_specs(params_file: str | None = None, *, rig: str | None = None,
                bag: str | None = None, record: str | None = None) -> list[ProcessSpec]:
    """One process per node: its ``config/<node>.yaml``, the user's file, then overrides."""
    extra: dict[str, list[str]] = {name: [] for name in NODES}
    names = list(CameraRig.from_yaml(rig).names) if rig else []
    if rig:
        for name in ('features', 'salient_points', 'tracker'):
            extra[name] += ['-p', f'cameras:={_list(names)}']
        extra['tracker'] += ['-p', f'rig_file:={Path(rig).resolve()}']
    if bag:
        for name in NODES:
            extra[name] += ['-p', 'use_sim_time:=true']
        extra['player'] += ['-p', f'bag:={bag}']
        if names:
            # Both `features` and `salient_points` subscribe to every camera's images.
            images = _list([f'/{c}/image_raw' for c in names])
            extra['player'] += ['-p', f'wait_topics:={images}', '-p', 'wait_subscriber_count:=2',
                                '-p', 'wait_for_subscribers_s:=60.0']
        extra['recorder'] += ['-p', f'output:={record}', '-p', f'topics:={_list(list(RECORDED))}']
    user = ['--params-file', params_file] if params_file else []
    return [ProcessSpec(name=name, executable=name,
                        ros_args=('--params-file', str(share_file(f'config/{name}.yaml')),
                                  *user, *extra[name]))
            for name in NODES]


def add_parser(sub: Any) -> None:
    """Register the verb."""
    parser = sub.add_parser('launch', help='run the node graph (until Ctrl-C or the bag ends)',
                            description=__doc__)
    parser.add_argument('--bag', help='bag to play through the graph')
    parser.add_argument('--rig', help='rig YAML (default with --bag: rig.yaml beside the bag)')
    parser.add_argument('--params', help='ros__parameters YAML passed to every node')
    parser.add_argument('--record', help='output bag of the tracker (default <bag>_tracked)')
    parser.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    """Start every node; on Ctrl-C/SIGTERM, or when the player (bag) ends, stop them all."""
    rig = args.rig or (str(Path(args.bag).parent / 'rig.yaml') if args.bag else None)
    record = args.record or (f'{Path(args.bag).resolve()}_tracked' if args.bag else None)
    group = ProcessGroup(graph_specs(args.params, rig=rig, bag=args.bag, record=record))
    signal.signal(signal.SIGTERM, signal.default_int_handler)
    group.start()
    try:
        exited = group.wait_any(names=('player',) if args.bag else ())
        print(f'[launch] {exited} exited; stopping the graph')
    except KeyboardInterrupt:
        print('[launch] interrupted; stopping the graph')
    codes = group.stop()
    print(f'[launch] exit codes: {codes}' + (f'; tracker outputs in {record}' if record else ''))
    return 0 if all(c in (0, -2) for c in codes.values()) else 1
