"""A SIGINT latch: a handler that only notes the signal (see :mod:`hand_tracker_ros.entry`).

It imports only the standard library, so that a console entry can install it before any
heavy import.
"""
from __future__ import annotations

import signal
from collections.abc import Callable
from types import FrameType


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
