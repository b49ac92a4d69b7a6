"""Synthetic multi-camera sequences with exact ground truth.

A sequence is a scripted motion (:mod:`.motions`) of the hand model seen by a rig of C
cameras (``CameraRig.ring``): per frame and camera, a shaded skin-coloured rendering over a
per-camera textured (optionally cluttered) background, plus Gaussian image noise. Everything is
a deterministic function of the config: frame ``k`` of camera ``c`` draws its noise from
``default_rng([seed, k, c])``, so frames can be produced in any order and twice identically.
"""
from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass
from functools import cached_property

import numpy as np

from hand_tracker_ros._typing import FloatArray, UInt8Array
from hand_tracker_ros.config import param
from hand_tracker_ros.geometry.rig import CameraRig
from hand_tracker_ros.model.hand import HandModel
from hand_tracker_ros.render.background import BackgroundConfig, make_background
from hand_tracker_ros.render.shading import render_rgb
from hand_tracker_ros.synthetic.motions import ALL_MOTIONS, trajectory

START_STAMP_NS = 1_700_000_000 * 10**9
_KINDS = ('noise', 'stripes', 'blobs')


@dataclass(frozen=True)
class SynthConfig:
    """A synthetic sequence."""

    motion: str = param('grasp', 'scripted motion', choices=ALL_MOTIONS)
    n_frames: int = param(120, 'number of frames', low=1, high=100000)
    fps: float = param(30.0, 'frame rate', unit='Hz', low=1.0, high=1000.0)
    n_cameras: int = param(4, 'cameras of the ring rig', low=1, high=8)
    width: int = param(320, 'image width', unit='px', low=16, high=4096)
    height: int = param(240, 'image height', unit='px', low=16, high=4096)
    radius_m: float = param(0.4, 'camera distance to the rig centre', unit='m', low=0.1,
                            high=5.0)
    fov_deg: float = param(50.0, 'horizontal field of view', unit='deg', low=5.0, high=170.0)
    noise_sigma: float = param(3.0, 'Gaussian image noise (std, gray levels)', low=0.0,
                               high=100.0)
    clutter: int = param(6, 'cluttering shapes per background', low=0, high=500)
    seed: int = param(0, 'seed of backgrounds, noise and the random motion', low=0)


@dataclass(frozen=True, eq=False)
class SyntheticFrame:
    """One frame: ground truth and the C camera images."""

    index: int
    stamp_ns: int
    theta: FloatArray          # (P,) ground-truth pose
    keypoints_m: FloatArray    # (21, 3) ground-truth 3D keypoints, world frame
    fingertips_m: FloatArray   # (5, 3) fingertip surface points, world frame
    images: tuple[UInt8Array, ...]   # C x (H, W, 3) rgb8


class SyntheticSequence:
    """Deterministic frames of one :class:`SynthConfig`."""

    def __init__(self, config: SynthConfig = SynthConfig(),
                 model: HandModel | None = None) -> None:
        self.config = config
        self.model = model or HandModel.build()
        self.rig = CameraRig.ring(config.n_cameras, config.width, config.height,
                                  radius_m=config.radius_m, fov_deg=config.fov_deg)
        self.thetas = trajectory(config.motion, config.n_frames, config.fps, seed=config.seed,
                                 model=self.model)

    def __len__(self) -> int:
        return self.config.n_frames

    @cached_property
    def backgrounds(self) -> tuple[UInt8Array, ...]:
        """One static background per camera (kind cycles through the texture kinds)."""
        cfg = self.config
        return tuple(make_background(cfg.width, cfg.height, seed=cfg.seed * 1000 + c,
                                     config=BackgroundConfig(kind=_KINDS[c % len(_KINDS)],
                                                             n_clutter=cfg.clutter))
                     for c in range(cfg.n_cameras))

    def stamp_ns(self, k: int) -> int:
        """Stamp of frame ``k`` (ns)."""
        return START_STAMP_NS + round(k * 1e9 / self.config.fps)

    def frame(self, k: int) -> SyntheticFrame:
        """Render frame ``k``."""
        posed = self.model.pose(self.thetas[k], jacobian=False)
        images = []
        for c, camera in enumerate(self.rig.cameras):
            image = render_rgb(camera, posed.vertices_m, self.model.faces, posed.vertex_normals,
                               self.backgrounds[c], seed=self.config.seed)
            if self.config.noise_sigma > 0.0:
                rng = np.random.default_rng([self.config.seed, k, c])
                noise = rng.normal(0.0, self.config.noise_sigma, image.shape)
                image = np.clip(np.rint(image + noise), 0, 255).astype(np.uint8)
            images.append(image)
        return SyntheticFrame(k, self.stamp_ns(k), self.thetas[k].copy(), posed.keypoints_m,
                              posed.fingertips_m, tuple(images))

    def __iter__(self) -> Iterator[SyntheticFrame]:
        return (self.frame(k) for k in range(len(self)))
