"""Hand shape (size) parameters: what a per-user calibration may fit.

Every length is multiplied by the global ``scale``; every sphere radius by
``scale * radius_scale``. The default is an adult right hand of hand length about 0.19 m with
segment lengths from the Buchholz et al. (1992) ratios listed in :mod:`.skeleton`.
:meth:`HandShape.to_vector` / :meth:`HandShape.from_vector` map the shape to a flat vector in
the order of ``SHAPE_NAMES`` so an optimizer can fit it.
"""
from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from typing import Any

import numpy as np

from hand_tracker_ros._typing import FloatArray
from hand_tracker_ros.checks import check_finite, check_shape
from hand_tracker_ros.errors import ConfigError

# Default hand length (wrist crease to middle fingertip), m; the segment ratios below are
# fractions of it (Buchholz, Armstrong & Goldstein 1992, Ergonomics 35(3):261-273; table of
# segment-length / hand-length ratios, as commonly reproduced; values quoted from memory of
# that table, not re-checked against the paper). docs/anthropometry.md cites it and checks the
# finger proportions against published phalanx measurements (all within 2.6 %, the thumb
# within 1.2 %).
_HAND_LENGTH_M = 0.19
_PALM_RATIO = 0.373                      # middle metacarpal: wrist to middle MCP
_RATIOS: dict[str, tuple[float, float, float]] = {
    'thumb': (0.251, 0.196, 0.158),      # metacarpal, proximal, distal
    'index': (0.265, 0.143, 0.097),      # proximal, middle, distal
    'middle': (0.277, 0.170, 0.108),
    'ring': (0.259, 0.165, 0.107),
    'pinky': (0.206, 0.117, 0.093),
}


def _lengths(finger: str) -> tuple[float, float, float]:
    r = _RATIOS[finger]
    return (r[0] * _HAND_LENGTH_M, r[1] * _HAND_LENGTH_M, r[2] * _HAND_LENGTH_M)


@dataclass(frozen=True)
class HandShape:
    """Size of the hand model (hashable, so models can be cached per shape).

    Attributes
    ----------
    scale : float
        Global scale factor applied to every length and radius.
    palm_length_m : float
        Wrist to middle-finger MCP.
    palm_width_m : float
        Index MCP centre to pinky MCP centre.
    thumb_m : (3,) tuple of float
        Thumb metacarpal (CMC to MCP), proximal, distal (IP to tip) lengths.
    index_m, middle_m, ring_m, pinky_m : (3,) tuple of float
        Proximal, middle, distal phalanx lengths (joint to joint, distal to the tip).
    radius_scale : float
        Extra factor on every sphere radius (finger thickness).
    """

    scale: float = 1.0
    palm_length_m: float = _PALM_RATIO * _HAND_LENGTH_M
    palm_width_m: float = 0.056
    thumb_m: tuple[float, float, float] = _lengths('thumb')
    index_m: tuple[float, float, float] = _lengths('index')
    middle_m: tuple[float, float, float] = _lengths('middle')
    ring_m: tuple[float, float, float] = _lengths('ring')
    pinky_m: tuple[float, float, float] = _lengths('pinky')
    radius_scale: float = 1.0

    def __post_init__(self) -> None:
        values = self.to_vector()
        if not np.all(np.isfinite(values)) or np.any(values <= 0.0):
            bad = [n for n, v in zip(SHAPE_NAMES, values) if not (np.isfinite(v) and v > 0)]
            msg = f'HandShape fields must be finite and > 0: {", ".join(bad)}'
            raise ConfigError(msg)

    def finger_lengths_m(self) -> FloatArray:
        """Scaled segment lengths (5, 3) float64, fingers in FINGER_NAMES order."""
        table = (self.thumb_m, self.index_m, self.middle_m, self.ring_m, self.pinky_m)
        return self.scale * np.asarray(table, dtype=np.float64)

    def to_vector(self) -> FloatArray:
        """Flat shape vector (19,) float64 in ``SHAPE_NAMES`` order."""
        return np.array([self.scale, self.palm_length_m, self.palm_width_m,
                         *self.thumb_m, *self.index_m, *self.middle_m, *self.ring_m,
                         *self.pinky_m, self.radius_scale], dtype=np.float64)

    @classmethod
    def from_vector(cls, values: FloatArray) -> HandShape:
        """Inverse of :meth:`to_vector`; ``values`` is (19,) float64."""
        values = np.asarray(values, dtype=np.float64)
        check_shape('values', values, (len(SHAPE_NAMES),))
        check_finite('values', values)
        v = [float(x) for x in values]
        return cls(scale=v[0], palm_length_m=v[1], palm_width_m=v[2],
                   thumb_m=(v[3], v[4], v[5]), index_m=(v[6], v[7], v[8]),
                   middle_m=(v[9], v[10], v[11]), ring_m=(v[12], v[13], v[14]),
                   pinky_m=(v[15], v[16], v[17]), radius_scale=v[18])

    def replace(self, **changes: Any) -> HandShape:
        """Copy with some fields changed (``dataclasses.replace``)."""
        return dataclasses.replace(self, **changes)


SHAPE_NAMES: tuple[str, ...] = (
    'scale', 'palm_length_m', 'palm_width_m',
    *(f'{f}_{s}_m' for f, segs in (('thumb', ('metacarpal', 'proximal', 'distal')),
                                   ('index', ('proximal', 'middle', 'distal')),
                                   ('middle', ('proximal', 'middle', 'distal')),
                                   ('ring', ('proximal', 'middle', 'distal')),
                                   ('pinky', ('proximal', 'middle', 'distal')))
      for s in segs),
    'radius_scale',
)
