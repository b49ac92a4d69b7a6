"""Tests of the model contour points (outer / inner) and the model edge image."""
from __future__ import annotations

import cv2
import numpy as np
import trimesh

from hand_tracker_ros.geometry.rig import CameraRig
from hand_tracker_ros.render.contours import MeshEdges, contour_points, edge_image, front_facing
from hand_tracker_ros.render.rasterizer import render


def _sphere() -> trimesh.Trimesh:
    return trimesh.creation.icosphere(subdivisions=4, radius=0.05)


def _crossed_capsules(cam_center: np.ndarray) -> trimesh.Trimesh:
    """Two capsules crossing in an X, one 3 cm nearer the camera than the other."""
    towards = cam_center / np.linalg.norm(cam_center)
    parts = []
    for angle, shift in ((0.4, 0.03), (-0.4, -0.01)):
        part = trimesh.creation.capsule(height=0.12, radius=0.012, count=[24, 24])
        part.apply_transform(trimesh.transformations.rotation_matrix(np.pi / 2, [0, 1, 0]))
        part.apply_transform(trimesh.transformations.rotation_matrix(angle, [0, 0, 1]))
        parts.append(part.apply_translation(shift * towards))
    return trimesh.util.concatenate(parts)


def test_sphere_contour_is_outer_and_points_outwards():
    cam = CameraRig.ring(4, 320, 240)[1]
    mesh = _sphere()
    raster = render(cam, mesh.vertices, mesh.faces)
    contour = contour_points(cam, mesh.vertices, MeshEdges.from_faces(mesh.faces), raster)
    assert len(contour.vertex_ids) > 50
    assert contour.is_outer.all()
    centre_px = cam.project(np.zeros((1, 3)))[0][0]
    radial = contour.uv_px - centre_px
    radial /= np.linalg.norm(radial, axis=1, keepdims=True)
    np.testing.assert_allclose(np.linalg.norm(contour.normals_px, axis=1), 1.0, atol=1e-12)
    assert np.einsum('ij,ij->i', contour.normals_px, radial).min() > 0.95
    # The points lie on the silhouette: the projected sphere radius.
    radius_px = np.linalg.norm(contour.uv_px - centre_px, axis=1)
    boundary = np.sqrt(raster.mask.sum() / np.pi)
    np.testing.assert_allclose(radius_px, boundary, rtol=0.03)


def test_crossed_capsules_have_inner_contour_points():
    cam = CameraRig.ring(4, 320, 240)[0]
    mesh = _crossed_capsules(cam.center_world)
    raster = render(cam, mesh.vertices, mesh.faces)
    edges = MeshEdges.from_faces(mesh.faces)
    contour = contour_points(cam, mesh.vertices, edges, raster)
    inner = ~contour.is_outer
    assert inner.sum() >= 5 and contour.is_outer.sum() > 50
    # Just outside an inner point lies the other capsule, mostly farther from the camera
    # (nearer only where the back capsule's contour runs under the front one).
    probe = np.rint(contour.uv_px[inner] + 2.5 * contour.normals_px[inner]).astype(int)
    assert raster.mask[probe[:, 1], probe[:, 0]].all()
    behind = raster.depth_m[probe[:, 1], probe[:, 0]]
    assert (behind > raster.vertex_depth_m[contour.vertex_ids[inner]] + 0.005).mean() > 0.6
    # Every point is a visible vertex of an edge between a front and a back triangle.
    front = front_facing(cam, mesh.vertices, edges.faces)[edges.faces_of_edge]
    generator = np.unique(edges.vertices[front[:, 0] != front[:, 1]])
    assert np.isin(contour.vertex_ids, generator).all()
    assert raster.visible_vertices[contour.vertex_ids].all()
    # Step inwards from an outer point: the model is there.
    outer = contour.is_outer
    inside = np.rint(contour.uv_px[outer] - 2.0 * contour.normals_px[outer]).astype(int)
    assert raster.mask[inside[:, 1], inside[:, 0]].mean() > 0.95


