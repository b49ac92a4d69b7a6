"""`hand-tracker topics list/echo/hz` against a publisher in this process."""
from __future__ import annotations

import io
import threading
from collections.abc import Iterator

import pytest
import yaml

pytestmark = pytest.mark.ros
TOPIC = '/topic_tools_test/joint_states'


@pytest.fixture()
def publisher() -> Iterator[None]:
    """A JointState on TOPIC every 50 ms, from its own context and thread, until the test
    ends (``position`` carries the message index)."""
    import rclpy
    from rclpy.executors import ExternalShutdownException, SingleThreadedExecutor
    from sensor_msgs.msg import JointState

    context = rclpy.Context()
    rclpy.init(context=context)
    node = rclpy.create_node('topic_tools_publisher', context=context)
    pub = node.create_publisher(JointState, TOPIC, 10)
    sent = [0]

    def tick() -> None:
        pub.publish(JointState(name=['a', 'b'], position=[float(sent[0]), 0.5],
                               velocity=[float(v) for v in range(40)]))
        sent[0] += 1

    node.create_timer(0.05, tick)
    executor = SingleThreadedExecutor(context=context)
    executor.add_node(node)

    def spin() -> None:
        try:
            executor.spin()
        except ExternalShutdownException:   # the fixture's teardown
            pass

    thread = threading.Thread(target=spin, daemon=True)
    thread.start()
    yield
    rclpy.try_shutdown(context=context)
    thread.join(timeout=10)


def test_list_echo_and_hz(publisher) -> None:
    from hand_tracker_ros.ros_io import topic_tools

    lines = topic_tools.list_topics(wait_s=2.0, verbose=True)
    assert any(line.startswith(f'{TOPIC} [sensor_msgs/msg/JointState]  publishers: 1')
               for line in lines), lines

    out = io.StringIO()
    assert topic_tools.echo(TOPIC.lstrip('/'), out, count=2, wait_s=10.0, max_items=4) == 2
    docs = [d for d in yaml.safe_load_all(out.getvalue()) if d]
    assert len(docs) == 2
    assert docs[0]['name'] == ['a', 'b'] and docs[0]['position'][1] == 0.5
    assert docs[0]['velocity'] == [0.0, 1.0, 2.0, 3.0, '... 36 more']
    assert set(docs[0]['header']['stamp']) == {'sec', 'nanosec'}
    assert docs[1]['position'][0] > docs[0]['position'][0]

    out = io.StringIO()
    received = topic_tools.hz(TOPIC, out, duration_s=2.0, wait_s=10.0, window=100)
    assert received >= 3
    assert 'average rate: ' in out.getvalue()


def test_unknown_topic_is_a_clear_error() -> None:
    from hand_tracker_ros.errors import HandTrackerError
    from hand_tracker_ros.ros_io import topic_tools

    with pytest.raises(HandTrackerError, match=r'topic /no_such_topic not found in the graph'):
        topic_tools.echo('/no_such_topic', io.StringIO(), count=1, wait_s=0.5, max_items=4)
