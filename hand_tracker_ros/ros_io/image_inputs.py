"""A node's camera images as whole synchronized sets (the distributed graph's image readers).

The features and salient_points processes read every camera's images. Processed one camera
at a time as they came, a process that fell behind dropped different frames per camera, and
its outputs stopped making sets at the tracker; :class:`ImageInputs` groups them by stamp and
serves the newest complete set.
"""
from __future__ import annotations

import functools
import traceback
from collections.abc import Callable, Sequence
from functools import partial

import rclpy
from rclpy.node import Node
from sensor_msgs.msg import CameraInfo, CompressedImage, Image
from std_msgs.msg import Header

from hand_tracker_ros._typing import UInt8Array
from hand_tracker_ros.bags.convert import stamp_ns_of
from hand_tracker_ros.bags.image_codec import image_from_msg
from hand_tracker_ros.errors import HandTrackerError
from hand_tracker_ros.pipeline.live import NewestSetWorker
from hand_tracker_ros.ros_io.images import image_input, intrinsics_from_info, sensor_qos
from hand_tracker_ros.sync.approximate import ApproximateTimeSync, SyncConfig, SyncedSet


class ImageSet:
    """One synchronized set of camera images, cameras in the node's order, decoded when first
    read: a node that skips the set (:mod:`.plans`) never decodes it (a compressed image costs
    a JPEG or PNG decode).

    Parameters
    ----------
    cameras : tuple of str
    msgs : sequence of sensor_msgs/Image or sensor_msgs/CompressedImage
        The set's image messages, in ``cameras`` order.
    sizes : dict of str to (width, height)
        Each camera's image size from its latest valid camera_info, where one came.

    Attributes
    ----------
    cameras : tuple of str
    headers : tuple of std_msgs/Header
        The input messages' headers (stamps and frame ids to publish with).
    """

    def __init__(self, cameras: tuple[str, ...], msgs: Sequence[Image | CompressedImage],
                 sizes: dict[str, tuple[int, int]]) -> None:
        self.cameras = cameras
        self.headers: tuple[Header, ...] = tuple(m.header for m in msgs)
        self._msgs = tuple(msgs)
        self._sizes = dict(sizes)

    @functools.cached_property
    def images_rgb(self) -> tuple[UInt8Array, ...]:
        """(H, W, 3) uint8 per camera, each of its camera_info's latest valid size.

        Raises
        ------
        HandTrackerError
            An image that cannot be decoded, or of another size than its camera_info.
        """
        return tuple(image_from_msg(m, source=c, expected_size_px=self._sizes.get(c))
                     for c, m in zip(self.cameras, self._msgs))


class ImageInputs:
    """Every camera's image and camera_info subscriptions; whole synchronized sets on a
    worker thread, the newest first.

    Subscribes (sensor-data QoS) to ``<cam>/<image_topic>`` (``sensor_msgs/Image``) or, with
    ``transport='compressed'``, to ``<cam>/<image_topic>/compressed``
    (``sensor_msgs/CompressedImage``, image_transport's naming), and to ``<cam>/camera_info``,
    whose latest valid size each decoded image must have. Image messages are grouped by
    stamp (:mod:`hand_tracker_ros.sync.approximate`, ``slop_ms``); each complete set goes to a
    :class:`~hand_tracker_ros.pipeline.live.NewestSetWorker`, which calls ``on_set`` with it
    (:class:`ImageSet`, decoded when read): a node that falls behind drops whole sets, and the
    sets it serves line up across cameras. A set with an image that cannot be decoded is
    dropped with a throttled error.

    Parameters
    ----------
    node : rclpy.node.Node
        The node that owns the subscriptions and logs errors (throttled).
    cameras : sequence of str
        Camera namespaces.
    image_topic : str
        Image topic relative to each camera namespace.
    transport : str
        ``raw`` or ``compressed``.
    depth : int
        Queue depth per subscription.
    on_set : callable
        Called with each :class:`ImageSet` (on the worker thread).
    throttle_s : float
        Minimum period of repeated errors, s.
    slop_ms : float
        Largest stamp spread within one set, ms.
    """

    def __init__(self, node: Node, cameras: Sequence[str], image_topic: str, transport: str,
                 depth: int, on_set: Callable[[ImageSet], None], throttle_s: float,
                 slop_ms: float) -> None:
        self._node = node
        self._throttle_s = throttle_s
        self._cameras = tuple(cameras)
        self._on_set = on_set
        self._sizes: dict[str, tuple[int, int]] = {}
        self._sync = ApproximateTimeSync(self._cameras, SyncConfig(slop_ns=round(slop_ms * 1e6)))
        self._worker: NewestSetWorker[SyncedSet] = NewestSetWorker(
            self._serve_set, self._on_error, f'{node.get_name()}-sets')
        qos = sensor_qos(depth)
        msg_type, topic = image_input(transport, image_topic)
        for cam in self._cameras:
            node.create_subscription(msg_type, f'{cam}/{topic}', partial(self._on_image, cam),
                                     qos)
            node.create_subscription(CameraInfo, f'{cam}/camera_info',
                                     partial(self._on_info, cam), qos)

    def close(self) -> None:
        """Stop the worker thread (the set in progress is finished)."""
        self._worker.close()

    def _on_image(self, camera: str, msg: Image | CompressedImage) -> None:
        """(Executor thread.) One camera's image into the synchronizer."""
        for synced in self._sync.add(camera, stamp_ns_of(msg.header), msg):
            self._worker.offer(synced)

    def _on_info(self, camera: str, msg: CameraInfo) -> None:
        """camera_info callback; an invalid one is logged (throttled) and ignored."""
        try:
            width, height, *_ = intrinsics_from_info(msg, camera)
        except HandTrackerError as err:
            self._node.get_logger().error(str(err), throttle_duration_sec=self._throttle_s)
            return
        self._sizes[camera] = (width, height)

    def _serve_set(self, synced: SyncedSet) -> None:
        """(Worker thread.) The set to ``on_set``, decoded when it reads the images; a decode
        error raised there is logged by :meth:`_on_error` like any failure of the set."""
        self._on_set(ImageSet(self._cameras, [synced.items[c] for c in self._cameras],
                              self._sizes))

    def summary(self) -> str:
        """Where the input sets went (for the log at shutdown)."""
        return (f'input: {self._sync.stats.summary()}, {self._worker.skipped} replaced by a '
                'newer one before the node was free')

    def _on_error(self, err: BaseException) -> None:
        """A set's failure: logged (throttled, with the traceback if it is not bad input)."""
        if not rclpy.ok(context=self._node.context):
            return
        text = (str(err) if isinstance(err, HandTrackerError)
                else ''.join(traceback.format_exception(err)))
        self._node.get_logger().error(f'dropping a set: {text}',
                                      throttle_duration_sec=self._throttle_s)
