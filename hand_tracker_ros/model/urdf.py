"""URDF of the hand, generated from a :class:`~.hand.HandModel`.

Joint names equal ``PARAM_NAMES`` (the JointState names the tracker publishes), so
``robot_state_publisher`` can display the tracked hand. The global DOF are three prismatic
joints (x, y, z) and three revolute joints in the chain order ``hand_ry, hand_rz, hand_rx``
through massless dummy links from the root link, then the palm. Each finger joint with two
DOF (thumb CMC, finger MCP) is an abduction joint (axis -z) followed by a flexion joint
(axis +x) through a dummy link, exactly as in :mod:`.kinematics`. Visuals are the sphere-mesh
spheres and, for each pill, a cylinder of the mean radius between its two spheres.

The joints are one table, :func:`urdf_joints` (name, type, parent and child link, origin
``T_parent_joint`` and axis), from which both the URDF text and the TF of a pose
(:func:`joint_transforms`) are made, so RViz's TF and RobotModel displays agree by
construction. A joint with origin ``T_o`` and unit axis ``a`` at value ``q`` gives

    T_parent_child = T_o Trans(a q)          (prismatic, q in m)
    T_parent_child = T_o Rot(a, q)           (revolute, q in rad)

and chaining them from the root link gives each link's pose, equal to the model's
``bone_transforms`` for the bone links (tested).
"""
from __future__ import annotations

import xml.etree.ElementTree as ET
from dataclasses import dataclass

import numpy as np

from hand_tracker_ros._typing import FloatArray
from hand_tracker_ros.checks import check_shape
from hand_tracker_ros.geometry.rotations import matrix_from_axis_angle
from hand_tracker_ros.model.hand import HandModel
from hand_tracker_ros.model.layout import GLOBAL_ROTATION_CHAIN, PARAM_NAMES
from hand_tracker_ros.model.skeleton import BONE_NAMES, BONE_PARENTS

_FMT = '{:.6g}'


def _vec(values: np.ndarray) -> str:
    # Rounded to 1e-9 (nm, nrad) first: the last bits of the kinematic chain's products differ
    # between BLAS builds, and the file must not change with the machine that wrote it.
    return ' '.join(_FMT.format(float(v) + 0.0) for v in np.round(values, 9))


def _rpy(rot: np.ndarray) -> np.ndarray:
    """URDF fixed-axis roll-pitch-yaw of ``rot``: R = Rz(yaw) Ry(pitch) Rx(roll)."""
    pitch = np.arcsin(np.clip(-rot[2, 0], -1.0, 1.0))
    roll = np.arctan2(rot[2, 1], rot[2, 2])
    yaw = np.arctan2(rot[1, 0], rot[0, 0])
    return np.array([roll, pitch, yaw])


@dataclass(frozen=True, slots=True)
class UrdfJoint:
    """One joint of the hand's URDF.

    Attributes
    ----------
    name : str
        A PARAM_NAMES entry (the JointState name).
    kind : str
        'prismatic' or 'revolute'.
    parent, child : str
        Link names.
    T_parent_joint : (4, 4) float64
        The joint's origin in the parent link's frame.
    axis : (3,) float64
        Unit axis in the joint frame.
    limits : tuple of float
        Lower and upper limit (m or rad).
    """

    name: str
    kind: str
    parent: str
    child: str
    T_parent_joint: FloatArray
    axis: FloatArray
    limits: tuple[float, float]


def _joint(robot: ET.Element, joint: UrdfJoint) -> None:
    element = ET.SubElement(robot, 'joint', name=joint.name, type=joint.kind)
    ET.SubElement(element, 'parent', link=joint.parent)
    ET.SubElement(element, 'child', link=joint.child)
    ET.SubElement(element, 'origin', xyz=_vec(joint.T_parent_joint[:3, 3]),
                  rpy=_vec(_rpy(joint.T_parent_joint[:3, :3])))
    ET.SubElement(element, 'axis', xyz=_vec(joint.axis))
    ET.SubElement(element, 'limit', lower=_FMT.format(joint.limits[0]),
                  upper=_FMT.format(joint.limits[1]), effort='1', velocity='10')


def _link(robot: ET.Element, name: str) -> ET.Element:
    return ET.SubElement(robot, 'link', name=name)


def _visual(link: ET.Element, xyz: np.ndarray, rpy: np.ndarray, geometry: str,
            **size: str) -> None:
    visual = ET.SubElement(link, 'visual')
    ET.SubElement(visual, 'origin', xyz=_vec(xyz), rpy=_vec(rpy))
    ET.SubElement(ET.SubElement(visual, 'geometry'), geometry, attrib=size)
    ET.SubElement(visual, 'material', name='skin')


