r"""Skin creases on the palmar side of the fingers, for the detector's training renders.

Real fingers show dark lines across their palmar side at the interphalangeal joints and at
their base, where the finger leaves the palm. The renders have none, and networks trained on
them fired at those lines in real photos (``bench/bench_real_hands.py``): a dark curve across
a finger bounds a bright rounded region, as a fingertip's outline does. Training views can
therefore darken the skin along those lines (:func:`crease_weights`, applied by
:mod:`.data` as a per-vertex albedo factor :math:`1 - d\,w_v`, :math:`d` drawn per view).

Each crease is a plane across a finger bone in the rest pose (theta = 0): through the joint
at the proximal end of the middle and distal bones of each finger (PIP, DIP) and of the
thumb's proximal and distal bones (MCP, IP), and at ``base_fraction`` of each finger's
proximal bone from its joint (the digital crease, at the web between the fingers). A vertex
of the bones next to a crease (both joint bones; the palm and the proximal bone for the base
crease, whose web vertices may belong to the palm), at distance :math:`s` (m) from its plane
along the bone axis and with rest normal :math:`\hat n`, gets

.. math:: w_v = \exp(-s^2 / 2\sigma^2)\,
          \mathrm{clip}((\hat n \cdot \hat p - 0.2) / 0.3, 0, 1),

with :math:`\sigma` = ``width_m`` and :math:`\hat p` the finger's palmar direction: where its
tip moves when its last joint flexes from the rest pose. The crease positions are ours (the
joints, and 0.3 of the proximal bone for the web), not measured on any photo.
"""
from __future__ import annotations

import numpy as np

from hand_tracker_ros._typing import FloatArray
from hand_tracker_ros.model.hand import HandModel
from hand_tracker_ros.model.layout import PARAM_NAMES, P
from hand_tracker_ros.model.skinning import vertex_normals

_FINGERS = ('thumb', 'index', 'middle', 'ring', 'pinky')
_FLEX_STEP_RAD = 0.1


def _palmar_directions(model: HandModel) -> FloatArray:
    """Unit direction (5, 3) in which each fingertip moves as its last joint flexes (m/m)."""
    rest = np.zeros(P)
    tips = model.pose(rest, jacobian=False).fingertips_m
    out = np.zeros((5, 3))
    for i, finger in enumerate(_FINGERS):
        theta = rest.copy()
        theta[PARAM_NAMES.index(f'{finger}_{"ip" if i == 0 else "dip"}_flex')] = _FLEX_STEP_RAD
        step = model.pose(theta, jacobian=False).fingertips_m[i] - tips[i]
        out[i] = step / np.linalg.norm(step)
    return out


def crease_weights(model: HandModel, width_m: float = 0.0015,
                   base_fraction: float = 0.3) -> FloatArray:
    """Crease weight :math:`w_v` (V,) float64 in [0, 1] of every mesh vertex (module
    docstring)."""
    transforms = model.rest_bone_transforms
    normals = vertex_normals(model.rest_vertices_m, model.faces)
    palmar = _palmar_directions(model)
    weights = np.zeros(len(model.rest_vertices_m))
    for i in range(5):
        proximal, middle, distal = 1 + 3 * i, 2 + 3 * i, 3 + 3 * i
        # (bone whose frame holds the plane, offset along its axis (m), the two bones)
        planes = [(middle, 0.0, (proximal, middle)), (distal, 0.0, (middle, distal))]
        if i > 0:
            length = np.linalg.norm(transforms[middle][:3, 3] - transforms[proximal][:3, 3])
            planes.append((proximal, base_fraction * length, (0, proximal)))
        side = np.clip((normals @ palmar[i] - 0.2) / 0.3, 0.0, 1.0)
        for bone, offset, parts in planes:
            s = (model.rest_vertices_m - transforms[bone][:3, 3]) @ transforms[bone][:3, 1]
            near = np.exp(-0.5 * ((s - offset) / width_m) ** 2) * side
            near[~np.isin(model.vertex_part, parts)] = 0.0
            weights = np.maximum(weights, near)
    return weights
