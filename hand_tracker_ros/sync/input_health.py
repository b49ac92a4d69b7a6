"""The health of each camera's input stream, as the tracker node reports it.

Per camera, from the frames that reach the synchronizer and the camera_info messages:

- a camera_info whose image size contradicts the rig makes that camera's frames *dropped*
  (tracking with the wrong size would be wrong everywhere) until a consistent one arrives;
  one whose ``K`` differs from the rig's (relative and absolute tolerance ``K_TOLERANCE``;
  for rig cameras that have a ``K``, i.e. pinhole ones) is only reported, the rig is used;
- frames without any camera_info for more than ``INFO_GRACE_S`` are reported (the rig's
  intrinsics are used);
- a camera whose last frame is more than ``SILENT_S`` older than the newest frame of any
  camera is *silent*: no set can be formed. A stream starts with the first frame of all, or
  the first after no camera sent for ``PAUSE_S`` (a playback resumed after a pause); a camera
  whose last frame came before it is silent once that start is ``SILENT_S`` old, since the
  cameras' first frames of a stream arrive a few ms apart.

Times are ``time.monotonic()`` seconds passed in by the caller, so the policy is testable
without clocks.
"""
from __future__ import annotations

from collections import Counter
from collections.abc import Sequence

import numpy as np

from hand_tracker_ros._typing import FloatArray
from hand_tracker_ros.geometry.camera_model import Camera

INFO_GRACE_S = 2.0
SILENT_S = 1.0
PAUSE_S = 2.0
K_TOLERANCE = 1e-3


class InputHealth:
    """Frame counts and problems of the cameras of a rig (not thread-safe: one caller).

    Parameters
    ----------
    cameras : sequence of Camera
        The rig's cameras the node serves (their names, sizes and, for pinhole ones, ``K``).
    """

    def __init__(self, cameras: Sequence[Camera]) -> None:
        self._cameras = {c.name: c for c in cameras}
        self._frames: Counter[str] = Counter()
        self._last_frame_s: dict[str, float] = {}
        self._first_frame_s: dict[str, float] = {}
        self._newest_s: float | None = None        # the newest frame of any camera
        self._stream_s = 0.0                       # the first frame of the current stream
        self._info_s: dict[str, float] = {}
        self._mismatch: dict[str, str] = {}

    def accepts(self, camera: str) -> bool:
        """False while ``camera``'s camera_info contradicts the rig's image size."""
        return camera not in self._mismatch

    def frame(self, camera: str, now_s: float) -> None:
        """Count a frame of ``camera`` received at ``now_s``."""
        self._frames[camera] += 1
        if self._newest_s is None or now_s - self._newest_s > PAUSE_S:
            self._stream_s = now_s
        self._newest_s = now_s if self._newest_s is None else max(self._newest_s, now_s)
        self._last_frame_s[camera] = now_s
        self._first_frame_s.setdefault(camera, now_s)

    def camera_info(self, camera: str, width: int, height: int, K: FloatArray,
                    now_s: float) -> tuple[str, str] | None:
        """Check a camera_info against the rig; ``(level, text)`` to log, or None if it agrees.

        ``level`` is ``'error'`` for a size mismatch (the camera's frames are dropped from now
        on) and ``'warning'`` for a different ``K`` (K : (3, 3) float64, px).
        """
        self._info_s[camera] = now_s
        rig = self._cameras[camera]
        if (width, height) != (rig.width, rig.height):
            self._mismatch[camera] = (f'{camera}: camera_info says {width}x{height} but the rig '
                                      f'says {rig.width}x{rig.height}; dropping {camera} frames')
            return 'error', self._mismatch[camera]
        self._mismatch.pop(camera, None)
        rig_K = getattr(rig, 'K', None)      # a pinhole camera's matrix; other models: no check
        if rig_K is not None and not np.allclose(K, rig_K, rtol=K_TOLERANCE, atol=K_TOLERANCE):
            return 'warning', f'{camera}: camera_info K differs from the rig; using the rig'
        return None

    @property
    def mismatches(self) -> dict[str, str]:
        """Per camera: the size mismatch its frames are dropped for."""
        return dict(self._mismatch)

    def problems(self, now_s: float) -> dict[str, str]:
        """Per camera with a problem: size mismatch, no camera_info, or silent."""
        problems = dict(self._mismatch)
        for cam in self._cameras:
            if cam not in self._info_s and \
                    now_s - self._first_frame_s.get(cam, now_s) > INFO_GRACE_S:
                problems.setdefault(cam, f'no camera_info on {cam}/camera_info; using the '
                                         'rig intrinsics')
            last = max(self._last_frame_s.get(cam, self._stream_s), self._stream_s)
            if self._newest_s is not None and self._newest_s - last > SILENT_S:
                problems.setdefault(cam, f'{cam}: no frames for more than {SILENT_S:.0f} s '
                                         'while other cameras send; no sets can be formed')
        return problems

    def take_frame_counts(self) -> dict[str, int]:
        """Frames per camera since the last call (every camera, zeros included)."""
        counts = {c: self._frames[c] for c in self._cameras}
        self._frames.clear()
        return counts
