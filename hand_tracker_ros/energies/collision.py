"""Collision term C: the cone distance field of Ballan et al. 2012 over intersecting triangles.

Every correspondence round, the triangles of non-adjacent hand parts that intersect are found
on the posed mesh (:func:`hand_tracker_ros.geometry.triangle_pairs.intersecting_pairs`). For
each intersecting pair ``(f, g)`` the three vertices of ``f`` are constrained against the cone
of the receiver face ``g`` and the three vertices of ``g`` against the cone of ``f``
(Ballan's symmetric constraints); duplicates are merged. One residual per constraint::

    r_i = rho(v_i / u; face_i / u)        (rho = (1 - Phi) Upsilon, rho^2 = Psi, Eqs. 1-3)

with the cone field of :mod:`hand_tracker_ros.energies.cone_field` and ``u = model_unit_m``.
The constraints are held fixed for the round, so ``M`` does not change during its LM steps;
a constraint whose vertex is outside its cone contributes ``r = 0`` and a zero Jacobian row.
The constraints of the frame's earlier rounds (``context.collisions``) are kept: the pairs
are found only at a round's start, and without that memory a round that resolves one contact
can slide the finger into the next one unseen, and back in the round after (measured on the
ablation rows without the silhouette term, where edges matched to the wrong finger pull).
When a round yields more than ``max_pairs`` constraints, the ``max_pairs`` largest residuals
at the start of the round are kept (Ballan caps the collision residuals at 600 per solve).

Model unit: Ballan's ``sigma = 0.5`` is the cone height in the units of *his* mesh, i.e.
relative to its triangle size (the same loss is used with ``sigma = 1e-4`` on metre-scale
SMPL meshes, papers.md 1.3(d)). Our mesh is in metres with triangles a few millimetres wide,
so coordinates are divided by ``model_unit_m`` (default 0.01 m) before evaluating the field:
``sigma = 0.5`` then means a 5 mm cone height, the order of a triangle's circumradius and of
a finger's radius, which keeps the field active across a realistic penetration depth.
The Jacobian is consistent: ``dr/dv_m = (1 / u) drho/dv``.

Jacobian: ``J_i = drho/dv (M, 3) . dv_i/dtheta + sum_k drho/dp_k . dp_k/dtheta``, chaining
the analytic cone-field gradients with ``posed.vertices_jac`` for the intruding vertex and
the receiver face's three vertices (origin, normal and radius all move with the face).

References: docs/references.md.
"""
from __future__ import annotations

import logging
from dataclasses import dataclass

import numpy as np

from hand_tracker_ros._typing import BoolArray, FloatArray, Int32Array, IntArray
from hand_tracker_ros.checks import check_shape
from hand_tracker_ros.config import param
from hand_tracker_ros.core.context import CollisionPairs, RoundContext
from hand_tracker_ros.energies import cone_field
from hand_tracker_ros.errors import ShapeError
from hand_tracker_ros.geometry.triangle_pairs import face_parts, intersecting_pairs
from hand_tracker_ros.model.hand import HandModel, PosedHand

logger = logging.getLogger(__name__)


@dataclass(frozen=True)
class CollisionConfig:
    """Switch, weight and cone parameters of the collision term."""

    enabled: bool = param(True, 'Use the collision term')
    weight: float = param(3e3, 'Weight of 0.5 |r|^2 in the total cost (r in model units; tuned '
                          'by hand-tracker evaluate)', low=0.0)
    sigma: float = param(0.5, 'Cone height above the receiver face (Ballan: 0.5), in model '
                         'units', low=1e-3, high=0.99)
    model_unit_m: float = param(0.01, 'Length of one model unit: coordinates are divided by '
                                'it before evaluating the cone field', unit='m', low=1e-5,
                                high=1.0)
    max_pairs: int = param(600, 'Maximum (vertex, receiver face) constraints, i.e. residuals, '
                           'per round (Ballan: 600)', low=1)


def _readonly(*arrays: np.ndarray) -> None:
    for a in arrays:
        a.setflags(write=False)