def _add_visuals(links: dict[int, ET.Element], model: HandModel) -> None:
    local = model.sphere_local_m
    rest_t = model.rest_bone_transforms
    for s, bone in enumerate(model.sphere_part):
        _visual(links[int(bone)], local[s], np.zeros(3), 'sphere',
                radius=_FMT.format(model.sphere_radii_m[s]))
    for s0, s1 in model.pills:
        bone = int(model.sphere_part[s1])
        # The pill's first sphere may belong to the parent: express it in this bone's frame.
        p0 = np.linalg.inv(rest_t[bone]) @ rest_t[model.sphere_part[s0]] @ [*local[s0], 1.0]
        p1 = local[s1]
        length = float(np.linalg.norm(p1 - p0[:3]))
        radius = 0.5 * (model.sphere_radii_m[s0] + model.sphere_radii_m[s1])
        # Cylinders run along their local z; the bone runs along +y: roll by -90 deg.
        _visual(links[bone], 0.5 * (p0[:3] + p1), np.array([-np.pi / 2, 0.0, 0.0]),
                'cylinder', radius=_FMT.format(radius), length=_FMT.format(length))


def _origin(xyz: FloatArray, rot: FloatArray) -> FloatArray:
    T = np.eye(4)
    T[:3, :3] = rot
    T[:3, 3] = xyz
    return T


def _global_chain(root_link: str, prefix: str, limit: dict[str, tuple[float, float]]
                  ) -> list[UrdfJoint]:
    """3 prismatic and 3 revolute global joints from the root link through dummy links."""
    unit = dict(zip(('x', 'y', 'z'), np.eye(3)))
    chain = [(f'hand_t{a}', 'prismatic', unit[a]) for a in 'xyz']
    chain += [(name, 'revolute', unit[name[-1]]) for name in GLOBAL_ROTATION_CHAIN]
    joints, parent = [], root_link
    for name, kind, axis in chain:
        child = f'{prefix}{name}_link' if name != chain[-1][0] else f'{prefix}palm'
        joints.append(UrdfJoint(name, kind, parent, child, np.eye(4), axis, limit[name]))
        parent = child
    return joints


def urdf_joints(model: HandModel, *, root_link: str = 'world', prefix: str = ''
                ) -> tuple[UrdfJoint, ...]:
    """The joints of the URDF of ``model``, parents before children (see :func:`urdf_text`)."""
    limit = dict(zip(PARAM_NAMES, zip(model.lower.tolist(), model.upper.tolist())))
    joints = _global_chain(root_link, prefix, limit)
    rest_t = model.rest_bone_transforms
    for bone in range(1, len(BONE_NAMES)):
        finger, seg = divmod(bone - 1, 3)
        dof0 = 6 + 4 * finger
        rel = np.linalg.inv(rest_t[BONE_PARENTS[bone]]) @ rest_t[bone]
        parent = f'{prefix}{BONE_NAMES[BONE_PARENTS[bone]]}'
        child = f'{prefix}{BONE_NAMES[bone]}'
        if seg == 0:
            abd = PARAM_NAMES[dof0 + 1]
            joints.append(UrdfJoint(abd, 'revolute', parent, f'{child}_abd',
                                    _origin(rel[:3, 3], rel[:3, :3]), -np.eye(3)[2], limit[abd]))
            parent, name, rel = f'{child}_abd', PARAM_NAMES[dof0], np.eye(4)
        else:
            name = PARAM_NAMES[dof0 + 1 + seg]
        joints.append(UrdfJoint(name, 'revolute', parent, child,
                                _origin(rel[:3, 3], rel[:3, :3]), np.eye(3)[0], limit[name]))
    return tuple(joints)


def joint_transforms(joints: tuple[UrdfJoint, ...], theta: FloatArray) -> FloatArray:
    """``T_parent_child`` of every joint at the pose ``theta``.

    Parameters
    ----------
    joints : tuple of UrdfJoint, length J
        From :func:`urdf_joints`.
    theta : (P,) float64
        Pose in PARAM_NAMES order (m, rad).

    Returns
    -------
    (J, 4, 4) float64
        The child link's frame in the parent link's frame, in the order of ``joints``.
    """
    theta = np.asarray(theta, dtype=np.float64)
    check_shape('theta', theta, (len(PARAM_NAMES),))
    out = np.zeros((len(joints), 4, 4))
    for j, joint in enumerate(joints):
        q = theta[PARAM_NAMES.index(joint.name)]
        motion = np.eye(4)
        if joint.kind == 'prismatic':
            motion[:3, 3] = joint.axis * q
        else:
            motion[:3, :3] = matrix_from_axis_angle(joint.axis * q)
        out[j] = joint.T_parent_joint @ motion
    return out


def urdf_text(model: HandModel, *, root_link: str = 'world', prefix: str = '') -> str:
    """URDF XML text of ``model``.

    Parameters
    ----------
    model : HandModel
    root_link : str
        Name of the root link the global joints hang from (e.g. 'world' or a camera frame).
    prefix : str
        Prefix for the link names (joint names stay PARAM_NAMES so JointState matches).
    """
    robot = ET.Element('robot', name='hand')
    ET.SubElement(ET.SubElement(robot, 'material', name='skin'), 'color', rgba='0.9 0.7 0.6 1')
    _link(robot, root_link)
    links = {}
    for joint in urdf_joints(model, root_link=root_link, prefix=prefix):
        links[joint.child] = _link(robot, joint.child)
        _joint(robot, joint)
    _add_visuals({b: links[f'{prefix}{name}'] for b, name in enumerate(BONE_NAMES)}, model)
    ET.indent(robot)
    return ET.tostring(robot, encoding='unicode')
