"""Node-level configuration: topology, topics and frames of each node.

One frozen dataclass per node; the node declares its ROS parameters from it
(``ros_io.params.declare_config``), and the launcher writes parameter files from it. Core
components (features, detector, tracker) nest their own config dataclasses here as they land.
"""
from __future__ import annotations

from dataclasses import dataclass

from hand_tracker_ros.config import nested, param
from hand_tracker_ros.vision.features import FeaturesConfig

DEFAULT_CAMERAS = ('cam0', 'cam1', 'cam2', 'cam3')


@dataclass(frozen=True)
class FeaturesNodeConfig:
    """The `features` node: edges, foreground mask and optical flow per camera."""

    cameras: tuple[str, ...] = param(DEFAULT_CAMERAS, 'camera namespaces served by this node')
    image_topic: str = param('image_raw', 'image topic, relative to each camera namespace')
    queue_depth: int = param(2, 'subscription queue depth per camera', low=1, high=100)
    features: FeaturesConfig = nested(FeaturesConfig)


@dataclass(frozen=True)
class SalientPointsNodeConfig:
    """The `salient_points` node: fingertip candidates per camera."""

    cameras: tuple[str, ...] = param(DEFAULT_CAMERAS, 'camera namespaces served by this node')
    image_topic: str = param('image_raw', 'image topic, relative to each camera namespace')
    queue_depth: int = param(2, 'subscription queue depth per camera', low=1, high=100)


@dataclass(frozen=True)
class TrackerNodeConfig:
    """The `tracker` node: synchronized multi-camera model fitting."""

    cameras: tuple[str, ...] = param(DEFAULT_CAMERAS, 'camera namespaces of the rig')
    rig_file: str = param('', 'rig YAML (intrinsics + extrinsics); empty: camera_info topics')
    world_frame: str = param('world', 'fixed frame of every output')
    sync_slop_ms: float = param(16.0, 'largest stamp spread within one camera set', unit='ms',
                                low=0.1, high=1000.0)
    sync_queue_size: int = param(10, 'messages kept per camera while waiting for a set',
                                 low=1, high=1000)


@dataclass(frozen=True)
class PlayerNodeConfig:
    """The `player` node: replays a rosbag2 (sqlite3 or mcap) on its original topics."""

    bag: str = param('', 'bag directory or .mcap file to play; empty: stay idle')
    rate: float = param(1.0, 'playback speed factor', low=0.01, high=100.0)
    loop: bool = param(False, 'restart from the beginning at the end of the bag')
    start_offset: float = param(0.0, 'seconds into the bag to start from', unit='s', low=0.0)
    publish_clock: bool = param(True, 'publish /clock before every message (use_sim_time)')


@dataclass(frozen=True)
class RecorderNodeConfig:
    """The `recorder` node: records topics to a rosbag2 mcap through raw subscriptions."""

    output: str = param('', 'output bag directory (must not exist); empty: stay idle')
    topics: tuple[str, ...] = param(('/joint_states', '/hand_state'), 'topics to record')
