"""Tests of the z-buffer rasterizer against exact ray casting (ray_oracle) and analytic
cases."""
from __future__ import annotations

import cv2
import numpy as np
import pytest
import trimesh
from ray_oracle import (
    occlusion_by_rays,
    occlusion_by_rays_trimesh,
    random_parts_mesh,
    ray_cast,
    ray_cast_trimesh,
)
from scipy.spatial.transform import Rotation

from hand_tracker_ros.errors import ShapeError
from hand_tracker_ros.geometry.camera import PinholeCamera
from hand_tracker_ros.geometry.rig import CameraRig
from hand_tracker_ros.model.hand import HandModel
from hand_tracker_ros.render.rasterizer import RenderConfig, render

MILD_DISTORTION = np.array([-0.15, 0.1, 0.002, -0.001, -0.03])
NO_CULL = RenderConfig(cull_back_faces=False)


def _camera(index: int, distorted: bool, width: int = 80, height: int = 60,
            fov_deg: float = 25.0) -> PinholeCamera:
    cam = CameraRig.ring(4, width, height, fov_deg=fov_deg, seed=index)[index]
    dist = MILD_DISTORTION if distorted else np.zeros(5)
    return PinholeCamera(cam.name, width, height, cam.K, dist, cam.T_cam_world)


def _assert_matches_ray_casting(cam: PinholeCamera, vertices: np.ndarray,
                                faces: np.ndarray) -> None:
    mesh = trimesh.Trimesh(vertices, faces, process=False)
    depth_ref, face_ref = ray_cast(cam, mesh)
    result = render(cam, vertices, faces)
    hit_ref = np.isfinite(depth_ref)
    assert hit_ref.sum() > 150, 'the mesh must cover a meaningful part of the image'
    assert (hit_ref == result.mask).mean() >= 0.99
    both = hit_ref & result.mask
    assert np.abs(depth_ref[both] - result.depth_m[both]).max() <= 0.5e-3
    assert (face_ref[both] == result.face_id[both]).mean() >= 0.97


@pytest.mark.parametrize('distorted', [False, True], ids=['pinhole', 'distorted'])
def test_the_ray_casting_oracle_equals_trimesh(distorted):
    """The exact ray-triangle oracles (conftest.ray_cast, occlusion_by_rays) against trimesh's
    ray caster, on every pixel of a small view and every 16th vertex."""
    mesh = random_parts_mesh(np.random.default_rng(5))
    cam = _camera(1, distorted, width=48, height=36)
    depth, face = ray_cast(cam, mesh)
    depth_ref, face_ref = ray_cast_trimesh(cam, mesh)
    assert np.isfinite(depth_ref).sum() > 150
    np.testing.assert_array_equal(np.isfinite(depth), np.isfinite(depth_ref))
    hit = np.isfinite(depth_ref)
    np.testing.assert_allclose(depth[hit], depth_ref[hit], atol=1e-9)
    assert (face[hit] == face_ref[hit]).mean() >= 0.99      # ties on shared edges may differ
    some = mesh.vertices[::16]
    occlusion = occlusion_by_rays(cam, some, mesh)
    assert (occlusion > 1e-3).sum() > 10                      # some are hidden
    np.testing.assert_allclose(occlusion, occlusion_by_rays_trimesh(cam, some, mesh),
                               atol=1e-9)


@pytest.mark.parametrize('distorted', [False, True], ids=['pinhole', 'distorted'])
@pytest.mark.parametrize('seed', [0, 1, 2])
def test_matches_ray_casting_on_random_parts(seed, distorted):
    mesh = random_parts_mesh(np.random.default_rng(seed))
    _assert_matches_ray_casting(_camera(seed, distorted), mesh.vertices, mesh.faces)


def _random_hand(model: HandModel, rng: np.random.Generator) -> np.ndarray:
    """Vertices of the hand at a random pose within the limits, centred at the origin."""
    theta = rng.uniform(model.lower, model.upper)
    theta[model.layout.rotation] = Rotation.random(random_state=rng).as_rotvec()
    theta[model.layout.translation] = 0.0
    vertices = model.pose(theta, jacobian=False).vertices_m
    return vertices - vertices.mean(axis=0)


