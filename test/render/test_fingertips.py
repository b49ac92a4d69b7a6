"""Fingertip visibility: the vertex test with the depth slack of the tip cap."""
from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from hand_tracker_ros.geometry.rig import CameraRig
from hand_tracker_ros.render.fingertips import cap_slack_m, visible_fingertips
from hand_tracker_ros.render.rasterizer import render
from hand_tracker_ros.vision.detector.data import _random_theta

SEED = 7   # neither the detector's training (0) nor its validation (1) seed


@pytest.fixture(scope='module')
def renders(hand_model):
    """Rasters of the 8 cameras of a ring around 6 random poses of SEED."""
    out = []
    for scene in range(6):
        rng = np.random.default_rng([SEED, scene])
        posed = hand_model.pose(_random_theta(rng, hand_model), jacobian=False)
        rig = CameraRig.ring(8, 320, 240, radius_m=0.45, fov_deg=50.0, seed=scene)
        out += [render(camera, posed.vertices_m, hand_model.faces) for camera in rig.cameras]
    return out


def _window(uv):
    u, v = (int(c) for c in np.rint(uv))
    return np.s_[max(v - 1, 0):v + 2, max(u - 1, 0):u + 2]


def test_the_slack_is_the_diameter_of_each_distal_bones_smallest_sphere(hand_model):
    slack = cap_slack_m(hand_model)
    assert slack.shape == (5,)
    for tip, s in zip(hand_model.fingertip_vertex_ids, slack):
        bone = hand_model.vertex_part[tip]
        radii = hand_model.sphere_radii_m[hand_model.sphere_part == bone]
        assert s == pytest.approx(2.0 * radii.min())
    assert np.all((slack > 0.010) & (slack < 0.020))   # 5-10 mm tip radii


def test_adds_tips_hidden_only_by_their_own_cap(hand_model, renders):
    tips, slack = hand_model.fingertip_vertex_ids, cap_slack_m(hand_model)
    added = 0
    for raster in renders:
        old = raster.visible_vertices[tips]
        new = visible_fingertips(raster, tips, slack)
        for k in np.flatnonzero(new & ~old):
            added += 1
            # What shows there is the finger's own distal bone (triangle ids).
            faces = raster.face_id[_window(raster.uv_px[tips[k]])]
            parts = hand_model.vertex_part[hand_model.faces[faces[faces >= 0], 0]]
            assert hand_model.vertex_part[tips[k]] in parts
    assert added > 0     # the case the rule is for occurs in a few random scenes


def test_the_slack_decides(hand_model, renders):
    tips, slack = hand_model.fingertip_vertex_ids, cap_slack_m(hand_model)
    raster, k = next((r, int(np.flatnonzero(~r.visible_vertices[tips]
                                            & visible_fingertips(r, tips, slack))[0]))
                     for r in renders
                     if np.any(~r.visible_vertices[tips] & visible_fingertips(r, tips, slack)))
    window = _window(raster.uv_px[tips[k]])
    for before, shows in ((0.9, True), (1.1, False)):
        depth = raster.depth_m.copy()
        depth[window] = raster.vertex_depth_m[tips[k]] - before * slack[k]
        moved = dataclasses.replace(raster, depth_m=depth)
        assert visible_fingertips(moved, tips, slack)[k] == shows
    # Projected outside the image: hidden whatever the depth.
    uv = raster.uv_px.copy()
    uv[tips[k]] = (-5.0, 10.0)
    assert not visible_fingertips(dataclasses.replace(raster, uv_px=uv), tips, slack)[k]
