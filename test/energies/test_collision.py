"""Collision term C: pairs, residuals, Jacobian vs central differences, separation by GN."""
from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest
import trimesh

from hand_tracker_ros.config import from_mapping
from hand_tracker_ros.energies.collision import CollisionConfig, CollisionEnergy
from hand_tracker_ros.energies.cone_field import cone_geometry, residual
from hand_tracker_ros.errors import ConfigError, ShapeError
from hand_tracker_ros.geometry.triangle_pairs import max_interpenetration_m
from hand_tracker_ros.model.hand import HandModel
from hand_tracker_ros.model.layout import PARAM_NAMES

_RADIUS_M = 0.01
_SPHERE = trimesh.creation.icosphere(subdivisions=2, radius=_RADIUS_M)
_N = len(_SPHERE.vertices)
_FACES = np.concatenate([_SPHERE.faces, _SPHERE.faces + _N]).astype(np.int32)
_VERTEX_PART = np.repeat(np.array([0, 1], dtype=np.int32), _N)
_CENTER_1 = np.array([0.013, 0.006, 0.002])


def _rot(axis: int, angle: float) -> tuple[np.ndarray, np.ndarray]:
    """Rotation about a coordinate axis and its derivative w.r.t. the angle."""
    c, s = np.cos(angle), np.sin(angle)
    i, j = [k for k in range(3) if k != axis]
    rot, d_rot = np.eye(3), np.zeros((3, 3))
    rot[i, i], rot[i, j], rot[j, i], rot[j, j] = c, -s, s, c
    d_rot[i, i], d_rot[i, j], d_rot[j, i], d_rot[j, j] = -s, -c, c, -s
    return rot, d_rot


def _pose(theta: np.ndarray) -> SimpleNamespace:
    """Two spheres: part 1 translated by theta[:3] and turned about z by theta[3] (about its
    centre); part 0 turned about x by theta[4]. Analytic vertex Jacobian (V, 3, 5)."""
    local = _SPHERE.vertices
    r0, d_r0 = _rot(0, theta[4])
    r1, d_r1 = _rot(2, theta[3])
    verts = np.concatenate([local @ r0.T, local @ r1.T + _CENTER_1 + theta[:3]])
    jac = np.zeros((2 * _N, 3, 5))
    jac[:_N, :, 4] = local @ d_r0.T
    jac[_N:, :, :3] = np.eye(3)
    jac[_N:, :, 3] = local @ d_r1.T
    return SimpleNamespace(vertices_m=verts, vertices_jac=jac)


def _energy(**overrides: object) -> CollisionEnergy:
    config = from_mapping(CollisionConfig, dict(overrides))
    return CollisionEnergy(config, _FACES, _VERTEX_PART, np.eye(2, dtype=bool))


_THETA0 = np.array([0.0005, -0.0003, 0.0004, 0.3, 0.2])


def test_pairs_are_symmetric_vertex_face_constraints() -> None:
    energy = _energy()
    posed = _pose(_THETA0)
    pairs = energy.correspond(SimpleNamespace(posed=posed, collisions=None))
    assert len(pairs.face_pairs) > 5
    assert pairs.n_residuals == len(pairs.vertex_ids) == len(pairs.face_ids)
    # Every constraint pairs a vertex of one part with a face of the other part.
    assert np.all(_VERTEX_PART[pairs.vertex_ids] != energy.face_part[pairs.face_ids])
    expected = {(int(v), int(receiver)) for f, g in pairs.face_pairs
                for intruder, receiver in ((f, g), (g, f)) for v in _FACES[intruder]}
    assert set(zip(pairs.vertex_ids.tolist(), pairs.face_ids.tolist())) == expected
    r = energy.residuals(posed, pairs)
    assert r.shape == (pairs.n_residuals,)
    assert np.all(r >= 0.0) and r.max() > 0.1
    assert not pairs.vertex_ids.flags.writeable


def test_residual_is_cone_field_in_model_units() -> None:
    energy = _energy(model_unit_m=0.005, sigma=0.3)
    posed = _pose(_THETA0)
    pairs = energy.pairs_at(posed.vertices_m)
    pts = posed.vertices_m[pairs.vertex_ids] / 0.005
    tris = posed.vertices_m[_FACES[pairs.face_ids]] / 0.005
    np.testing.assert_allclose(energy.residuals(posed, pairs),
                               residual(cone_geometry(pts, tris), 0.3))


def test_jacobian_matches_central_differences() -> None:
    energy = _energy()
    pairs = energy.pairs_at(_pose(_THETA0).vertices_m)
    r, jac = energy.linearize(_pose(_THETA0), pairs)
    np.testing.assert_allclose(r, energy.residuals(_pose(_THETA0), pairs))
    h = 1e-8
    numeric = np.zeros_like(jac)
    for p in range(5):
        step = np.zeros(5)
        step[p] = h
        numeric[:, p] = (energy.residuals(_pose(_THETA0 + step), pairs)
                         - energy.residuals(_pose(_THETA0 - step), pairs)) / (2 * h)
    assert np.abs(jac[:, 4]).max() > 1.0  # the receiver faces' own motion is exercised
    np.testing.assert_allclose(jac, numeric, rtol=1e-5, atol=1e-3)


