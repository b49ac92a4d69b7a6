r"""Which fingertips show in a render: the vertex test with the depth slack of the tip cap.

A fingertip is the end of its finger (``HandModel.fingertip_vertex_ids``: the distal-bone
vertex farthest along the bone), a point of the tip cap, a sphere of radius :math:`r` (the
smallest sphere of the distal bone). The rasterizer's vertex test (:mod:`.rasterizer`: the
z-buffer in the 3 x 3 pixels around the projection at most 2 mm before the vertex) calls that
point hidden as soon as the finger tilts a few degrees away from the camera: the cap's own
front then lies up to :math:`2r` before it, while the rounded end of the finger still shows
within a pixel or two of the projection, where a fingertip detector fires. In 300 validation
views of the detector (``vision/detector/data.py``, seed 1) that was 167 of the 1172 tips
that show, 14 %.

A fingertip therefore *shows* when its projection rounds to a pixel inside the image and one
of the 3 x 3 pixels around it has a z-buffer depth of at least :math:`z - 2r` (background
counts as infinitely deep): the same test with the slack :math:`2r`. Every ray to the tip
meets the cap sphere at most :math:`2r` before it, so the wider slack adds the tips hidden
only by their own cap (:math:`2r` is 13-17 mm on the default hand). A tip behind another
part or deep behind its own finger stays hidden unless that occluder is less than :math:`2r`
before it; on the same views, requiring in addition that the pixel show the finger's own
distal bone (triangle ids) changed none of the 1500 tips.
"""
from __future__ import annotations

import numpy as np

from hand_tracker_ros._typing import BoolArray, FloatArray, IntArray
from hand_tracker_ros.model.hand import HandModel
from hand_tracker_ros.render.rasterizer import RenderResult, visible_with_slack


def cap_slack_m(model: HandModel) -> FloatArray:
    """Depth slack :math:`2r` (5,) float64 of each fingertip, in m (module docstring)."""
    bones = model.vertex_part[model.fingertip_vertex_ids]
    return np.array([2.0 * model.sphere_radii_m[model.sphere_part == b].min() for b in bones])


def visible_fingertips(raster: RenderResult, tip_ids: IntArray, slack_m: FloatArray
                       ) -> BoolArray:
    """Whether each fingertip shows in ``raster`` (module docstring).

    Parameters
    ----------
    raster : RenderResult
    tip_ids : (K,) int64
        Fingertip vertices.
    slack_m : (K,) float64
        Depth slack of each (:func:`cap_slack_m`), m; wider than the vertex test's, so every
        vertex that test finds visible shows. Tips nearer than the render's default near
        plane are hidden, as in the vertex test.

    Returns
    -------
    (K,) bool
    """
    return visible_with_slack(raster, tip_ids, slack_m)
