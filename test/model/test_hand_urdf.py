"""The generated URDF: parses, names, limits, connectivity, FK equal to the model's, and
the TF of a pose (joint_transforms) equal to both."""
from __future__ import annotations

import xml.etree.ElementTree as ET

import numpy as np

from hand_tracker_ros.geometry.rotations import matrix_from_axis_angle, rot_x, rot_y, rot_z
from hand_tracker_ros.model.layout import PARAM_NAMES
from hand_tracker_ros.model.urdf import joint_transforms, urdf_joints, urdf_text


def _origin(joint: ET.Element) -> np.ndarray:
    o = joint.find('origin')
    xyz = np.array(o.get('xyz').split(), dtype=float)
    roll, pitch, yaw = np.array(o.get('rpy').split(), dtype=float)
    t = np.eye(4)
    t[:3, :3] = rot_z(yaw) @ rot_y(pitch) @ rot_x(roll)
    t[:3, 3] = xyz
    return t


def _urdf_fk(root: ET.Element, theta: np.ndarray, base: str) -> dict[str, np.ndarray]:
    """Link poses of the URDF at ``theta`` (a tiny reference FK for the test)."""
    joints = {j.find('parent').get('link'): [] for j in root.iter('joint')}
    for j in root.iter('joint'):
        joints[j.find('parent').get('link')].append(j)
    poses, stack = {base: np.eye(4)}, [base]
    while stack:
        link = stack.pop()
        for j in joints.get(link, []):
            q = theta[PARAM_NAMES.index(j.get('name'))]
            axis = np.array(j.find('axis').get('xyz').split(), dtype=float)
            motion = np.eye(4)
            if j.get('type') == 'prismatic':
                motion[:3, 3] = axis * q
            else:
                motion[:3, :3] = matrix_from_axis_angle(axis * q)
            child = j.find('child').get('link')
            poses[child] = poses[link] @ _origin(j) @ motion
            stack.append(child)
    return poses


def test_urdf_joints_limits_and_tree(model) -> None:
    root = ET.fromstring(urdf_text(model, root_link='cam0'))
    joints = {j.get('name'): j for j in root.iter('joint')}
    assert set(joints) == set(PARAM_NAMES)
    for k, name in enumerate(PARAM_NAMES):
        lim = joints[name].find('limit')
        assert float(lim.get('lower')) == np.float64(f'{model.lower[k]:.6g}')
        assert float(lim.get('upper')) == np.float64(f'{model.upper[k]:.6g}')
    links = {link.get('name') for link in root.iter('link')}
    children = [j.find('child').get('link') for j in joints.values()]
    assert len(children) == len(set(children)) == len(links) - 1     # a tree
    assert links - set(children) == {'cam0'}                            # one root
    assert {j.find('parent').get('link') for j in joints.values()} <= links
    assert len(list(root.iter('cylinder'))) == 15
    assert len(list(root.iter('sphere'))) == model.sphere_radii_m.size


def test_urdf_kinematics_equal_model(model, random_theta) -> None:
    theta = random_theta(np.random.default_rng(21))
    poses = _urdf_fk(ET.fromstring(urdf_text(model)), theta, 'world')
    posed = model.pose(theta, jacobian=False)
    for b, name in enumerate(model.part_names):
        np.testing.assert_allclose(poses[name], posed.bone_transforms[b], atol=1e-5)


def test_tf_tree_is_the_urdf_tree(model) -> None:
    root = ET.fromstring(urdf_text(model, root_link='map', prefix='r_'))
    in_text = [(j.get('name'), j.find('parent').get('link'), j.find('child').get('link'))
               for j in root.iter('joint')]
    table = urdf_joints(model, root_link='map', prefix='r_')
    assert [(j.name, j.parent, j.child) for j in table] == in_text


def test_tf_of_a_pose_chains_to_the_model_bones_and_the_urdf_links(model, random_theta) -> None:
    theta = random_theta(np.random.default_rng(22))
    joints = urdf_joints(model)
    transforms = joint_transforms(joints, theta)
    poses = {'world': np.eye(4)}
    for joint, T_parent_child in zip(joints, transforms):      # parents come first
        poses[joint.child] = poses[joint.parent] @ T_parent_child
    posed = model.pose(theta, jacobian=False)
    for b, name in enumerate(model.part_names):
        np.testing.assert_allclose(poses[name], posed.bone_transforms[b], atol=1e-12)
    from_text = _urdf_fk(ET.fromstring(urdf_text(model)), theta, 'world')
    assert set(from_text) == set(poses)
    for link, pose in poses.items():
        np.testing.assert_allclose(pose, from_text[link], atol=1e-5)    # text: 6 digits