def test_matches_ray_casting_on_hand():
    model = HandModel.build()
    vertices = _random_hand(model, np.random.default_rng(0))
    _assert_matches_ray_casting(_camera(0, distorted=True, fov_deg=35.0), vertices, model.faces)


def test_matches_ray_casting_on_hand_all_views():
    model = HandModel.build()
    rng = np.random.default_rng(7)
    for _ in range(2):
        vertices = _random_hand(model, rng)
        for index in range(4):
            cam = _camera(index, distorted=index % 2 == 1, width=120, height=90,
                          fov_deg=35.0)
            _assert_matches_ray_casting(cam, vertices, model.faces)


@pytest.mark.parametrize('seed', [3, 4])
def test_vertex_visibility_matches_rays_away_from_discontinuities(seed):
    mesh = random_parts_mesh(np.random.default_rng(seed))
    cam = _camera(seed % 4, distorted=False, width=160, height=120, fov_deg=30.0)
    result = render(cam, mesh.vertices, mesh.faces)
    occlusion = occlusion_by_rays(cam, mesh.vertices, mesh)
    reference = occlusion <= 1e-4
    # Vertices hidden by less than the tolerance plus the depth change across a pixel
    # (where the overlapping parts intersect) are ambiguous, and so are vertices within a
    # pixel of a depth discontinuity, where the 3x3 neighbourhood test is lenient by
    # definition; elsewhere the test must agree with the ray oracle.
    clear = reference | (occlusion > 0.005)
    depth = np.where(result.mask, result.depth_m, 10.0).astype(np.float32)
    kernel = np.ones((3, 3), np.uint8)
    jump = cv2.dilate(depth, kernel) - cv2.erode(depth, kernel) > 0.005
    band = cv2.dilate(jump.astype(np.uint8), kernel).astype(bool)
    uv = np.rint(result.uv_px).astype(int)
    away = ~band[uv[:, 1], uv[:, 0]] & clear
    assert away.sum() > 200 and (~reference[away]).sum() > 20
    assert (reference[away] == result.visible_vertices[away]).mean() >= 0.99
    assert (reference & ~result.visible_vertices).sum() <= 0.005 * reference.sum()
    assert 0 < result.visible_vertices.sum() < len(mesh.vertices)


def _frontal_camera(width: int = 40, height: int = 30) -> PinholeCamera:
    K = np.array([[50.0, 0.0, 20.0], [0.0, 50.0, 15.0], [0.0, 0.0, 1.0]])
    return PinholeCamera('front', width, height, K, np.zeros(5), np.eye(4))


def _quad_at_pixels(u0: float, u1: float, v0: float, v1: float, z: float) -> tuple:
    """Two triangles whose projection is the pixel rectangle [u0, u1] x [v0, v1].

    Their winding is clockwise seen from the camera, i.e. back-facing: render with NO_CULL.
    """
    corners = np.array([[u0, v0], [u1, v0], [u1, v1], [u0, v1]])
    xy = (corners - (20.0, 15.0)) / 50.0 * z
    vertices = np.column_stack([xy, np.full(4, z)])
    return vertices, np.array([[0, 1, 2], [0, 2, 3]])


def test_pixel_centre_convention():
    cam = _frontal_camera()
    vertices, faces = _quad_at_pixels(10.0, 20.0, 5.0, 12.0, 0.5)
    mask = render(cam, vertices, faces, NO_CULL).mask
    rows, cols = np.nonzero(mask)
    assert (cols.min(), cols.max(), rows.min(), rows.max()) == (10, 20, 5, 12)
    assert mask.sum() == 11 * 8  # edges on pixel centres are inside, no gaps on the diagonal
    vertices, faces = _quad_at_pixels(10.2, 19.8, 5.4, 11.6, 0.5)
    rows, cols = np.nonzero(render(cam, vertices, faces, NO_CULL).mask)
    assert (cols.min(), cols.max(), rows.min(), rows.max()) == (11, 19, 6, 11)


