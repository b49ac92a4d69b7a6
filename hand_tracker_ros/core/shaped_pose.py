"""The hand posed with parameters beyond the pose, as the energy terms read it.

The terms read only ``vertices_m``, the rows ``vertices_jac[ids]``, ``size(theta)`` and the
fingertip vertices. A :class:`ShapedPose` whose vertex Jacobian has columns for further
parameters (the calibration's 19 shape fields, the online refinement's global scale) makes
each term's analytic Jacobian the one with respect to all of them by the chain rule.
"""
from __future__ import annotations

from dataclasses import dataclass

from hand_tracker_ros._typing import FloatArray, IntArray


@dataclass(frozen=True, eq=False)
class ShapedPose:
    """The hand at one pose and shape.

    Attributes
    ----------
    theta : (P + S,) float64
        ``[theta; x]``: the pose (m, rad) and the ``S`` further parameters.
    vertices_m : (V, 3) float64
    vertices_jac : (V, 3, P + S) float64 or None
    fingertip_vertex_ids : (5,) int64
    """

    theta: FloatArray
    vertices_m: FloatArray
    vertices_jac: FloatArray | None
    fingertip_vertex_ids: IntArray

    @property
    def fingertips_m(self) -> FloatArray:
        """Fingertip vertices (5, 3) float64."""
        return self.vertices_m[self.fingertip_vertex_ids]
