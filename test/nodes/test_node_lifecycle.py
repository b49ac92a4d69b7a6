"""Every node starts, shows up in the ROS graph, and exits 0 on SIGINT or SIGTERM."""
from __future__ import annotations

import os
import signal
import subprocess
import sys
from pathlib import Path

import pytest

from hand_tracker_ros.ament import executable
from hand_tracker_ros.cli.launch import graph_specs
from hand_tracker_ros.graph_nodes import NODES
from hand_tracker_ros.launcher import GRAPH_MODES, ProcessGroup

pytestmark = pytest.mark.ros

RIG = Path(__file__).resolve().parents[2] / 'config' / 'rig_example.yaml'


@pytest.mark.parametrize(('mode', 'readers'), [('composed', 1), ('distributed', 2)])
def test_bag_playback_waits_for_every_image_reader_of_every_rig_camera(mode: str,
                                                                       readers: int) -> None:
    specs = {s.name: s for s in graph_specs(rig=str(RIG), bag='demo_bag', mode=mode)}
    player = specs['player'].ros_args
    images = ','.join(f'/cam{i}/image_raw' for i in range(4))
    assert f'wait_topics:=[{images}]' in player
    assert f'wait_subscriber_count:={readers}' in player
    assert ('features' in specs) == (mode == 'distributed')
    inputs = 'images' if mode == 'composed' else 'features'
    assert f'inputs:={inputs}' in specs['tracker'].ros_args
    without_rig = {s.name: s for s in graph_specs(bag='demo_bag')}['player'].ros_args
    assert not any(arg.startswith('wait_topics') for arg in without_rig)


@pytest.mark.parametrize('mode', GRAPH_MODES)
def test_graph_comes_up_and_stops_cleanly_on_sigint(mode: str, tmp_path: Path) -> None:
    """Both modes show the same five nodes (composed: three of them in one process)."""
    from hand_tracker_ros.ros_io.graph import wait_for_nodes

    specs = graph_specs(rig=str(RIG), mode=mode)
    with open(tmp_path / 'graph.log', 'w') as log:
        group = ProcessGroup(specs, output=log)
        group.start()
        try:
            seen = wait_for_nodes(NODES, timeout_s=60.0)
        finally:
            codes = group.stop()
    output = (tmp_path / 'graph.log').read_text()
    assert seen == set(NODES), output
    assert codes == dict.fromkeys((s.name for s in specs), 0), output


