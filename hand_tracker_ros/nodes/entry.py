"""Console-script entry of every node: ``ros2 run hand_tracker_ros NAME`` calls ``entry.NAME``.

A node is told to stop with SIGINT, and the signal may come while the node still imports its
modules (about a second: the hand model pulls in trimesh). Python's handler would raise
``KeyboardInterrupt`` there, and trimesh guards its optional imports with
``except BaseException``, so the interrupt would be swallowed and the node would run on.
Each entry therefore latches SIGINT (:data:`INTERRUPTS`) before it imports the node's module;
:func:`hand_tracker_ros.nodes._runner.run_node` keeps the latch installed and shuts down at
once if it was hit. This module imports only the standard library and the node list, so the
latch is in place within a few milliseconds of the interpreter's start.
"""
from __future__ import annotations

import importlib
import signal
from collections.abc import Callable
from types import FrameType

from hand_tracker_ros.graph_nodes import NODES


class InterruptLatch:
    """A SIGINT handler that only records that the signal came."""

    def __init__(self) -> None:
        self.hit = False

    def __call__(self, signum: int, frame: FrameType | None) -> None:
        self.hit = True

    def install(self) -> signal.Handlers | Callable | int | None:
        """Make this the process's SIGINT handler; returns the previous one."""
        return signal.signal(signal.SIGINT, self)


INTERRUPTS = InterruptLatch()


def __getattr__(name: str) -> Callable[[], int]:
    """``entry.<node>``: latch SIGINT, import ``nodes/<node>_node.py`` and run its ``main``."""
    if name not in NODES:
        raise AttributeError(f'{__name__} has no node {name!r}; nodes: {", ".join(NODES)}')

    def main() -> int:
        INTERRUPTS.install()
        return importlib.import_module(f'{__package__}.{name}_node').main()

    main.__name__ = name
    return main
