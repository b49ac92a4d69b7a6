"""Tests of the shaded RGB renderer and the synthetic backgrounds."""
from __future__ import annotations

import cv2
import numpy as np
import pytest
import trimesh

from hand_tracker_ros.errors import ConfigError, ImageFormatError
from hand_tracker_ros.geometry.rig import CameraRig
from hand_tracker_ros.render.background import BackgroundConfig, make_background
from hand_tracker_ros.render.rasterizer import RenderConfig, render
from hand_tracker_ros.render.shading import ShadingConfig, render_rgb


def _scene() -> tuple:
    cam = CameraRig.ring(4, 320, 240)[2]
    sphere = trimesh.creation.icosphere(subdivisions=4, radius=0.05)
    return cam, sphere


def test_render_rgb_composites_lit_skin_over_the_background():
    cam, sphere = _scene()
    background = make_background(320, 240, seed=3)
    image = render_rgb(cam, sphere.vertices, sphere.faces, sphere.vertex_normals, background,
                       seed=5)
    mask = render(cam, sphere.vertices, sphere.faces).mask
    assert image.shape == (240, 320, 3) and image.dtype == np.uint8
    np.testing.assert_array_equal(image[~mask], background[~mask])
    skin = image[mask].astype(float)
    assert (skin[:, 0] > skin[:, 2]).mean() > 0.99  # reddish, never the background's random hue
    # The light comes from above (y = -0.6 in the camera frame): the upper half is brighter.
    rows = np.nonzero(mask)[0]
    middle = np.median(rows)
    grey = image.astype(float).sum(axis=2)
    assert grey[mask & (np.arange(240)[:, None] < middle)].mean() > \
        grey[mask & (np.arange(240)[:, None] > middle)].mean() + 30.0


def test_render_rgb_refuses_a_raster_without_triangle_ids():
    cam, sphere = _scene()
    raster = render(cam, sphere.vertices, sphere.faces, RenderConfig(face_ids=False))
    with pytest.raises(ValueError, match='face_ids=True'):
        render_rgb(cam, sphere.vertices, sphere.faces, sphere.vertex_normals,
                   make_background(320, 240, seed=3), raster=raster)


def test_render_rgb_is_deterministic_per_seed():
    cam, sphere = _scene()
    background = make_background(320, 240, seed=0)
    args = (cam, sphere.vertices, sphere.faces, sphere.vertex_normals, background)
    a, b, c = render_rgb(*args, seed=1), render_rgb(*args, seed=1), render_rgb(*args, seed=2)
    assert a.tobytes() == b.tobytes() and a.tobytes() != c.tobytes()
    flat = render_rgb(*args, seed=1, config=ShadingConfig(albedo_sigma=0.0))
    assert flat.tobytes() != a.tobytes()


def test_render_rgb_rejects_a_background_of_the_wrong_size():
    cam, sphere = _scene()
    with pytest.raises(ImageFormatError, match=r'`background` must be \(240, 320, 3\) uint8'):
        render_rgb(cam, sphere.vertices, sphere.faces, sphere.vertex_normals,
                   np.zeros((120, 160, 3), np.uint8))


@pytest.mark.parametrize('kind', ['noise', 'stripes', 'blobs'])
def test_backgrounds_are_deterministic_textured_images(kind):
    config = BackgroundConfig(kind=kind)
    a = make_background(160, 120, seed=4, config=config)
    assert a.shape == (120, 160, 3) and a.dtype == np.uint8
    assert a.tobytes() == make_background(160, 120, seed=4, config=config).tobytes()
    assert a.tobytes() != make_background(160, 120, seed=5, config=config).tobytes()
    assert a.reshape(-1, 3).std(axis=0).max() > 5.0  # textured, not flat


def test_clutter_adds_strong_edges_and_skin_distractors():
    plain = make_background(320, 240, seed=1)
    cluttered = make_background(320, 240, seed=1,
                                config=BackgroundConfig(n_clutter=40, skin_fraction=0.5))
    edges = [cv2.Canny(cv2.cvtColor(img, cv2.COLOR_RGB2GRAY), 50, 150).sum()
             for img in (plain, cluttered)]
    assert edges[1] > 3 * edges[0] + 1000
    skin = np.array([224.0, 172.0, 145.0])
    near_skin = np.linalg.norm(cluttered.astype(float) - skin, axis=2) < 30.0
    assert near_skin.sum() > 100


def test_bad_background_requests_are_rejected():
    with pytest.raises(ConfigError, match="`kind` must be one of .* got 'plaid'"):
        make_background(32, 24, config=BackgroundConfig(kind='plaid'))
    with pytest.raises(ConfigError, match='must be positive, got 0x24'):
        make_background(0, 24)
