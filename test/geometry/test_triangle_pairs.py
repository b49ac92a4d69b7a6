"""Triangle-pair search between non-adjacent parts and the interpenetration metric."""
from __future__ import annotations

import numpy as np
import pytest
import trimesh

from hand_tracker_ros.errors import ShapeError
from hand_tracker_ros.geometry import triangle_pairs as tp


def _segment_hits_triangle(p: np.ndarray, q: np.ndarray, tri: np.ndarray) -> bool:
    """Moeller-Trumbore on the closed segment pq (independent oracle)."""
    e1, e2 = tri[1] - tri[0], tri[2] - tri[0]
    d = q - p
    h = np.cross(d, e2)
    det = e1 @ h
    if abs(det) < 1e-14:
        return False
    s = p - tri[0]
    u = (s @ h) / det
    qv = np.cross(s, e1)
    v = (d @ qv) / det
    t = (e2 @ qv) / det
    return bool(u >= 0 and v >= 0 and u + v <= 1 and 0 <= t <= 1)


def _oracle(a: np.ndarray, b: np.ndarray) -> bool:
    """Non-coplanar triangles meet iff an edge of one crosses the other."""
    return any(_segment_hits_triangle(t[i], t[(i + 1) % 3], o)
               for t, o in ((a, b), (b, a)) for i in range(3))


def test_random_triangles_match_edge_crossing_oracle() -> None:
    rng = np.random.default_rng(3)
    hits = 0
    for _ in range(3000):
        a = rng.uniform(size=(3, 3))
        b = rng.uniform(size=(3, 3)) + rng.uniform(-0.3, 0.3, size=3)
        expected = _oracle(a, b)
        hits += expected
        assert tp.triangles_intersect(a, b) == expected
    assert 300 < hits < 2700


@pytest.mark.parametrize(('b', 'expected'), [
    # crossing: pierces the interior of a
    ([[0.2, 0.2, -1.0], [0.3, 0.2, 1.0], [0.2, 0.3, 1.0]], True),
    # parallel plane above
    ([[0.0, 0.0, 0.1], [1.0, 0.0, 0.1], [0.0, 1.0, 0.1]], False),
    # touching: one vertex on a's interior, the rest above
    ([[0.2, 0.2, 0.0], [0.3, 0.2, 1.0], [0.2, 0.3, 1.0]], True),
    # touching along an edge from outside the plane
    ([[0.0, 0.5, 0.0], [0.5, 0.0, 0.0], [1.0, 1.0, 1.0]], True),
    # crossing a's plane outside a
    ([[2.0, 2.0, -1.0], [2.1, 2.0, 1.0], [2.0, 2.1, 1.0]], False),
    # coplanar overlapping, coplanar contained, coplanar disjoint
    ([[0.5, 0.5, 0.0], [-0.5, 0.2, 0.0], [0.2, -0.5, 0.0]], True),
    ([[0.1, 0.1, 0.0], [0.3, 0.1, 0.0], [0.1, 0.3, 0.0]], True),
    ([[1.0, 1.0, 0.0], [2.0, 1.0, 0.0], [1.0, 2.0, 0.0]], False),
])
def test_known_configurations(b: list[list[float]], expected: bool) -> None:
    a = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])
    assert tp.triangles_intersect(a, np.array(b)) is expected
    assert tp.triangles_intersect(np.array(b), a) is expected
    # Scale invariance of the tolerance (hand triangles are millimetres in metres).
    assert tp.triangles_intersect(a * 1e-3, np.array(b) * 1e-3) is expected


