"""Node-level configuration: topology, topics and frames of each node.

One frozen dataclass per node; the node declares its ROS parameters from it
(``ros_io.params.declare_config``), and the launcher writes parameter files from it. Core
components (features, detector, tracker) nest their own config dataclasses here as they land.
"""
from __future__ import annotations

from dataclasses import dataclass

from hand_tracker_ros.bags.playback import PlaybackConfig
from hand_tracker_ros.config import nested, param
from hand_tracker_ros.graph_nodes import NODES
from hand_tracker_ros.model.poses import NEUTRAL_THETA
from hand_tracker_ros.tracking.attention import AttentionConfig
from hand_tracker_ros.tracking.session import SessionConfig
from hand_tracker_ros.tracking.tracker import TrackerConfig
from hand_tracker_ros.vision.detector.detector import DetectorConfig
from hand_tracker_ros.vision.features import FeaturesConfig
from hand_tracker_ros.vision.resolution import LIVE_WIDTH_PX

DEFAULT_CAMERAS = ('cam0', 'cam1', 'cam2', 'cam3')
IMAGE_TRANSPORTS = ('raw', 'compressed')


@dataclass(frozen=True)
class FeaturesNodeConfig:
    """The `features` node: edges, foreground mask and optical flow per camera."""

    cameras: tuple[str, ...] = param(DEFAULT_CAMERAS, 'camera namespaces served by this node')
    image_topic: str = param('image_raw', 'image topic, relative to each camera namespace')
    image_transport: str = param('raw', "'raw': sensor_msgs/Image on <cam>/<image_topic>; "
                                 "'compressed': sensor_msgs/CompressedImage (jpeg, png) on "
                                 '<cam>/<image_topic>/compressed', choices=IMAGE_TRANSPORTS)
    queue_depth: int = param(2, 'subscription queue depth per camera', low=1, high=100)
    sync_slop_ms: float = param(16.0, 'largest stamp spread within one camera set; whole sets '
                                'are served, the newest first', unit='ms', low=0.1,
                                high=1000.0)
    working_width_px: int = param(LIVE_WIDTH_PX, 'observe images wider than this scaled '
                                  'down to it (vision/resolution.py); the tracker\'s '
                                  'working_width_px must be the same', unit='px', low=0,
                                  high=100000)
    follow_plan: bool = param(True, "observe one set per plan of the tracker on "
                              "'hand/observation_plan', in its regions of interest "
                              '(ros_io/plans.py); without a recent plan, every set whole')
    features: FeaturesConfig = nested(FeaturesConfig)


@dataclass(frozen=True)
class SalientPointsNodeConfig:
    """The `salient_points` node: fingertip candidates per camera."""

    cameras: tuple[str, ...] = param(DEFAULT_CAMERAS, 'camera namespaces served by this node')
    image_topic: str = param('image_raw', 'image topic, relative to each camera namespace')
    image_transport: str = param('raw', "'raw': sensor_msgs/Image on <cam>/<image_topic>; "
                                 "'compressed': sensor_msgs/CompressedImage (jpeg, png) on "
                                 '<cam>/<image_topic>/compressed', choices=IMAGE_TRANSPORTS)
    queue_depth: int = param(2, 'subscription queue depth per camera', low=1, high=100)
    sync_slop_ms: float = param(16.0, 'largest stamp spread within one camera set; whole sets '
                                'are served, the newest first', unit='ms', low=0.1,
                                high=1000.0)
    working_width_px: int = param(LIVE_WIDTH_PX, 'observe images wider than this scaled '
                                  'down to it (vision/resolution.py); the tracker\'s '
                                  'working_width_px must be the same', unit='px', low=0,
                                  high=100000)
    follow_plan: bool = param(True, "detect in one set per plan of the tracker on "
                              "'hand/observation_plan', in its regions of interest, when it "
                              'asks for detection (ros_io/plans.py); without a recent plan, '
                              'in every set whole')
    detector: DetectorConfig = nested(DetectorConfig)


# The model's neutral pose, wrist at the world origin (one definition: model/poses.py).
NEUTRAL_POSE = NEUTRAL_THETA


