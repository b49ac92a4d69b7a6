"""ROS parameters declared from config dataclasses: overrides, ranges, live validation."""
from __future__ import annotations

import pytest

from hand_tracker_ros.node_config import TrackerNodeConfig

pytestmark = pytest.mark.ros


@pytest.fixture()
def context():
    import rclpy

    ctx = rclpy.Context()
    rclpy.init(context=ctx)
    yield ctx
    rclpy.try_shutdown(context=ctx)


def test_overrides_reach_the_config_and_live_changes_are_validated(context) -> None:
    from rclpy.node import Node
    from rclpy.parameter import Parameter

    from hand_tracker_ros.ros_io.params import declare_config

    changes = []
    node = Node('params_test', context=context, parameter_overrides=[
        Parameter('sync_slop_ms', Parameter.Type.DOUBLE, 8.0),
        Parameter('cameras', Parameter.Type.STRING_ARRAY, ['a', 'b'])])
    config = declare_config(node, TrackerNodeConfig, read_only=('cameras',),
                            on_change=changes.append)
    assert config.sync_slop_ms == 8.0 and config.cameras == ('a', 'b')
    descriptor = node.describe_parameter('sync_slop_ms')
    assert 'ms' in descriptor.description
    [ok] = node.set_parameters([Parameter('sync_queue_size', Parameter.Type.INTEGER, 20)])
    assert ok.successful and changes[-1].sync_queue_size == 20
    [bad] = node.set_parameters([Parameter('sync_queue_size', Parameter.Type.INTEGER, 0)])
    assert not bad.successful and 'sync_queue_size' in bad.reason
    [fixed] = node.set_parameters([Parameter('cameras', Parameter.Type.STRING_ARRAY, ['c'])])
    assert not fixed.successful
    node.destroy_node()