class CollisionEnergy:
    """Collision term C (see module docstring); holds only configuration and topology."""

    name = 'collision'

    def __init__(self, config: CollisionConfig, faces: Int32Array, vertex_part: Int32Array,
                 adjacent_parts: BoolArray) -> None:
        """Build the term for a mesh.

        Parameters
        ----------
        config : CollisionConfig
        faces : (F, 3) int32
            Triangles, counter-clockwise seen from outside (the cones open outwards).
        vertex_part : (V,) int32
            Part of each vertex; a face's part is the majority of its vertices' parts.
        adjacent_parts : (B, B) bool
            Part pairs that may touch and are never constrained.
        """
        check_shape('faces', faces, (None, 3))
        check_shape('vertex_part', vertex_part, (None,))
        n_parts = len(adjacent_parts)
        check_shape('adjacent_parts', adjacent_parts, (n_parts, n_parts))
        if faces.size and faces.max() >= len(vertex_part):
            msg = f'`faces` index vertex {faces.max()} but `vertex_part` has {len(vertex_part)}'
            raise ShapeError(msg)
        self.config = config
        self.faces = np.array(faces, dtype=np.int64)
        self.face_part = face_parts(faces, vertex_part)
        self.adjacent_parts = np.array(adjacent_parts, dtype=bool)
        self._n_vertices = len(vertex_part)
        _readonly(self.faces, self.face_part, self.adjacent_parts)

    @classmethod
    def from_model(cls, config: CollisionConfig, model: HandModel) -> CollisionEnergy:
        """Build from a ``HandModel`` (uses ``faces``, ``vertex_part``, ``adjacent_parts``)."""
        return cls(config, model.faces, model.vertex_part, model.adjacent_parts)

    @property
    def weight(self) -> float:
        """Weight of the term's cost ``0.5 * weight * |r|^2``."""
        return self.config.weight

    def correspond(self, context: RoundContext) -> CollisionPairs:
        """Constraints for one round, from ``context.posed.vertices_m`` (V, 3) float64."""
        return self.pairs_at(context.posed.vertices_m, context.collisions)

    def pairs_at(self, vertices_m: FloatArray, keep: CollisionPairs | None = None
                 ) -> CollisionPairs:
        """Constraints of the mesh posed at ``vertices_m`` (V, 3) float64, plus the ones of
        ``keep`` (earlier rounds of the frame)."""
        check_shape('vertices_m', vertices_m, (self._n_vertices, 3))
        empty = np.zeros(0, dtype=np.int64)
        if not self.config.enabled:
            pairs = CollisionPairs(np.zeros((0, 2), np.int64), empty, empty.copy())
        else:
            face_pairs = intersecting_pairs(vertices_m, self.faces, self.face_part,
                                            self.adjacent_parts)
            vertex_ids, face_ids = self._constraints(vertices_m, face_pairs, keep)
            pairs = CollisionPairs(face_pairs, vertex_ids, face_ids)
        _readonly(pairs.face_pairs, pairs.vertex_ids, pairs.face_ids)
        logger.debug('collision: %d face pairs, %d constraints', len(pairs.face_pairs),
                     pairs.n_residuals)
        return pairs

    def _constraints(self, vertices_m: FloatArray, face_pairs: IntArray,
                     keep: CollisionPairs | None) -> tuple[IntArray, IntArray]:
        """Unique (vertex, receiver face) constraints of ``face_pairs`` and ``keep``, capped at
        ``max_pairs`` largest ``r``."""
        intruder = np.concatenate([face_pairs[:, 0], face_pairs[:, 1]])
        receiver = np.concatenate([face_pairs[:, 1], face_pairs[:, 0]])
        both = np.stack([self.faces[intruder].ravel(), np.repeat(receiver, 3)], axis=1)
        if keep is not None:
            both = np.concatenate([both, np.stack([keep.vertex_ids, keep.face_ids], axis=1)])
        if len(both):   # np.unique(axis=0) costs ~40 us even on nothing, the usual case
            both = np.unique(both, axis=0)
        vertex_ids, face_ids = both[:, 0], both[:, 1]
        if len(vertex_ids) > self.config.max_pairs:
            rho = self._rho(vertices_m, vertex_ids, face_ids)
            top = np.sort(np.argsort(-rho, kind='stable')[:self.config.max_pairs])
            vertex_ids, face_ids = vertex_ids[top], face_ids[top]
        return vertex_ids.astype(np.int64), face_ids.astype(np.int64)

    def _rho(self, vertices_m: FloatArray, vertex_ids: IntArray, face_ids: IntArray
             ) -> FloatArray:
        scale = 1.0 / self.config.model_unit_m
        geom = cone_field.cone_geometry(vertices_m[vertex_ids] * scale,
                                        vertices_m[self.faces[face_ids]] * scale)
        return cone_field.residual(geom, self.config.sigma)

    def residuals(self, posed: PosedHand, pairs: CollisionPairs) -> FloatArray:
        """Residuals ``r (M,)`` float64 of ``posed.vertices_m`` for the round's constraints."""
        if pairs.n_residuals == 0:  # the common case; skips the cone geometry's dispatch
            return np.zeros(0)
        return self._rho(posed.vertices_m, pairs.vertex_ids, pairs.face_ids)

    def jacobian_vertices(self, pairs: CollisionPairs) -> IntArray:
        """Vertex ids (K,) int64 the rows read: intruding vertices and receiving triangles."""
        return np.concatenate([pairs.vertex_ids, self.faces[pairs.face_ids].ravel()])

    def linearize(self, posed: PosedHand, pairs: CollisionPairs) -> tuple[FloatArray, FloatArray]:
        """Residuals ``r (M,)`` and Jacobian ``dr/dtheta (M, P)`` using ``posed.vertices_jac``."""
        jac = posed.vertices_jac
        if jac is None:
            msg = '`posed.vertices_jac` is None: pose the hand with jacobian=True'
            raise ShapeError(msg)
        check_shape('posed.vertices_jac', jac, (self._n_vertices, 3, None))
        if pairs.n_residuals == 0:
            return np.zeros(0), np.zeros((0, jac.shape[2]))
        scale = 1.0 / self.config.model_unit_m
        tri_ids = self.faces[pairs.face_ids]
        rho, d_pt, d_tri = cone_field.residual_and_gradients(
            posed.vertices_m[pairs.vertex_ids] * scale, posed.vertices_m[tri_ids] * scale,
            self.config.sigma)
        jacobian = (np.einsum('mk,mkp->mp', d_pt, jac[pairs.vertex_ids])
                    + np.einsum('mjk,mjkp->mp', d_tri, jac[tri_ids]))
        return rho, jacobian * scale
