"""`hand-tracker launch`: start the node graph as processes and stop it cleanly."""
from __future__ import annotations

import argparse
import signal
from typing import Any

from hand_tracker_ros.ament import share_file
from hand_tracker_ros.launcher import ProcessGroup, ProcessSpec

NODES = ('features', 'salient_points', 'tracker', 'player', 'recorder')


def graph_specs(params_file: str | None = None) -> list[ProcessSpec]:
    """One process per node with its ``config/<node>.yaml``, then the user's file if any."""
    user = ('--params-file', params_file) if params_file else ()
    return [ProcessSpec(name=name, executable=name,
                        ros_args=('--params-file', str(share_file(f'config/{name}.yaml')), *user))
            for name in NODES]


def add_parser(sub: Any) -> None:
    """Register the verb."""
    parser = sub.add_parser('launch', help='run the node graph until Ctrl-C',
                            description=__doc__)
    parser.add_argument('--params', help='ros__parameters YAML passed to every node')
    parser.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    """Start every node; on Ctrl-C/SIGTERM or when one node exits, stop them all."""
    group = ProcessGroup(graph_specs(args.params))
    signal.signal(signal.SIGTERM, signal.default_int_handler)
    group.start()
    try:
        exited = group.wait_any()
        print(f'[launch] {exited} exited; stopping the graph')
    except KeyboardInterrupt:
        print('[launch] interrupted; stopping the graph')
    codes = group.stop()
    print(f'[launch] exit codes: {codes}')
    return 0 if all(c in (0, -2) for c in codes.values()) else 1
