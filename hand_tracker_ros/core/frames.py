"""The frame set: one synchronized set of camera images, the tracker's input."""
from __future__ import annotations

from dataclasses import dataclass

from hand_tracker_ros._typing import UInt8Array


@dataclass(frozen=True, eq=False)
class FrameSet:
    """One synchronized set of camera images (rgb8), in rig camera order."""

    stamp_ns: int
    images: tuple[UInt8Array, ...]