def _parts_mesh(offsets: list[tuple[float, float, float]], subdivisions: int = 2
                ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Unit icospheres at ``offsets``, one part each: vertices, faces, face_part."""
    verts, faces, parts = [], [], []
    for i, off in enumerate(offsets):
        s = trimesh.creation.icosphere(subdivisions=subdivisions)
        faces.append(s.faces + sum(len(v) for v in verts))
        verts.append(s.vertices + np.asarray(off))
        parts.append(np.full(len(s.faces), i))
    return (np.concatenate(verts), np.concatenate(faces).astype(np.int32),
            np.concatenate(parts).astype(np.int32))


def _brute_force(verts: np.ndarray, faces: np.ndarray, part: np.ndarray,
                 adjacent: np.ndarray) -> set[tuple[int, int]]:
    out = set()
    for f in range(len(faces)):
        for g in range(len(faces)):
            pf, pg = part[f], part[g]
            if pf >= pg or adjacent[pf, pg] or set(faces[f]) & set(faces[g]):
                continue
            if tp.triangles_intersect(verts[faces[f]], verts[faces[g]]):
                out.add((f, g))
    return out


def test_pairs_match_brute_force_and_respect_adjacency() -> None:
    rng = np.random.default_rng(5)
    verts, faces, part = _parts_mesh([(0, 0, 0), (1.5, 0.2, 0), (0.7, 1.2, 0.3)], 1)
    verts = verts + rng.normal(scale=0.02, size=verts.shape)
    adjacent = np.eye(3, dtype=bool)
    adjacent[0, 2] = adjacent[2, 0] = True
    pairs = tp.intersecting_pairs(verts, faces, part, adjacent)
    expected = _brute_force(verts, faces, part, adjacent)
    assert len(expected) > 10
    assert {tuple(p) for p in pairs.tolist()} == expected
    assert set(map(tuple, part[pairs].tolist())) == {(0, 1), (1, 2)}


def test_separated_parts_give_no_pairs() -> None:
    verts, faces, part = _parts_mesh([(0, 0, 0), (2.5, 0, 0)])
    pairs = tp.intersecting_pairs(verts, faces, part, np.eye(2, dtype=bool))
    assert pairs.shape == (0, 2)


def test_shared_vertices_are_not_collisions() -> None:
    # Two triangles of different parts sharing an edge: topological neighbours, not a hit.
    verts = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 1, 0.0]])
    faces = np.array([[0, 1, 2], [1, 3, 2]], dtype=np.int32)
    part = np.array([0, 1], dtype=np.int32)
    assert tp.intersecting_pairs(verts, faces, part, np.eye(2, dtype=bool)).shape == (0, 2)


def test_bad_face_part_raises() -> None:
    verts, faces, part = _parts_mesh([(0, 0, 0)])
    with pytest.raises(ShapeError, match='face_part'):
        tp.intersecting_pairs(verts, faces, part + 3, np.eye(2, dtype=bool))


def test_face_parts_majority() -> None:
    vertex_part = np.array([0, 1, 1, 2], dtype=np.int32)
    faces = np.array([[0, 1, 2], [1, 0, 2], [0, 1, 3], [2, 3, 3]], dtype=np.int32)
    np.testing.assert_array_equal(tp.face_parts(faces, vertex_part), [1, 1, 0, 2])


def test_winding_number_closed_and_open() -> None:
    sphere = trimesh.creation.icosphere(subdivisions=3)
    tris = sphere.vertices[sphere.faces]
    w = tp.winding_numbers(np.array([[0, 0, 0], [0.5, 0.2, 0], [1.5, 0, 0], [0, 3, 0.0]]), tris)
    np.testing.assert_allclose(w, [1, 1, 0, 0], atol=1e-9)
    # Open tube (radius 1, length 4) without caps: each cap subtends 2 pi (1 - cos a) at the
    # centre, cos a = 2 / sqrt(5), so w = cos a.
    tube = trimesh.creation.cylinder(radius=1.0, height=4.0, sections=256)
    side = tube.faces[np.abs(tube.face_normals[:, 2]) < 0.5]
    w_tube = tp.winding_numbers(np.zeros((1, 3)), tube.vertices[side])
    np.testing.assert_allclose(w_tube, [2 / np.sqrt(5)], rtol=1e-3)


@pytest.mark.parametrize('distance', [1.6, 1.8, 1.95])
def test_max_interpenetration_of_two_spheres(distance: float) -> None:
    # Unit spheres along a vertex direction u: the deepest vertex of A is at R u, the
    # antipodal vertex of B at (distance - R) u, so the depth is about 2 R - distance.
    sphere = trimesh.creation.icosphere(subdivisions=3)
    u = sphere.vertices[0]
    verts, faces, part = _parts_mesh([(0, 0, 0), tuple(distance * u)], 3)
    depth = tp.max_interpenetration_m(verts, faces, part, np.eye(2, dtype=bool))
    np.testing.assert_allclose(depth, 2.0 - distance, rtol=0.02)
    # Oracle on the closed meshes: trimesh signed distance (positive inside).
    n = len(sphere.vertices)
    other = trimesh.Trimesh(verts[n:], faces[part == 1] - n, process=False)
    expected = trimesh.proximity.signed_distance(other, verts[:n]).max()
    np.testing.assert_allclose(depth, expected, rtol=1e-6)


def test_no_interpenetration_when_apart_or_adjacent() -> None:
    verts, faces, part = _parts_mesh([(0, 0, 0), (2.2, 0, 0)])
    assert tp.max_interpenetration_m(verts, faces, part, np.eye(2, dtype=bool)) == 0.0
    verts, faces, part = _parts_mesh([(0, 0, 0), (1.5, 0, 0)])
    assert tp.max_interpenetration_m(verts, faces, part, np.ones((2, 2), dtype=bool)) == 0.0
