"""Labelled synthetic views for training and evaluating the fingertip detector.

A *scene* is one random hand pose seen by a few cameras of a random ring rig; each camera
view gets its own random background, lighting and image noise. Everything is drawn from
``np.random.default_rng([seed, scene])``, so views can be regenerated in any order and a
different ``seed`` gives disjoint poses, rigs, backgrounds and noise (training and held-out
evaluation use different seeds).

Randomised per scene / view (ranges are ours, chosen to cover the synthetic sequences and a
margin around them):

- pose: a random frame of a random scripted or random motion, plus a global rotation offset
  (+-35 deg about each hinge) and wrist offset (+-4 cm);
- rig: ``CameraRig.ring`` of 8 cameras, radius 0.35-0.6 m, field of view 45-60 deg, a random
  placement seed; ``cameras_per_scene`` distinct cameras are used;
- background: kind, 0-12 clutter shapes of which 0-50 % skin-coloured, seed;
- shading: light direction, ambient 0.25-0.45, skin colour +-8 % per channel, albedo seed;
- noise: Gaussian, sigma 0-6 gray levels.

Ground truth per view: the projection of each fingertip vertex and whether the tip shows in
the image (:func:`hand_tracker_ros.render.fingertips.visible_fingertips`: the vertex test with
the depth slack of the tip cap, which the tracker's salient term uses too).
"""
from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass

import numpy as np

from hand_tracker_ros._typing import BoolArray, FloatArray, UInt8Array
from hand_tracker_ros.geometry.rig import CameraRig
from hand_tracker_ros.model.hand import HandModel
from hand_tracker_ros.model.layout import Layout
from hand_tracker_ros.render.background import BackgroundConfig, make_background
from hand_tracker_ros.render.fingertips import cap_slack_m, visible_fingertips
from hand_tracker_ros.render.rasterizer import render
from hand_tracker_ros.render.shading import ShadingConfig, render_rgb
from hand_tracker_ros.synthetic.motions import MOTIONS, trajectory
from hand_tracker_ros.vision.detector.creases import crease_weights

_KINDS = ('noise', 'stripes', 'blobs')
_BASE_SKIN = np.array([224.0, 172.0, 145.0])
_RING_CAMERAS = 8
_MOTION_FRAMES = 90


@dataclass(frozen=True, eq=False)
class LabelledView:
    """One rendered camera view with its fingertip ground truth.

    Attributes
    ----------
    image : (H, W, 3) uint8
        rgb8 image.
    hand_mask : (H, W) bool
        Pixels covered by the hand.
    tips_uv : (5, 2) float64
        Projections of the fingertip vertices (px), FINGER_NAMES order.
    tips_visible : (5,) bool
        The tip shows in the image (module docstring).
    """

    image: UInt8Array
    hand_mask: BoolArray
    tips_uv: FloatArray
    tips_visible: BoolArray


def _random_theta(rng: np.random.Generator, model: HandModel) -> FloatArray:
    motion = str(rng.choice(MOTIONS))
    thetas = trajectory(motion, _MOTION_FRAMES, 30.0, seed=int(rng.integers(2**31)))
    theta = thetas[int(rng.integers(_MOTION_FRAMES))].copy()
    theta[Layout.translation] += rng.uniform(-0.04, 0.04, 3)
    theta[3:6] += np.deg2rad(rng.uniform(-35.0, 35.0, 3))
    return np.clip(theta, model.lower, model.upper)


def _shading(rng: np.random.Generator) -> ShadingConfig:
    ambient = rng.uniform(0.25, 0.45)
    light = (rng.uniform(-0.8, 0.8), rng.uniform(-0.8, 0.8), -1.0)
    skin = _BASE_SKIN * rng.uniform(0.92, 1.08, 3)
    return ShadingConfig(skin_rgb=tuple(float(c) for c in np.clip(skin, 0.0, 255.0)),
                         ambient=ambient, diffuse=1.0 - ambient, light_dir_cam=light)


def _background(rng: np.random.Generator, width: int, height: int) -> UInt8Array:
    config = BackgroundConfig(kind=str(rng.choice(_KINDS)), n_clutter=int(rng.integers(0, 13)),
                              skin_fraction=float(rng.uniform(0.0, 0.5)))
    return make_background(width, height, seed=int(rng.integers(2**31)), config=config)


def scene_views(model: HandModel, seed: int, scene: int, *, cameras_per_scene: int = 3,
                width: int = 320, height: int = 240,
                crease_depth: tuple[float, float] = (0.0, 0.0)) -> list[LabelledView]:
    r"""The views of one random scene (deterministic in ``(seed, scene)``).

    With ``crease_depth = (lo, hi)``, ``hi > 0``, each view's skin is darkened along the
    creases of :mod:`.creases` by a factor :math:`1 - d w_v`, :math:`d \sim U(lo, hi)` drawn
    from a generator of its own, so that everything else in the views stays as without.
    """
    rng = np.random.default_rng([seed, scene])
    crease_rng = np.random.default_rng([seed, scene, 1])
    weights = crease_weights(model) if crease_depth[1] > 0.0 else None
    posed = model.pose(_random_theta(rng, model), jacobian=False)
    rig = CameraRig.ring(_RING_CAMERAS, width, height, radius_m=rng.uniform(0.35, 0.6),
                         fov_deg=rng.uniform(45.0, 60.0), seed=int(rng.integers(2**31)))
    picks = rng.choice(_RING_CAMERAS, cameras_per_scene, replace=False)
    tips, slack_m = model.fingertip_vertex_ids, cap_slack_m(model)
    views = []
    for c in picks:
        camera = rig.cameras[int(c)]
        raster = render(camera, posed.vertices_m, model.faces)
        gain = None if weights is None else 1.0 - crease_rng.uniform(*crease_depth) * weights
        image = render_rgb(camera, posed.vertices_m, model.faces, posed.vertex_normals,
                           _background(rng, width, height), seed=int(rng.integers(2**31)),
                           raster=raster, config=_shading(rng), albedo_gain=gain)
        noisy = image + rng.normal(0.0, rng.uniform(0.0, 6.0), image.shape)
        views.append(LabelledView(np.clip(np.rint(noisy), 0, 255).astype(np.uint8),
                                  raster.mask, raster.uv_px[tips].copy(),
                                  visible_fingertips(raster, tips, slack_m)))
    return views


def labelled_views(n_views: int, seed: int, *, model: HandModel | None = None,
                   cameras_per_scene: int = 3, width: int = 320, height: int = 240,
                   first_scene: int = 0, crease_depth: tuple[float, float] = (0.0, 0.0)
                   ) -> Iterator[LabelledView]:
    """``n_views`` labelled views of consecutive scenes of ``seed``, from ``first_scene`` on
    (``crease_depth``: :func:`scene_views`)."""
    model = model or HandModel.build()
    produced, scene = 0, first_scene
    while produced < n_views:
        for view in scene_views(model, seed, scene, cameras_per_scene=cameras_per_scene,
                                width=width, height=height,
                                crease_depth=crease_depth)[:n_views - produced]:
            produced += 1
            yield view
        scene += 1
