"""The hand model: skeleton, pose layout, sphere-mesh geometry, skinned mesh and URDF.

Public entry: :class:`~hand_tracker_ros.model.hand.HandModel`.
"""