@dataclass(frozen=True)
class TrackerNodeConfig:
    """The `tracker` node: synchronized multi-camera model fitting."""

    cameras: tuple[str, ...] = param(DEFAULT_CAMERAS, 'camera namespaces to use; each must be '
                                     'a camera of the rig file')
    rig_file: str = param('', 'rig YAML (intrinsics + extrinsics, geometry.rig schema); '
                          'required: without it the node refuses to start')
    shape_file: str = param('', 'hand shape YAML (model.shape_file schema, written by '
                            'hand-tracker calibrate); empty: the default hand')
    inputs: str = param('images', "'images': the composed graph, features and salient_points "
                        "run in this process on <cam>/<image_topic>; 'features': the "
                        'distributed graph, subscribe to the topics of features and '
                        'salient_points processes', choices=('images', 'features'))
    image_topic: str = param('image_raw', "with inputs 'images': image topic, relative to "
                             'each camera namespace')
    image_transport: str = param('raw', "with inputs 'images': 'raw' sensor_msgs/Image or "
                                 "'compressed' (jpeg, png) on <cam>/<image_topic>/compressed",
                                 choices=IMAGE_TRANSPORTS)
    attention: AttentionConfig = nested(AttentionConfig)
    working_width_px: int = param(LIVE_WIDTH_PX, 'track wider images scaled down to this width '
                                  '(vision/resolution.py): a 640x480 rig then costs what a '
                                  '320x240 one does, at about twice its error; 0: at their '
                                  "own size. With inputs 'features' the features and "
                                  "salient_points nodes' working_width_px must be the same",
                                  unit='px', low=0, high=100000)
    budget_ms: float = param(0.0, "time for one set's main fit: a correspondence round that "
                             'would end later is not started; 0 = the measured period '
                             'between input sets', unit='ms', low=0.0, high=10000.0)
    warm_up: bool = param(True, 'load the JIT kernels (tracking a few synthetic frames) '
                          'before subscribing, so the first set is tracked at full speed')
    world_frame: str = param('world', 'fixed frame of every output (the rig\'s world frame)')
    sync_slop_ms: float = param(16.0, 'largest stamp spread within one camera set', unit='ms',
                                low=0.1, high=1000.0)
    sync_queue_size: int = param(10, 'messages kept per camera while waiting for a set',
                                 low=1, high=1000)
    queue_depth: int = param(2, 'subscription queue depth per topic (sensor-data QoS)',
                             low=1, high=100)
    optional_wait_ms: float = param(100.0, 'how long a camera frame whose edges, orientation '
                                    'and mask are in waits for flow and salient points',
                                    unit='ms', low=0.0, high=5000.0)
    max_pending_frames: int = param(8, 'incomplete frames kept per camera (oldest dropped)',
                                    low=1, high=1000)
    initial_pose: tuple[float, ...] = param(NEUTRAL_POSE, 'start pose, 26 numbers in '
                                            'JointState order (m, rad), with '
                                            'initialization: initial_pose (and the restart '
                                            'pose with restart_at_initial_pose)')
    initialization: str = param('observations', 'first pose: search the hand in the '
                                'observations, or use initial_pose',
                                choices=('observations', 'initial_pose'))
    restart_at_initial_pose: bool = param(False, 'after session.failure.reinit_after lost '
                                          'frames, reset to initial_pose (a user who shows '
                                          'that pose to restart) instead of searching the '
                                          'observations')
    session: SessionConfig = nested(SessionConfig)
    publish_mesh: bool = param(False, 'add the model mesh (TRIANGLE_LIST) to `hand/markers`')
    publish_tf: bool = param(True, 'publish /tf: every URDF joint of the hand at the estimate '
                             '(off when another node, e.g. robot_state_publisher, does)')
    publish_overlay: bool = param(False, 'publish <cam>/overlay: the model drawn on the input')
    optical_frame_suffix: str = param('_optical_frame', 'frame id of <cam>/overlay is the '
                                      'camera name plus this suffix (REP 103 optical frame)')
    overlay_source: str = param('mask', 'image the overlay is drawn on',
                                choices=('mask', 'edges'))
    diagnostics_period_s: float = param(1.0, 'period of /diagnostics', unit='s', low=0.1,
                                        high=60.0)
    tracking: TrackerConfig = nested(TrackerConfig)


@dataclass(frozen=True)
class PlayerNodeConfig:
    """The `player` node: replays a rosbag2 (sqlite3 or mcap) on its original topics."""

    bag: str = param('', 'bag directory or .mcap file to play; empty: stay idle')
    playback: PlaybackConfig = nested(PlaybackConfig)
    publish_clock: bool = param(True, 'publish /clock (bag time) before each message with a '
                                'new bag time, for use_sim_time; the bag\'s own /clock is then '
                                'not played')
    start_paused: bool = param(False, 'wait for `false` on ~/pause (std_msgs/Bool) to start')
    wait_for_subscribers_s: float = param(
        5.0, 'before playing, wait up to this long until every topic of `wait_topics` has '
        'a subscriber; 0 = do not wait', unit='s', low=0.0)
    wait_topics: tuple[str, ...] = param((), 'output topics to wait for; empty = every '
                                         'played topic')
    wait_subscriber_count: int = param(1, 'subscribers every topic of `wait_topics` must have '
                                       '(DDS matches each publisher-subscriber pair on its own, '
                                       'so one subscriber says nothing of a second)', low=1,
                                       high=1000)
    qos_reliability: str = param('bag', "publisher reliability: 'bag' = as recorded "
                                 '(best effort if every recorded publisher was)',
                                 choices=('bag', 'reliable', 'best_effort'))
    qos_depth: int = param(20, 'publisher queue depth (keep last)', low=1, high=10000)
    ack_timeout_s: float = param(5.0, 'at the end, wait up to this long until reliable '
                                 'subscribers acknowledged every message', unit='s', low=0.0)


@dataclass(frozen=True)
class RecorderNodeConfig:
    """The `recorder` node: records topics to a rosbag2 through raw subscriptions."""

    output: str = param('', 'output bag directory (must not exist); empty: stay idle')
    topics: tuple[str, ...] = param(('/hand/joint_states', '/hand/state'), 'topics to record')
    all_topics: bool = param(False, 'record every topic that appears in the graph')
    exclude_regex: str = param('', "topics fully matching this regex are not recorded; "
                               "'' = none")
    storage: str = param('mcap', 'bag storage plugin', choices=('mcap', 'sqlite3'))
    queue_depth: int = param(1000, 'subscription queue depth (keep last) per topic', low=1,
                             high=100000)
    discovery_period_s: float = param(0.1, 'period of the graph poll that finds the types '
                                      'of topics not yet recorded', unit='s', low=0.01,
                                      high=10.0)


def _config_class(node: str) -> type:
    """``features`` -> ``FeaturesNodeConfig``: every node's config class by its name."""
    return globals()[''.join(part.title() for part in node.split('_')) + 'NodeConfig']


#: Config class of every node of :data:`~hand_tracker_ros.graph_nodes.NODES`, in its order.
NODE_CONFIGS: dict[str, type] = {node: _config_class(node) for node in NODES}
