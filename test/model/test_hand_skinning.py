"""Linear-blend skinning and its analytic vertex Jacobian."""
from __future__ import annotations

import numpy as np
import pytest
import trimesh


@pytest.mark.parametrize('seed', [0, 1])
def test_vertex_jacobian_matches_central_difference(model, random_theta, numeric_jacobian,
                                                    seed: int) -> None:
    theta = random_theta(np.random.default_rng(100 + seed))
    posed = model.pose(theta)
    numeric = numeric_jacobian(lambda t: model.pose(t, jacobian=False).vertices_m, theta)
    np.testing.assert_allclose(posed.vertices_jac, numeric, rtol=1e-5, atol=1e-8)


def test_jacobian_and_plain_skinning_agree(model, random_theta) -> None:
    theta = random_theta(np.random.default_rng(9))
    np.testing.assert_allclose(model.pose(theta).vertices_m,
                               model.pose(theta, jacobian=False).vertices_m, atol=1e-15)


def test_rest_pose_reproduces_rest_mesh(model) -> None:
    np.testing.assert_allclose(model.pose(np.zeros(26), jacobian=False).vertices_m,
                               model.rest_vertices_m, atol=1e-14)


def test_rigid_motion_is_rigid(model) -> None:
    theta = np.zeros(26)
    theta[:6] = [0.1, 0.2, -0.3, 0.5, -1.0, 2.0]
    verts = model.pose(theta, jacobian=False).vertices_m
    rest = model.rest_vertices_m
    d_rest = np.linalg.norm(rest[:100] - rest[100:200], axis=1)
    np.testing.assert_allclose(np.linalg.norm(verts[:100] - verts[100:200], axis=1), d_rest,
                               atol=1e-12)


def test_vertex_normals_are_area_weighted_and_outward(model, random_theta) -> None:
    posed = model.pose(random_theta(np.random.default_rng(4)), jacobian=False)
    tri = posed.vertices_m[model.faces]
    face_n = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])   # 2 * area * normal
    ref = np.zeros_like(posed.vertices_m)
    for c in range(3):
        np.add.at(ref, model.faces[:, c], face_n)
    ref /= np.linalg.norm(ref, axis=1, keepdims=True)
    np.testing.assert_allclose(posed.vertex_normals, ref, atol=1e-9)
    mesh = trimesh.Trimesh(posed.vertices_m, model.faces, process=False)
    assert np.median(np.sum(posed.vertex_normals * mesh.vertex_normals, axis=1)) > 0.99
