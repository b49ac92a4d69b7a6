"""config/hand_tracker.rviz and config/foxglove_layout.json: they parse, and every topic they
name is one the tracker graph publishes (hand_tracker_ros.topics), in its world frame."""
from __future__ import annotations

import json
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import yaml

from hand_tracker_ros import topics
from hand_tracker_ros.node_config import TrackerNodeConfig

CONFIG = Path(__file__).resolve().parents[1] / 'config'
HAND_STATE_MSG = CONFIG.parent / 'msg_defs' / 'hand_tracker_msgs' / 'msg' / 'HandState.msg'
SHOWN_IN_3D = {topics.TF.absolute, topics.MARKERS.absolute, topics.ROBOT_DESCRIPTION.absolute}


def _published() -> set[str]:
    overlays = {f'/{topics.overlay_topic(c)}' for c in TrackerNodeConfig().cameras}
    return {t.absolute for t in topics.TRACKER_OUTPUTS} | overlays


def _rviz_topics(node: Any) -> Iterator[tuple[str, dict]]:
    """(topic, its QoS block) of every display, nested groups included."""
    if isinstance(node, dict):
        for key, value in node.items():
            if key.endswith('Topic') and isinstance(value, dict) and 'Value' in value:
                yield value['Value'], value
            else:
                yield from _rviz_topics(value)
    elif isinstance(node, list):
        for item in node:
            yield from _rviz_topics(item)


def _panel_ids(tree: Any) -> Iterator[str]:
    if isinstance(tree, str):
        yield tree
    else:
        yield from _panel_ids(tree['first'])
        yield from _panel_ids(tree['second'])


def _foxglove_topics(layout: dict) -> tuple[set[str], list[str]]:
    """Topics the panels name, and the message paths the plots read."""
    named, paths = set(), []
    for panel_id, config in layout['configById'].items():
        kind = panel_id.split('!')[0]
        if kind == '3D':
            named |= set(config['topics'])
            named |= {layer['topic'] for layer in config['layers'].values()
                      if layer.get('sourceType') == 'topic'}
        elif kind == 'Image':
            named.add(config['imageMode']['imageTopic'])
        elif kind == 'Plot':
            paths += [p['value'] for p in config['paths']]
        elif kind == 'DiagnosticSummary':
            named.add(config['topicToRender'])
        else:
            raise AssertionError(f'unexpected panel {panel_id}')
    named |= {p.split('.')[0] for p in paths}
    return named, paths


def test_rviz_config_shows_the_graphs_topics_in_the_world_frame() -> None:
    config = yaml.safe_load((CONFIG / 'hand_tracker.rviz').read_text())
    manager = config['Visualization Manager']
    assert manager['Global Options']['Fixed Frame'] == TrackerNodeConfig().world_frame
    named = dict(_rviz_topics(manager['Displays']))
    assert set(named) <= _published(), set(named) - _published()
    classes = {d['Class'] for d in manager['Displays']}
    assert {'rviz_default_plugins/TF', 'rviz_default_plugins/RobotModel',
            'rviz_default_plugins/MarkerArray', 'rviz_default_plugins/Image'} <= classes
    assert SHOWN_IN_3D - {topics.TF.absolute} <= set(named)     # the TF display reads /tf
    # The description is latched: only a transient-local subscription gets it.
    assert named[topics.ROBOT_DESCRIPTION.absolute]['Durability Policy'] == 'Transient Local'


def test_foxglove_layout_shows_the_graphs_topics() -> None:
    layout = json.loads((CONFIG / 'foxglove_layout.json').read_text())
    assert set(_panel_ids(layout['layout'])) == set(layout['configById'])
    named, paths = _foxglove_topics(layout)
    assert named <= _published(), named - _published()
    assert SHOWN_IN_3D <= named
    assert layout['configById']['3D!hand']['followTf'] == TrackerNodeConfig().world_frame
    fields = {line.split()[1] for line in HAND_STATE_MSG.read_text().splitlines()
              if line.strip() and not line.startswith('#') and '=' not in line}
    for path in paths:
        topic, field = path.split('.', 1)
        assert topic == topics.STATE.absolute and field in fields, path
