"""`hand-tracker launch`: start the node graph as processes and stop it cleanly.

The tracking nodes run composed (``--mode composed``, the default: one ``tracker`` process that
also hosts ``features`` and ``salient_points``, data passed in memory) or distributed
(``--mode distributed``: three processes over DDS); README "Composed or distributed".
Without ``--bag`` the nodes run until Ctrl-C/SIGTERM (the player idles, the recorder
records nothing): live cameras publish ``<cam>/image_raw`` and ``<cam>/camera_info``, and
``--rig`` is required (the tracker cannot run without the cameras' calibration).

With ``--bag`` (every node on sim time, the rig beside the bag unless ``--rig``):

1. the four other nodes start, and the player starts once the tracker subscribes to every
   camera's features and the recorder to the outputs (at most ``--startup-timeout``);
2. the player plays the bag (``/clock`` on, at ``--rate``) once every image reader listens
   to every camera's images, so no frame is played into an unconnected graph;
3. the recorder writes the tracker's outputs to ``--record`` (default ``<bag>_tracked``);
4. when the bag ends, the graph gets ``--drain`` seconds to finish the frames in flight, then
   every process is stopped.

Every process gets the shipped Fast DDS profile and its ``config/<node>.yaml``, then the
user's ``--params`` file, then the rig, camera and bag settings.
"""
from __future__ import annotations

import argparse
import signal
import time
from pathlib import Path
from typing import Any

from hand_tracker_ros.ament import share_file
from hand_tracker_ros.errors import HandTrackerError
from hand_tracker_ros.geometry.rig import CameraRig
from hand_tracker_ros.launcher import (
    GRAPH_MODES,
    PROCESS_NODES,
    TRACKING_PROCESSES,
    ProcessGroup,
    ProcessSpec,
    player_waits_for_image_consumers,
    ros_list,
    tracker_mode_args,
)
from hand_tracker_ros.topics import JOINT_STATES, STATE, TRACKER_OUTPUTS

RECORDED = tuple(t.absolute for t in TRACKER_OUTPUTS)
# The graph is ready to play once the recorder listens to these (/tf may be switched off).
READY = (JOINT_STATES.absolute, STATE.absolute)


def graph_specs(params_file: str | None = None, *, rig: str | None = None,
                bag: str | None = None, record: str | None = None, mode: str = 'composed',
                rate: float | None = None, loop: bool = False) -> list[ProcessSpec]:
    """One process per executable of ``mode`` plus player and recorder: its
    ``config/<node>.yaml``, the user's file, then overrides."""
    processes = (*TRACKING_PROCESSES[mode], 'player', 'recorder')
    extra: dict[str, list[str]] = {name: [] for name in processes}
    extra['tracker'] += list(tracker_mode_args(mode))
    names = list(CameraRig.from_yaml(rig).names) if rig else []
    if rig:
        for name in TRACKING_PROCESSES[mode]:
            extra[name] += ['-p', f'cameras:={ros_list(names)}']
        extra['tracker'] += ['-p', f'rig_file:={Path(rig).resolve()}']
    if bag:
        for name in processes:
            extra[name] += ['-p', 'use_sim_time:=true']
        extra['player'] += ['-p', f'bag:={bag}']
        if rate is not None:
            extra['player'] += ['-p', f'playback.rate:={rate}']
        if loop:
            extra['player'] += ['-p', 'playback.loop:=true']
        if names:
            extra['player'] += player_waits_for_image_consumers(names, mode)
        extra['recorder'] += ['-p', f'output:={record}', '-p', f'topics:={ros_list(RECORDED)}']
    user = ['--params-file', params_file] if params_file else []
    # A composed tracker process hosts the features and salient_points nodes too: their
    # files go in as well (each node reads the section under its own name).
    hosted = {'tracker': PROCESS_NODES[mode]}
    return [ProcessSpec(name=name, executable=name, ros_args=(
        *(arg for node in hosted.get(name, (name,))
          for arg in ('--params-file', str(share_file(f'config/{node}.yaml')))),
        *user, *extra[name])) for name in processes]


def add_parser(sub: Any) -> None:
    """Register the verb."""
    parser = sub.add_parser('launch', help='run the node graph (until Ctrl-C or the bag ends)',
                            description=__doc__)
    parser.add_argument('--bag', help='bag to play through the graph')
    parser.add_argument('--rig', help='rig YAML (required without --bag; default with --bag: '
                                      'rig.yaml beside the bag)')
    parser.add_argument('--params', help='ros__parameters YAML passed to every node')
    parser.add_argument('--record', help='output bag of the tracker (default <bag>_tracked)')
    parser.add_argument('--mode', choices=GRAPH_MODES, default='composed',
                        help='composed: one tracker process hosting features and '
                             'salient_points (default); distributed: three processes')
    parser.add_argument('--rate', type=float,
                        help="with --bag: playback rate (default: the player's playback.rate, "
                             '1.0 = real time)')
    parser.add_argument('--loop', action='store_true',
                        help='with --bag: play it again and again (until Ctrl-C)')
    parser.add_argument('--startup-timeout', type=float, default=120.0, metavar='S',
                        help='with --bag: longest wait for the graph to connect (default 120)')
    parser.add_argument('--drain', type=float, default=5.0, metavar='S',
                        help='with --bag: seconds for the frames in flight after the bag ends '
                             '(default 5)')
    parser.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    """Start every node; on Ctrl-C/SIGTERM, or when the bag has played and drained, stop them."""
    rig = args.rig or (str(Path(args.bag).parent / 'rig.yaml') if args.bag else None)
    if rig is None:
        msg = ('the tracker needs the camera rig: --rig RIG (intrinsics + extrinsics, schema '
               'config/rig_example.yaml), or --bag BAG with rig.yaml beside it')
        raise HandTrackerError(msg)
    record = args.record or (f'{Path(args.bag).resolve()}_tracked' if args.bag else None)
    specs = graph_specs(args.params, rig=rig, bag=args.bag, record=record, mode=args.mode,
                        rate=args.rate, loop=args.loop)
    # With a bag the player starts last, once the graph is connected (module docstring).
    graph = ProcessGroup([s for s in specs if not (args.bag and s.name == 'player')])
    playback = ProcessGroup([s for s in specs if args.bag and s.name == 'player'])
    signal.signal(signal.SIGTERM, signal.default_int_handler)
    graph.start()
    try:
        try:
            if args.bag and rig:
                _play(playback, CameraRig.from_yaml(rig).names, args)
            else:
                print(f'[launch] {graph.wait_any()} exited; stopping the graph', flush=True)
        except KeyboardInterrupt:
            print('[launch] interrupted; stopping the graph')
    finally:
        codes = {**playback.stop(), **graph.stop()}
    print(f'[launch] exit codes: {codes}' + (f'; tracker outputs in {record}' if record else ''))
    return 0 if all(c in (0, -2) for c in codes.values()) else 1


def _play(playback: ProcessGroup, cameras: tuple[str, ...], args: argparse.Namespace) -> None:
    """Steps 1, 2 and 4 of the module docstring, once the other nodes run."""
    from hand_tracker_ros.ros_io.graph import wait_for_tracking_graph  # rclpy only here

    wait_for_tracking_graph(cameras, READY, timeout_s=args.startup_timeout, mode=args.mode)
    playback.start()
    playback.wait_any()
    print(f'[launch] player exited; stopping the graph in {args.drain:g} s', flush=True)
    time.sleep(args.drain)
