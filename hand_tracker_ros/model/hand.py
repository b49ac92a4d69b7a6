"""The hand model: the public entry point of :mod:`hand_tracker_ros.model`.

``HandModel.build(shape)`` assembles the skeleton (:mod:`.skeleton`), the sphere mesh
(:mod:`.spheremesh`) and its skinned triangle mesh (:mod:`.mesh`); it is cached per shape.
``HandModel.pose(theta)`` runs forward kinematics (:mod:`.kinematics`) and skinning
(:mod:`.skinning`) and returns a :class:`PosedHand` with the analytic Jacobians of keypoints,
vertices and sphere centres with respect to ``theta`` (P,).
"""
from __future__ import annotations

import functools
from dataclasses import dataclass, field

import numpy as np

from hand_tracker_ros._typing import BoolArray, FloatArray, Int32Array, IntArray
from hand_tracker_ros.checks import check_finite, check_shape
from hand_tracker_ros.model import kinematics
from hand_tracker_ros.model.layout import PARAM_NAMES, Layout, P
from hand_tracker_ros.model.mesh import adjacent_parts, build_skinned_mesh
from hand_tracker_ros.model.poses import NEUTRAL_RAD
from hand_tracker_ros.model.shape import HandShape
from hand_tracker_ros.model.skeleton import (
    BONE_NAMES,
    KEYPOINT_BONES,
    RestSkeleton,
    joint_limits,
    rest_skeleton,
)
from hand_tracker_ros.model.skinning import skin, skin_with_jacobian, vertex_normals
from hand_tracker_ros.model.spheremesh import build_sphere_mesh


def _readonly(*arrays: np.ndarray) -> None:
    for a in arrays:
        a.setflags(write=False)


@dataclass(frozen=True, eq=False)
class PosedHand:
    """The hand at one pose; ``*_jac`` are None when posed with ``jacobian=False``.

    The vertex normals and the sphere-mesh centres are computed on first access: the
    tracker's Levenberg-Marquardt evaluations pose the hand some 30 times per frame and use
    neither (they cost about as much as the skinning itself).

    Attributes
    ----------
    theta : (P,) float64
    bone_transforms : (B, 4, 4) float64
        ``T_world_bone``.
    keypoints_m : (21, 3) float64
        KEYPOINT_NAMES order; ``keypoints_jac`` (21, 3, P).
    vertices_m : (V, 3) float64
        Skinned mesh; ``vertices_jac`` (V, 3, P).
    vertex_normals : (V, 3) float64
        Unit outward normals (lazy).
    sphere_centers_m : (S, 3) float64
        Sphere-mesh centres; ``sphere_centers_jac`` (S, 3, P) (both lazy). Radii do not
        change with pose.
    fingertip_vertex_ids : (5,) int64
    """

    theta: FloatArray
    bone_transforms: FloatArray
    keypoints_m: FloatArray
    keypoints_jac: FloatArray | None
    vertices_m: FloatArray
    vertices_jac: FloatArray | None
    fingertip_vertex_ids: IntArray
    _model: HandModel = field(repr=False)
    _fk: kinematics.FKResult = field(repr=False)

    @property
    def model(self) -> HandModel:
        """The hand model posed (its shape, mesh and limits)."""
        return self._model

    @functools.cached_property
    def vertex_normals(self) -> FloatArray:
        """Unit outward vertex normals (V, 3) float64."""
        return vertex_normals(self.vertices_m, self._model.faces)

    @functools.cached_property
    def sphere_centers_m(self) -> FloatArray:
        """Sphere-mesh centres (S, 3) float64."""
        return kinematics.transform_points(self._fk, self._model.sphere_part,
                                           self._model.sphere_local_m)

    @functools.cached_property
    def sphere_centers_jac(self) -> FloatArray | None:
        """Jacobian (S, 3, P) float64 of the sphere centres; None without ``jacobian``."""
        if self.vertices_jac is None:
            return None
        return kinematics.points_jacobian(self._fk, self._model.sphere_part,
                                          self.sphere_centers_m)

    @property
    def fingertips_m(self) -> FloatArray:
        """Fingertip vertices (5, 3) float64, FINGER_NAMES order."""
        return self.vertices_m[self.fingertip_vertex_ids]


