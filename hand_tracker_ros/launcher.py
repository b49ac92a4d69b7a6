"""A small process launcher: the part of `ros2 launch` this project needs.

``launch``/``launch_ros`` are not on PyPI, so ``hand-tracker launch`` starts the node
executables itself (found as `ros2 run` finds them, see :mod:`hand_tracker_ros.ament`), with
the large-data Fast DDS profile in their environment. It forwards each child's output line by
line with a ``[name]`` prefix, and stops the whole group cleanly: SIGINT to every child, then
SIGTERM and finally SIGKILL to any child still running after its grace period.
"""
from __future__ import annotations

import logging
import os
import signal
import subprocess
import sys
import threading
import time
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import TextIO

from hand_tracker_ros.ament import executable
from hand_tracker_ros.ros_env import apply_ros_defaults
from hand_tracker_ros.shm import SHM_DIR, remove_stale_segments

LOG = logging.getLogger(__name__)


def ros_list(values: Iterable[str]) -> str:
    """Strings as the value of a ``-p name:=[a,b]`` ROS argument."""
    return '[' + ','.join(values) + ']'


# The two ways to run the tracking nodes (README "Composed or distributed"): the node
# processes of each, and the ROS arguments that select the tracker's inputs.
GRAPH_MODES = ('composed', 'distributed')
TRACKING_PROCESSES = {'composed': ('tracker',),
                      'distributed': ('features', 'salient_points', 'tracker')}
TRACKER_INPUTS = {'composed': 'images', 'distributed': 'features'}
IMAGE_READERS = {'composed': 1, 'distributed': 2}    # processes subscribing to the images
# The nodes of the tracker process in each mode.
PROCESS_NODES = {'composed': ('features', 'salient_points', 'tracker'),
                 'distributed': ('tracker',)}


def tracker_mode_args(mode: str) -> tuple[str, ...]:
    """The tracker's ROS arguments for graph ``mode``."""
    return ('-p', f'inputs:={TRACKER_INPUTS[mode]}')


def player_waits_for_image_consumers(cameras: Iterable[str], mode: str) -> tuple[str, ...]:
    """Player ROS arguments that hold playback (at most 60 s) until every process that reads
    images (the composed tracker, or ``features`` and ``salient_points``) subscribes to every
    camera's ``image_raw``."""
    images = ros_list(f'/{c}/image_raw' for c in cameras)
    return ('-p', f'wait_topics:={images}', '-p', f'wait_subscriber_count:={IMAGE_READERS[mode]}',
            '-p', 'wait_for_subscribers_s:=60.0')


@dataclass(frozen=True)
class ProcessSpec:
    """One child process: a node executable with its ROS arguments (``name`` labels its
    output lines; the nodes keep their own names, so a composed process keeps all three)."""

    name: str
    executable: str
    ros_args: tuple[str, ...] = ()
    env: Mapping[str, str] = field(default_factory=dict)

    def argv(self) -> list[str]:
        """Command line: the installed executable plus ``--ros-args ...``."""
        path = str(executable(self.executable))
        return [path, '--ros-args', *self.ros_args]


class ProcessGroup:
    """Start, watch and stop a set of node processes as one unit."""

    def __init__(self, specs: Sequence[ProcessSpec], *, output: TextIO | None = None) -> None:
        self._specs = tuple(specs)
        self._output = output or sys.stdout
        self._procs: dict[str, subprocess.Popen[str]] = {}
        self._threads: list[threading.Thread] = []
        self._lock = threading.Lock()

    def start(self) -> None:
        """Start every process (in order), after removing the Fast DDS shared memory that
        killed processes left behind (:mod:`hand_tracker_ros.shm`)."""
        stale = remove_stale_segments()
        if stale:
            print(f'removed {len(stale)} Fast DDS shared-memory files whose processes are gone '
                  f'from {SHM_DIR}', file=self._output, flush=True)
        for spec in self._specs:
            env = apply_ros_defaults(dict(os.environ))
            env.update(spec.env)
            env['PYTHONUNBUFFERED'] = '1'
            proc = subprocess.Popen(spec.argv(), env=env, stdout=subprocess.PIPE,
                                    stderr=subprocess.STDOUT, text=True, bufsize=1,
                                    start_new_session=True)
            self._procs[spec.name] = proc
            thread = threading.Thread(target=self._forward, args=(spec.name, proc),
                                      daemon=True)
            thread.start()
            self._threads.append(thread)

    def _forward(self, name: str, proc: subprocess.Popen[str]) -> None:
        assert proc.stdout is not None
        for line in proc.stdout:
            with self._lock:
                self._output.write(f'[{name}] {line}')
                self._output.flush()

    def returncodes(self) -> dict[str, int | None]:
        """Exit code per process name (None while running)."""
        return {name: proc.poll() for name, proc in self._procs.items()}

    def wait_any(self, timeout_s: float | None = None, names: Sequence[str] = ()) -> str | None:
        """Block until one process (of ``names``, default any) exits; return its name."""
        watched = names or tuple(self._procs)
        deadline = None if timeout_s is None else time.monotonic() + timeout_s
        while deadline is None or time.monotonic() < deadline:
            for name in watched:
                if self._procs[name].poll() is not None:
                    return name
            time.sleep(0.05)
        return None

    def stop(self, grace_s: float = 10.0) -> dict[str, int | None]:
        """SIGINT every child, escalate to SIGTERM then SIGKILL; return the exit codes."""
        for sig in (signal.SIGINT, signal.SIGTERM, signal.SIGKILL):
            running = [p for p in self._procs.values() if p.poll() is None]
            if not running:
                break
            for proc in running:
                proc.send_signal(sig)
            deadline = time.monotonic() + grace_s
            while time.monotonic() < deadline and any(p.poll() is None for p in running):
                time.sleep(0.05)
            left = [name for name, p in self._procs.items() if p.poll() is None]
            if left:
                LOG.warning('still running after %s: %s', signal.Signals(sig).name, left)
        for thread in self._threads:
            thread.join(timeout=2.0)
        return self.returncodes()
