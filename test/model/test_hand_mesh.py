"""Sphere-mesh distance, mesh construction, skinning weights, fingertips, adjacency."""
from __future__ import annotations

import numpy as np
import trimesh

from hand_tracker_ros.model.hand import HandModel
from hand_tracker_ros.model.kinematics import rest_transforms
from hand_tracker_ros.model.mesh import build_surface
from hand_tracker_ros.model.shape import HandShape
from hand_tracker_ros.model.skeleton import BONE_PARENTS, rest_skeleton
from hand_tracker_ros.model.spheremesh import (
    build_sphere_mesh,
    part_distances,
    round_cone_distance,
)


def test_round_cone_distance_matches_sampled_balls() -> None:
    rng = np.random.default_rng(5)
    a, b, ra, rb = np.zeros(3), np.array([0.0, 0.04, 0.01]), 0.010, 0.006
    pts = rng.uniform(-0.03, 0.06, size=(400, 3))
    u = np.linspace(0.0, 1.0, 4001)[:, None]
    centers, radii = (1 - u) * a + u * b, (1 - u[:, 0]) * ra + u[:, 0] * rb
    brute = np.min(np.linalg.norm(pts[:, None] - centers[None], axis=2) - radii, axis=1)
    got = round_cone_distance(pts, a, b, ra, rb)
    outside = brute > 0
    np.testing.assert_allclose(got[outside], brute[outside], atol=1e-7)
    assert np.array_equal(got < 0, brute < 0)


def test_mesh_is_watertight_and_in_budget(model: HandModel) -> None:
    mesh = trimesh.Trimesh(model.rest_vertices_m, model.faces, process=False)
    assert mesh.is_watertight and mesh.is_winding_consistent
    assert mesh.volume > 0.0 and mesh.euler_number == 2
    assert 2000 <= len(model.rest_vertices_m) <= 8000
    assert model.faces.dtype == np.int32


def test_mesh_surface_lies_on_the_sphere_mesh(model: HandModel) -> None:
    rest = rest_skeleton(model.shape)
    sm = build_sphere_mesh(rest, rest_transforms(rest))
    dist = part_distances(model.rest_vertices_m, sm, 16).min(axis=1)
    assert np.max(np.abs(dist)) < 1.5e-3          # grid 3.3 mm + smoothing


def test_skin_weights(model: HandModel) -> None:
    w = model.skin_weights
    np.testing.assert_allclose(w.sum(axis=1), 1.0, atol=1e-12)
    assert np.all(w >= 0.0) and np.max(np.count_nonzero(w, axis=1)) <= 4
    assert np.array_equal(np.argmax(w, axis=1), model.vertex_part)
    # Some vertices blend across joints, and blends only pair parent and child bones.
    blended = np.flatnonzero(np.count_nonzero(w, axis=1) > 1)
    assert blended.size > 200
    for v in blended[::25]:
        bones = np.flatnonzero(w[v])
        main = model.vertex_part[v]
        for b in bones:
            assert b == main or BONE_PARENTS[b] == main or BONE_PARENTS[main] == b
    assert np.all(np.bincount(model.vertex_part, minlength=16) > 50)


def test_fingertips_are_farthest_along_their_finger(model: HandModel) -> None:
    rest_t = model.rest_bone_transforms
    for i, vid in enumerate(model.fingertip_vertex_ids):
        distal = 1 + 3 * i + 2
        in_finger = np.isin(model.vertex_part, [distal - 2, distal - 1, distal])
        reach = (model.rest_vertices_m - rest_t[distal, :3, 3]) @ rest_t[distal, :3, 1]
        assert vid == np.flatnonzero(in_finger)[np.argmax(reach[in_finger])]
    tips = model.pose(np.zeros(26), jacobian=False)
    # The tip sphere is tangent to the tip keypoint; the mesh reaches it up to the grid
    # (3.3 mm) and smoothing error.
    np.testing.assert_allclose(tips.fingertips_m, tips.keypoints_m[4::4], atol=2.5e-3)


def test_adjacency_is_symmetric_with_parents(model: HandModel) -> None:
    adj = model.adjacent_parts
    assert np.array_equal(adj, adj.T) and np.all(np.diag(adj))
    for b, p in enumerate(BONE_PARENTS):
        assert p < 0 or adj[b, p]
    names = model.part_names
    assert not adj[names.index('index_distal'), names.index('middle_distal')]


def test_build_is_deterministic() -> None:
    rest = rest_skeleton(HandShape())
    sm = build_sphere_mesh(rest, rest_transforms(rest))
    a, b = build_surface(sm, 1.0), build_surface(sm, 1.0)
    assert np.array_equal(a.vertices, b.vertices) and np.array_equal(a.faces, b.faces)


def test_global_scale_scales_the_mesh(model: HandModel) -> None:
    big = HandModel.build(HandShape(scale=1.2))
    ext0 = np.ptp(model.rest_vertices_m, axis=0)
    np.testing.assert_allclose(np.ptp(big.rest_vertices_m, axis=0), 1.2 * ext0, rtol=0.01)
    np.testing.assert_allclose(big.sphere_radii_m, 1.2 * model.sphere_radii_m, rtol=1e-12)


def test_longer_middle_finger_moves_only_its_tip(model: HandModel) -> None:
    shape = model.shape.replace(middle_m=tuple(1.1 * x for x in model.shape.middle_m))
    long = HandModel.build(shape)
    a = model.pose(np.zeros(26), jacobian=False)
    b = long.pose(np.zeros(26), jacobian=False)
    extra = 0.1 * sum(model.shape.middle_m)
    assert b.fingertips_m[2, 1] - a.fingertips_m[2, 1] > 0.8 * extra
    np.testing.assert_allclose(b.fingertips_m[[0, 1, 3, 4]], a.fingertips_m[[0, 1, 3, 4]],
                               atol=1e-3)