@dataclass(frozen=True, eq=False)
class HandModel:
    """Immutable hand model; build with :meth:`HandModel.build`.

    Attributes
    ----------
    shape : HandShape
    layout : Layout
    faces : (F, 3) int32
    rest_vertices_m : (V, 3) float64
        Rest pose (theta = 0) in the hand frame.
    skin_weights : (V, B) float64
        Rows sum to 1.
    vertex_part : (V,) int32
        Dominant bone of each vertex (index into ``part_names``).
    part_names : tuple of str
        Bone names (B = 16).
    adjacent_parts : (B, B) bool
        Pairs the collision term ignores (diagonal, parent/child, neighbouring first segments).
    fingertip_vertex_ids : (5,) int64
    lower, upper : (P,) float64
        Joint limits (m / rad).
    sphere_radii_m : (S,) float64
    sphere_part : (S,) int64
        Bone of each sphere.
    sphere_local_m : (S, 3) float64
        Sphere centres in their bone frames.
    rest_bone_transforms : (B, 4, 4) float64
        Bone frames of the rest pose in the hand frame.
    rest : RestSkeleton
        Rest joint positions, segment lengths, rest rotations and radii.
    influence_bones, influence_weights : (V, 4) int64, (V, 4) float64
        ``skin_weights`` in sparse form (largest first, zero-padded).
    bone_dofs : (B, 7) int64
        Revolute DOF moving each bone, padded with -1.
    keypoint_local_m : (21, 3) float64
        Keypoints in the frames of KEYPOINT_BONES.
    pills : (Np, 2) int64
    wedges : (Nw, 3) int64
    """

    shape: HandShape
    layout: Layout
    faces: Int32Array
    rest_vertices_m: FloatArray
    skin_weights: FloatArray
    vertex_part: Int32Array
    part_names: tuple[str, ...]
    adjacent_parts: BoolArray
    fingertip_vertex_ids: IntArray
    lower: FloatArray
    upper: FloatArray
    sphere_radii_m: FloatArray
    sphere_part: IntArray
    sphere_local_m: FloatArray
    rest_bone_transforms: FloatArray
    pills: IntArray
    wedges: IntArray
    rest: RestSkeleton
    influence_bones: IntArray
    influence_weights: FloatArray
    bone_dofs: IntArray
    keypoint_local_m: FloatArray
    _rest_inv: FloatArray

    @staticmethod
    def build(shape: HandShape | None = None) -> HandModel:
        """Build (or fetch from the per-shape cache) the model of ``shape`` (default hand)."""
        return _build(shape if shape is not None else HandShape())

    def neutral_theta(self, translation_m: FloatArray | tuple[float, float, float] = (
            0.0, 0.0, 0.0)) -> FloatArray:
        """Relaxed, slightly flexed open hand (P,) float64 with the wrist at ``translation_m``."""
        theta = np.zeros(P)
        theta[Layout.translation] = np.asarray(translation_m, dtype=np.float64)
        for name, value in NEUTRAL_RAD.items():
            theta[PARAM_NAMES.index(name)] = value
        return theta

    def pose(self, theta: FloatArray, *, jacobian: bool = True,
             jacobian_vertices: IntArray | None = None) -> PosedHand:
        """Pose the hand.

        Parameters
        ----------
        theta : (P,) float64
            Pose in PARAM_NAMES order (not clipped to the limits).
        jacobian : bool
            Also compute the (..., 3, P) Jacobians.
        jacobian_vertices : (K,) int64, optional
            Unique vertex ids: only these rows of ``vertices_jac`` are computed and the others
            are left zero, for callers that read no other row (the tracker's LM evaluations
            read only the vertices of their correspondences, about a third of the mesh).
            Default: every vertex.

        Raises
        ------
        ShapeError
            If ``theta`` is not (P,) or not finite.
        """
        theta = np.asarray(theta, dtype=np.float64)
        check_shape('theta', theta, (P,))
        check_finite('theta', theta)
        fk = kinematics.forward_kinematics(self.rest, theta)
        skin_t = fk.bone_transforms @ self._rest_inv
        kp_bones = np.asarray(KEYPOINT_BONES)
        keypoints = kinematics.transform_points(fk, kp_bones, self.keypoint_local_m)
        verts_jac: FloatArray | None
        kp_jac: FloatArray | None
        if jacobian:
            verts, verts_jac = skin_with_jacobian(
                skin_t, self.rest_vertices_m, self.influence_bones, self.influence_weights,
                self.bone_dofs, fk.axes, fk.pivots, jacobian_vertices)
            kp_jac = kinematics.points_jacobian(fk, kp_bones, keypoints)
        else:
            verts = skin(skin_t, self.rest_vertices_m, self.influence_bones,
                         self.influence_weights)
            verts_jac = kp_jac = None
        return PosedHand(theta=theta.copy(), bone_transforms=fk.bone_transforms,
                         keypoints_m=keypoints, keypoints_jac=kp_jac, vertices_m=verts,
                         vertices_jac=verts_jac, fingertip_vertex_ids=self.fingertip_vertex_ids,
                         _model=self, _fk=fk)


@functools.lru_cache(maxsize=8)
def _build(shape: HandShape) -> HandModel:
    rest = rest_skeleton(shape)
    rest_t = kinematics.rest_transforms(rest)
    sm = build_sphere_mesh(rest, rest_t)
    mesh = build_skinned_mesh(sm, rest_t, shape.scale)
    lower, upper = joint_limits()
    model = HandModel(
        shape=shape, layout=Layout(), faces=mesh.faces, rest_vertices_m=mesh.vertices_m,
        skin_weights=mesh.weights, vertex_part=mesh.vertex_part, part_names=BONE_NAMES,
        adjacent_parts=adjacent_parts(), fingertip_vertex_ids=mesh.fingertip_vertex_ids,
        lower=lower, upper=upper, sphere_radii_m=sm.radii_m, sphere_part=sm.sphere_bone,
        sphere_local_m=sm.sphere_local_m, rest_bone_transforms=rest_t,
        pills=sm.pills, wedges=sm.wedges, rest=rest,
        influence_bones=mesh.influence_bones, influence_weights=mesh.influence_weights,
        bone_dofs=kinematics.bone_revolute_dofs(),
        keypoint_local_m=kinematics.keypoint_local(rest),
        _rest_inv=np.asarray(np.linalg.inv(rest_t), np.float64))
    _readonly(model.faces, model.rest_vertices_m, model.skin_weights, model.vertex_part,
              model.adjacent_parts, model.fingertip_vertex_ids, model.lower, model.upper,
              model.sphere_radii_m, model.sphere_part, model.sphere_local_m,
              model.rest_bone_transforms, model.pills, model.wedges, model.influence_bones,
              model.influence_weights, model.bone_dofs, model.keypoint_local_m)
    return model