def test_depth_is_perspective_correct_on_a_tilted_plane():
    cam = _frontal_camera()
    normal = np.array([0.3, -0.2, 1.0])
    offset = 0.6  # plane n . X = offset
    corners_uv = np.array([[-5.0, -5.0], [45.0, -5.0], [20.0, 40.0]])
    rays = np.column_stack([(corners_uv - (20.0, 15.0)) / 50.0, np.ones(3)])
    vertices = rays * (offset / (rays @ normal))[:, None]
    result = render(cam, vertices, np.array([[0, 1, 2]]), NO_CULL)
    rows, cols = np.nonzero(result.mask)
    pixel_rays = np.column_stack([(np.column_stack([cols, rows]) - (20.0, 15.0)) / 50.0,
                                  np.ones(len(rows))])
    expected = offset / (pixel_rays @ normal)
    np.testing.assert_allclose(result.depth_m[rows, cols], expected, rtol=1e-6)
    assert result.mask.mean() > 0.5


def test_behind_camera_and_near_plane_are_skipped():
    cam = _frontal_camera()
    vertices, faces = _quad_at_pixels(5.0, 30.0, 5.0, 25.0, 0.5)
    vertices_behind = vertices * (1.0, 1.0, -1.0)
    result = render(cam, vertices_behind, faces)
    assert not result.mask.any() and np.isinf(result.depth_m).all()
    assert (result.face_id == -1).all() and not result.visible_vertices.any()
    result = render(cam, vertices * 0.01, faces, RenderConfig(near_m=0.01))
    assert not result.mask.any()


def test_output_types_and_visibility_of_a_plane():
    cam = _frontal_camera()
    vertices, faces = _quad_at_pixels(5.0, 30.0, 5.0, 25.0, 0.5)
    result = render(cam, vertices, faces, NO_CULL)
    assert result.depth_m.dtype == np.float32 and result.face_id.dtype == np.int32
    assert result.mask.dtype == bool and result.depth_m.shape == (30, 40)
    assert result.visible_vertices.all()
    hidden = np.vstack([vertices, [[0.0, 0.0, 0.8]]])  # a vertex behind the quad
    assert not render(cam, hidden, faces, NO_CULL).visible_vertices[4]
    assert not render(cam, vertices, faces).mask.any()  # culled: it faces away
    assert render(cam, vertices, faces[:, ::-1]).mask.sum() == result.mask.sum()


@pytest.mark.parametrize('seed', [5, 6])
def test_culling_does_not_change_closed_meshes(seed):
    mesh = random_parts_mesh(np.random.default_rng(seed))
    cam = _camera(seed % 4, distorted=True, width=160, height=120, fov_deg=30.0)
    culled = render(cam, mesh.vertices, mesh.faces)
    full = render(cam, mesh.vertices, mesh.faces, NO_CULL)
    np.testing.assert_array_equal(culled.mask, full.mask)
    np.testing.assert_array_equal(culled.depth_m, full.depth_m)
    np.testing.assert_array_equal(culled.visible_vertices, full.visible_vertices)
    assert culled.mask.sum() > 500


@pytest.mark.parametrize('cull', [True, False], ids=['culled', 'all faces'])
def test_without_triangle_ids_the_view_is_the_same(cull):
    """``face_ids=False`` (the tracker's views) keeps every other output to the last bit."""
    mesh = random_parts_mesh(np.random.default_rng(7))
    cam = _camera(2, distorted=True, width=160, height=120, fov_deg=30.0)
    full = render(cam, mesh.vertices, mesh.faces, RenderConfig(cull_back_faces=cull))
    lean = render(cam, mesh.vertices, mesh.faces,
                  RenderConfig(cull_back_faces=cull, face_ids=False))
    assert lean.face_id is None and full.face_id is not None
    np.testing.assert_array_equal(full.mask, full.face_id >= 0)
    np.testing.assert_array_equal(lean.mask, full.mask)
    np.testing.assert_array_equal(lean.depth_m, full.depth_m)
    np.testing.assert_array_equal(lean.visible_vertices, full.visible_vertices)
    np.testing.assert_array_equal(lean.uv_px, full.uv_px)
    assert full.mask.sum() > 500


def test_bad_faces_are_rejected():
    cam = _frontal_camera()
    with pytest.raises(ShapeError, match='`faces` index out of range for 3 vertices'):
        render(cam, np.ones((3, 3)), np.array([[0, 1, 3]]))
    with pytest.raises(ShapeError, match=r'`faces` must be \(\*, 3\)'):
        render(cam, np.ones((3, 3)), np.array([0, 1, 2]))
