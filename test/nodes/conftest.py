"""Helpers for node tests: a node process with captured output, and an in-test ROS node."""
from __future__ import annotations

import signal
import subprocess
import time
from collections.abc import Callable, Iterator
from pathlib import Path

import pytest

from hand_tracker_ros.ament import executable


class NodeProcess:
    """A node executable running in the background, its output in a file."""

    def __init__(self, name: str, ros_args: list[str], log: Path) -> None:
        self.log = log
        self._file = log.open('w')
        self._interrupted = False
        self.proc = subprocess.Popen([str(executable(name)), '--ros-args', *ros_args],
                                     stdout=self._file, stderr=subprocess.STDOUT)

    def output(self) -> str:
        """Everything the node printed so far."""
        return self.log.read_text()

    def interrupt(self) -> None:
        """SIGINT, once, without waiting (:meth:`stop` waits)."""
        if self.proc.poll() is None and not self._interrupted:
            self.proc.send_signal(signal.SIGINT)
            self._interrupted = True

    def stop(self) -> int:
        """SIGINT and wait; returns the exit code."""
        if self.proc.poll() is None:
            self.interrupt()
            try:
                self.proc.wait(timeout=20)
            except subprocess.TimeoutExpired:
                self.proc.kill()
                self.proc.wait()
        self._file.close()
        return self.proc.returncode


@pytest.fixture()
def node_process(tmp_path: Path) -> Iterator[Callable[..., NodeProcess]]:
    started: list[NodeProcess] = []

    def start(name: str, *ros_args: str) -> NodeProcess:
        node = NodeProcess(name, list(ros_args), tmp_path / f'{name}.log')
        started.append(node)
        return node
    yield start
    # Every node shuts down at once, then each is waited for.
    for node in started:
        node.interrupt()
    for node in started:
        node.stop()


@pytest.fixture()
def ros():
    """An in-test rclpy node with its own context and executor: (node, spin_until)."""
    import rclpy
    from rclpy.executors import SingleThreadedExecutor

    context = rclpy.Context()
    rclpy.init(context=context)
    node = rclpy.create_node('node_test_driver', context=context)
    executor = SingleThreadedExecutor(context=context)
    executor.add_node(node)

    def spin_until(done: Callable[[], bool], timeout_s: float) -> bool:
        deadline = time.monotonic() + timeout_s
        while not done() and time.monotonic() < deadline:
            executor.spin_once(timeout_sec=0.05)
        return done()

    yield node, spin_until
    node.destroy_node()
    rclpy.try_shutdown(context=context)