def test_max_pairs_keeps_the_largest_residuals() -> None:
    posed = _pose(_THETA0)
    full = _energy()
    capped = _energy(max_pairs=20)
    pairs_full = full.pairs_at(posed.vertices_m)
    pairs_cap = capped.pairs_at(posed.vertices_m)
    assert pairs_full.n_residuals > 20 and pairs_cap.n_residuals == 20
    r_full = np.sort(full.residuals(posed, pairs_full))[::-1]
    np.testing.assert_allclose(np.sort(capped.residuals(posed, pairs_cap))[::-1], r_full[:20])


def test_disabled_and_separated_give_no_residuals() -> None:
    posed = _pose(_THETA0)
    pairs = _energy(enabled=False).pairs_at(posed.vertices_m)
    assert pairs.n_residuals == 0
    apart = _pose(np.array([0.01, 0.0, 0.0, 0.0, 0.0]))
    pairs = _energy().pairs_at(apart.vertices_m)
    r, jac = _energy().linearize(apart, pairs)
    assert r.shape == (0,) and jac.shape == (0, 5)


def test_gauss_newton_separates_interpenetrating_parts() -> None:
    energy = _energy()
    theta = _THETA0.copy()
    face_part = energy.face_part
    adjacent = np.eye(2, dtype=bool)
    start = max_interpenetration_m(_pose(theta).vertices_m, _FACES, face_part, adjacent)
    assert start > 0.003
    for _ in range(15):
        posed = _pose(theta)
        pairs = energy.pairs_at(posed.vertices_m)
        if pairs.n_residuals == 0:
            break
        r, jac = energy.linearize(posed, pairs)
        lhs = jac.T @ jac
        lhs += 1e-3 * np.diag(np.diag(lhs)) + 1e-9 * np.eye(5)
        theta = theta - np.linalg.solve(lhs, jac.T @ r)
    end = max_interpenetration_m(_pose(theta).vertices_m, _FACES, face_part, adjacent)
    assert end < 0.1 * start


def test_bad_inputs_raise() -> None:
    with pytest.raises(ConfigError, match='sigma'):
        from_mapping(CollisionConfig, {'sigma': 0.0})
    with pytest.raises(ShapeError, match='vertex_part'):
        CollisionEnergy(CollisionConfig(), _FACES, _VERTEX_PART[:10], np.eye(2, dtype=bool))
    energy = _energy()
    posed = _pose(_THETA0)
    pairs = energy.pairs_at(posed.vertices_m)
    with pytest.raises(ShapeError, match='jacobian=True'):
        energy.linearize(SimpleNamespace(vertices_m=posed.vertices_m, vertices_jac=None), pairs)


@pytest.fixture(scope='module')
def hand() -> tuple[HandModel, CollisionEnergy, np.ndarray]:
    """The real hand with the index finger abducted into the middle finger."""
    model = HandModel.build()
    theta = model.neutral_theta()
    theta[PARAM_NAMES.index('index_mcp_abd')] = -0.3
    return model, CollisionEnergy.from_model(CollisionConfig(), model), theta


def test_hand_neutral_pose_has_no_collisions(hand: tuple) -> None:
    model, energy, _ = hand
    posed = model.pose(model.neutral_theta())
    assert energy.pairs_at(posed.vertices_m).n_residuals == 0
    assert max_interpenetration_m(posed.vertices_m, model.faces, energy.face_part,
                                  model.adjacent_parts) == 0.0


def test_hand_abducted_index_jacobian_and_separation(hand: tuple) -> None:
    model, energy, theta = hand
    posed = model.pose(theta)
    pairs = energy.pairs_at(posed.vertices_m)
    fingers = {model.part_names[p].split('_')[0]
               for p in np.unique(energy.face_part[pairs.face_pairs])}
    assert fingers == {'index', 'middle'}
    r, jac = energy.linearize(posed, pairs)
    assert 0.5 * r @ r > 0.1
    cols = [PARAM_NAMES.index(n) for n in ('index_mcp_abd', 'middle_mcp_abd', 'index_pip_flex')]
    h = 1e-7
    for c in cols:
        step = np.zeros_like(theta)
        step[c] = h
        numeric = (energy.residuals(model.pose(theta + step, jacobian=False), pairs)
                   - energy.residuals(model.pose(theta - step, jacobian=False), pairs)) / (2 * h)
        np.testing.assert_allclose(jac[:, c], numeric, rtol=1e-4, atol=1e-4 * np.abs(jac).max())
    # Levenberg-Marquardt steps on the collision term alone reduce the interpenetration.
    start = max_interpenetration_m(posed.vertices_m, model.faces, energy.face_part,
                                   model.adjacent_parts)
    assert start > 0.002
    for _ in range(6):
        posed = model.pose(theta)
        pairs = energy.pairs_at(posed.vertices_m)
        if pairs.n_residuals == 0:
            break
        r, jac = energy.linearize(posed, pairs)
        lhs = jac.T @ jac
        lhs += 0.1 * np.diag(np.diag(lhs)) + 1e-6 * np.eye(len(theta))
        theta = theta - np.linalg.solve(lhs, jac.T @ r)
    end_pose = model.pose(theta, jacobian=False)
    end = max_interpenetration_m(end_pose.vertices_m, model.faces, energy.face_part,
                                 model.adjacent_parts)
    assert end < 0.25 * start