def test_node_exits_cleanly_on_sigterm() -> None:
    from hand_tracker_ros.ros_io.graph import wait_for_nodes

    proc = subprocess.Popen([str(executable('tracker')), '--ros-args', '-p',
                             f'rig_file:={RIG}'],
                            stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    try:
        assert wait_for_nodes(['tracker'], timeout_s=60.0) == {'tracker'}
    finally:
        proc.send_signal(signal.SIGTERM)
        out, _ = proc.communicate(timeout=30)
    assert proc.returncode == 0, out
    assert 'Traceback' not in out


def test_each_console_script_is_an_entry_that_latches_sigint_before_its_imports(
        monkeypatch) -> None:
    """A SIGINT during the imports is noted, not raised where an import could swallow it
    (see ``entry.py``): every node, and ``hand-tracker``, which then ends with 130."""
    from importlib.metadata import entry_points
    from types import SimpleNamespace

    from hand_tracker_ros import entry
    from hand_tracker_ros.interrupts import INTERRUPTS

    scripts = {e.name: e.value for e in entry_points(group='console_scripts')
               if e.value.startswith('hand_tracker_ros.')}
    assert scripts == {**{name: f'hand_tracker_ros.entry:{name}' for name in NODES},
                       'hand-tracker': 'hand_tracker_ros.entry:cli'}
    handlers = []

    def import_module(name: str) -> SimpleNamespace:
        handlers.append((name, signal.getsignal(signal.SIGINT)))
        return SimpleNamespace(main=lambda: 7)

    previous = signal.getsignal(signal.SIGINT)
    monkeypatch.setattr(entry, 'import_module', import_module)
    try:
        assert [getattr(entry, name)() for name in NODES] == [7] * len(NODES)
        # A node process keeps the latch; the CLI starts from Python's own handler (this
        # process may run in the background, with SIGINT ignored).
        signal.signal(signal.SIGINT, signal.default_int_handler)
        assert entry.cli() == 7
        assert signal.getsignal(signal.SIGINT) is signal.default_int_handler   # restored

        def interrupted_import(name: str) -> SimpleNamespace:
            assert signal.getsignal(signal.SIGINT) is INTERRUPTS
            INTERRUPTS(signal.SIGINT, None)                     # the signal, as it would come
            return SimpleNamespace(main=lambda: 7)

        monkeypatch.setattr(entry, 'import_module', interrupted_import)
        assert entry.cli() == entry.INTERRUPTED_EXIT           # interrupted while importing
        assert not INTERRUPTS.hit
        assert signal.getsignal(signal.SIGINT) is signal.default_int_handler
        signal.signal(signal.SIGINT, signal.SIG_IGN)            # a background job's
        monkeypatch.setattr(entry, 'import_module', lambda name: SimpleNamespace(
            main=lambda: signal.getsignal(signal.SIGINT)))
        assert entry.cli() is signal.SIG_IGN                    # left ignoring it
    finally:
        signal.signal(signal.SIGINT, previous)
    assert handlers == [(f'hand_tracker_ros.nodes.{name}_node', INTERRUPTS) for name in NODES] \
        + [('hand_tracker_ros.cli.main', INTERRUPTS)]
    with pytest.raises(AttributeError, match='no node'):
        entry.composer  # noqa: B018 (the attribute access is the test)


def test_a_sigint_latched_before_rclpy_init_stops_the_node_with_0() -> None:
    """The signal comes after the entry latched SIGINT and before the node initialised rclpy
    (in practice: while trimesh imports): the node exits 0 at once instead of running on."""
    script = (
        'import os, signal, sys\n'
        'from hand_tracker_ros.interrupts import INTERRUPTS\n'
        'INTERRUPTS.install()\n'
        'os.kill(os.getpid(), signal.SIGINT)\n'
        'from hand_tracker_ros.nodes import recorder_node\n'
        'sys.exit(recorder_node.main(["recorder"]))\n')
    proc = subprocess.run([sys.executable, '-c', script], capture_output=True, text=True,
                          timeout=20)
    assert proc.returncode == 0, proc.stdout + proc.stderr
    assert 'Traceback' not in proc.stdout + proc.stderr


def test_tracker_without_a_rig_refuses_to_start_and_says_why() -> None:
    proc = subprocess.run([str(executable('tracker'))], capture_output=True, text=True,
                          timeout=60)
    assert proc.returncode == 2
    assert 'no `rig_file` parameter' in proc.stdout + proc.stderr
    assert 'Traceback' not in proc.stdout + proc.stderr


def test_launch_without_a_rig_refuses_to_start() -> None:
    proc = subprocess.run(['hand-tracker', 'launch'], capture_output=True, text=True,
                          timeout=60)
    assert proc.returncode == 2 and '--rig RIG' in proc.stderr


def test_bad_parameter_is_a_clear_startup_error() -> None:
    proc = subprocess.run([str(executable('tracker')), '--ros-args', '-p', 'sync_slop_ms:=-5.0'],
                          capture_output=True, text=True, timeout=60)
    assert proc.returncode != 0
    assert 'sync_slop_ms' in proc.stdout + proc.stderr


def test_restarting_at_an_initial_pose_that_is_not_used_is_a_clear_startup_error() -> None:
    proc = subprocess.run([str(executable('tracker')), '--ros-args', '-p', f'rig_file:={RIG}',
                           '-p', 'restart_at_initial_pose:=true'],
                          capture_output=True, text=True, timeout=60)
    assert proc.returncode != 0
    assert 'needs `initialization: initial_pose`' in proc.stdout + proc.stderr


@pytest.mark.parametrize('level, param_lines', [('info', 0), ('debug', 'all')])
def test_parameters_are_one_info_line_and_each_at_debug(node_process, level,
                                                        param_lines) -> None:
    from hand_tracker_ros.config import flatten
    from hand_tracker_ros.node_config import FeaturesNodeConfig
    from hand_tracker_ros.ros_io.graph import wait_for_nodes

    node = node_process('features', '-p', 'cameras:=[left,right]', '--log-level', level)
    assert wait_for_nodes(['features'], timeout_s=60.0) == {'features'}
    assert node.stop() == 0
    lines = node.output().splitlines()
    summaries = [line for line in lines if 'parameters (' in line]
    assert len(summaries) == 1 and '[INFO]' in summaries[0], lines
    assert f"{len(flatten(FeaturesNodeConfig()))} parameters (cameras=('left', 'right'); " \
        in summaries[0]
    each = [line for line in lines if '] param ' in line or ': param ' in line]
    expected = len(flatten(FeaturesNodeConfig())) if param_lines == 'all' else 0
    assert len(each) == expected, lines


def test_a_process_spins_on_the_events_executor_unless_a_node_has_a_guard_condition(
        ros) -> None:
    from rclpy.executors import SingleThreadedExecutor

    from hand_tracker_ros.nodes._runner import _executor

    node, _ = ros
    events = _executor([node], node.context, 'events')
    assert type(events).__name__ == 'EventsExecutor'
    assert isinstance(_executor([node], node.context, 'single'), SingleThreadedExecutor)
    node.create_guard_condition(lambda: None)       # a player with a bag makes one
    assert isinstance(_executor([node], node.context, 'events'), SingleThreadedExecutor)
    events.shutdown()


@pytest.mark.parametrize(('choice', 'spun_on'), [(None, 'EventsExecutor'),
                                                  ('single', 'SingleThreadedExecutor')])
def test_run_node_spins_on_the_chosen_executor(choice, spun_on) -> None:
    """A node run by ``run_node`` reports its executor from a timer, then SIGINT ends it."""
    script = (
        'import os, signal, sys\n'
        'from rclpy.node import Node\n'
        'from hand_tracker_ros.node_config import RecorderNodeConfig\n'
        'from hand_tracker_ros.nodes._runner import run_node\n'
        'class Probe(Node):\n'
        '    def __init__(self):\n'
        '        super().__init__("executor_probe")\n'
        '        self.create_timer(0.05, self.tick)\n'
        '    def tick(self):\n'
        '        print("spun on", type(self.executor).__name__, flush=True)\n'
        '        os.kill(os.getpid(), signal.SIGINT)\n'
        'sys.exit(run_node("probe", "", RecorderNodeConfig, Probe, ["probe"]))\n')
    env = {k: v for k, v in os.environ.items() if k != 'HAND_TRACKER_EXECUTOR'}
    if choice is not None:
        env['HAND_TRACKER_EXECUTOR'] = choice
    proc = subprocess.run([sys.executable, '-c', script], capture_output=True, text=True,
                          timeout=60, env=env)
    assert proc.returncode == 0, proc.stdout + proc.stderr
    assert f'spun on {spun_on}' in proc.stdout, proc.stdout + proc.stderr


def test_an_unknown_executor_choice_is_a_clear_startup_error() -> None:
    env = {**os.environ, 'HAND_TRACKER_EXECUTOR': 'Single'}
    proc = subprocess.run([str(executable('features'))], capture_output=True, text=True,
                          timeout=60, env=env)
    assert proc.returncode == 2
    assert "HAND_TRACKER_EXECUTOR must be one of events, single, got 'Single'" in proc.stderr
    assert 'Traceback' not in proc.stdout + proc.stderr
