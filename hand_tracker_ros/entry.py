"""Console-script entries: ``ros2 run hand_tracker_ros NAME`` calls ``entry.NAME`` (each node
of :data:`~hand_tracker_ros.graph_nodes.NODES`), ``hand-tracker`` calls :func:`cli`.

A process is told to stop with SIGINT (Ctrl-C), and the signal may come while it still
imports its modules (about a second: the hand model pulls in trimesh). Python's handler would
raise ``KeyboardInterrupt`` there, and trimesh guards its optional imports with
``except BaseException``, so the interrupt would be swallowed and the process would run on.
Each entry therefore latches SIGINT (:data:`hand_tracker_ros.interrupts.INTERRUPTS`) before
it imports anything else:

- a node keeps the latch: :func:`hand_tracker_ros.nodes._runner.run_node` shuts down at once
  after ``rclpy.init`` if it was hit;
- ``hand-tracker`` restores the previous handler after its imports and ends with 130 (the
  shell's code for an interrupted command) if the latch was hit meanwhile; a process that
  ignores SIGINT (a background job of a script) is left ignoring it.

This module imports only the standard library, the node list and the latch, so the latch is
in place about 40 ms after the interpreter starts (the console script's own
``importlib.metadata`` lookup is most of it); a SIGINT before that ends the process with
Python's ``KeyboardInterrupt``.
"""
from __future__ import annotations

import signal
from collections.abc import Callable
from importlib import import_module

from hand_tracker_ros.graph_nodes import NODES
from hand_tracker_ros.interrupts import INTERRUPTS

INTERRUPTED_EXIT = 130


def cli() -> int:
    """``hand-tracker``: :func:`hand_tracker_ros.cli.main.main`, imported under the latch."""
    if signal.getsignal(signal.SIGINT) is signal.SIG_IGN:
        return import_module(f'{__package__}.cli.main').main()
    previous = INTERRUPTS.install()
    try:
        main = import_module(f'{__package__}.cli.main').main
    finally:
        signal.signal(signal.SIGINT, previous)
    if INTERRUPTS.hit:
        INTERRUPTS.hit = False
        return INTERRUPTED_EXIT
    return main()


def __getattr__(name: str) -> Callable[[], int]:
    """``entry.<node>``: latch SIGINT, import ``nodes/<node>_node.py`` and run its ``main``."""
    if name not in NODES:
        raise AttributeError(f'{__name__} has no node {name!r}; nodes: {", ".join(NODES)}')

    def main() -> int:
        INTERRUPTS.install()
        return import_module(f'{__package__}.nodes.{name}_node').main()

    main.__name__ = name
    return main