def test_edge_image_has_silhouette_and_depth_edges():
    cam = CameraRig.ring(4, 320, 240)[0]
    kernel = np.array([[0, 1, 0], [1, 1, 1], [0, 1, 0]], np.uint8)
    sphere = _sphere()
    raster = render(cam, sphere.vertices, sphere.faces)
    boundary = raster.mask & ~cv2.erode(raster.mask.astype(np.uint8), kernel).astype(bool)
    edges = edge_image(raster)
    assert (edges >= boundary).all()
    assert (edges <= cv2.dilate(boundary.astype(np.uint8), kernel).astype(bool)).all()
    capsules = _crossed_capsules(cam.center_world)
    raster = render(cam, capsules.vertices, capsules.faces)
    boundary = raster.mask & ~cv2.erode(raster.mask.astype(np.uint8), kernel).astype(bool)
    far_from_boundary = ~cv2.dilate(boundary.astype(np.uint8), np.ones((5, 5), np.uint8))
    assert (edge_image(raster) & far_from_boundary.astype(bool)).sum() > 20


def test_no_contour_when_the_mesh_is_behind_the_camera():
    cam = CameraRig.ring(1)[0]
    mesh = _sphere().apply_translation(2.0 * cam.center_world)
    raster = render(cam, mesh.vertices, mesh.faces)
    contour = contour_points(cam, mesh.vertices, MeshEdges.from_faces(mesh.faces), raster)
    assert contour.vertex_ids.shape == (0,) and contour.normals_px.shape == (0, 2)
    assert not edge_image(raster).any()


def _reference_contour(cam, vertices, edges, raster):
    """The plain numpy form of the contour kernels: (ids, normals)."""
    v0, v1, v2 = (vertices[edges.faces[:, k]] for k in range(3))
    front = np.einsum('ij,ij->i', np.cross(v1 - v0, v2 - v0), cam.center_world - v0) > 0.0
    side = front[edges.faces_of_edge]
    on_contour = side[:, 0] != side[:, 1]
    a, b = edges.vertices[on_contour].T
    o = np.where(side[on_contour, 0], edges.opposite[on_contour, 0],
                 edges.opposite[on_contour, 1])
    uv = raster.uv_px
    t = uv[b] - uv[a]
    n = np.column_stack([t[:, 1], -t[:, 0]])
    n *= -np.sign(np.einsum('ij,ij->i', n, uv[o] - uv[a]))[:, None]
    length = np.linalg.norm(n, axis=1, keepdims=True)
    n = np.divide(n, length, out=np.zeros_like(n), where=length > 1e-9)
    ends = np.concatenate([a, b])
    acc = np.column_stack([np.bincount(ends, np.tile(n[:, k], 2), minlength=uv.shape[0])
                           for k in range(2)])
    ids = np.unique(ends)
    ids = ids[raster.visible_vertices[ids] & (np.linalg.norm(acc[ids], axis=1) > 1e-9)]
    return ids, acc[ids] / np.linalg.norm(acc[ids], axis=1, keepdims=True), front


def test_contour_kernels_match_the_numpy_reference():
    from hand_tracker_ros.model.hand import HandModel
    model = HandModel.build()
    rng = np.random.default_rng(3)
    theta = model.neutral_theta((0.0, 0.0, 0.0))
    theta[6:] += rng.uniform(-0.2, 0.2, theta.size - 6)
    verts = model.pose(np.clip(theta, model.lower, model.upper), jacobian=False).vertices_m
    edges = MeshEdges.from_faces(model.faces)
    for cam in CameraRig.ring(4, 320, 240):
        raster = render(cam, verts, model.faces)
        contour = contour_points(cam, verts, edges, raster)
        ids, normals, front = _reference_contour(cam, verts, edges, raster)
        np.testing.assert_array_equal(front_facing(cam, verts, edges.faces), front)
        np.testing.assert_array_equal(contour.vertex_ids, ids)
        np.testing.assert_allclose(contour.normals_px, normals, rtol=0, atol=1e-14)
