"""From a rosbag2 to synchronized multi-camera frame sets, calibration and ground truth.

The offline path uses the same approximate-time synchronizer as the live tracker node, so
jittered, dropped or late camera frames in a bag are handled exactly as they would be live.
Images that cannot be decoded are logged and dropped (the set they belonged to is then not
complete and is skipped, and counted by the synchronizer). Damage met while reading ends the
frame sets with a warning (:meth:`BagReader.intact_messages`): the sets before it are tracked.
"""
from __future__ import annotations

import logging
from collections.abc import Collection, Iterator, Sequence
from pathlib import Path

import numpy as np

from hand_tracker_ros.bags.convert import (
    CameraInfoValues,
    HandStateValues,
    camera_info_from_msg,
    hand_state_from_msg,
)
from hand_tracker_ros.bags.image_codec import image_from_msg
from hand_tracker_ros.bags.reader import BagReader, check_bag_path
from hand_tracker_ros.core.frames import FrameSet
from hand_tracker_ros.errors import BagFormatError, CalibrationError, HandTrackerError
from hand_tracker_ros.geometry.camera import PinholeCamera
from hand_tracker_ros.geometry.rig import CameraRig
from hand_tracker_ros.sync.approximate import ApproximateTimeSync, SyncConfig
from hand_tracker_ros.synthetic.writer import (
    GT_STATE_TOPIC,
    compressed_image_topic,
    image_topic,
    info_topic,
)

LOG = logging.getLogger(__name__)


def rig_file(bag: str | Path, rig_path: str | Path | None = None) -> Path:
    """The rig YAML of a bag: ``rig_path``, or ``rig.yaml`` beside the bag.

    Raises
    ------
    BagFormatError
        ``bag`` is not a bag (checked first, so a wrong bag path is reported as such).
    CalibrationError
        The rig file does not exist.
    """
    bag = Path(bag)
    check_bag_path(bag)
    path = Path(rig_path) if rig_path else bag.parent / 'rig.yaml'
    if not path.is_file():
        msg = (f'no rig calibration for {bag}: {path} does not exist (pass --rig with the '
               'rig YAML holding the cameras\' intrinsics and extrinsics; a bag\'s '
               'camera_info, if any, has no extrinsics)')
        raise CalibrationError(msg)
    return path


def load_rig(bag: str | Path, rig_path: str | Path | None = None) -> CameraRig:
    """The rig of a bag (:func:`rig_file`), checked against the bag's ``camera_info`` where it
    has one (image size and intrinsics must agree)."""
    path = rig_file(bag, rig_path)
    rig = CameraRig.from_yaml(path)
    with BagReader(bag) as reader:
        topics = reader.topics
        camera_image_topics(topics, rig.names, f'{bag} (rig {path})')
        unchecked = {info_topic(c.name) for c in rig.cameras if info_topic(c.name) in topics}
        for topic, msgtype, _, raw in reader.intact_messages(topics=sorted(unchecked)):
            if topic in unchecked:   # the first camera_info of each camera
                unchecked.discard(topic)
                info = camera_info_from_msg(reader.deserialize(raw, msgtype, topic=topic))
                _check_info(rig[topic.split('/')[1]], info, topic)
            if not unchecked:
                break
    return rig


def camera_image_topic(topics: Collection[str], camera: str) -> str | None:
    """The bag topic with ``camera``'s images: raw ``/<cam>/image_raw`` if the bag has it,
    else ``/<cam>/image_raw/compressed``, else None."""
    for topic in (image_topic(camera), compressed_image_topic(camera)):
        if topic in topics:
            return topic
    return None


def camera_image_topics(topics: Collection[str], cameras: Sequence[str], source: str
                        ) -> dict[str, str]:
    """Each camera's image topic (:func:`camera_image_topic`) -> the camera's name.

    Raises
    ------
    CalibrationError
        Naming ``source`` (the bag) and the cameras that have no image topic in ``topics``.
    """
    found = {name: camera_image_topic(topics, name) for name in cameras}
    missing = [name for name, topic in found.items() if topic is None]
    if missing:
        msg = (f'{source}: no image topic for camera(s) {missing} (looked for '
               f'{image_topic(missing[0])} and {compressed_image_topic(missing[0])})')
        raise CalibrationError(msg)
    return {topic: name for name, topic in found.items() if topic is not None}


def image_count(bag: str | Path, camera: str) -> int | None:
    """How many images of ``camera`` the bag holds (an upper bound of its frame sets), or
    None if that cannot be read without tracking (a damaged bag)."""
    try:
        with BagReader(bag) as reader:
            topic = camera_image_topic(reader.topics, camera)
            return None if topic is None else reader.topics[topic].count
    except BagFormatError:
        return None


def _check_info(camera: PinholeCamera, info: CameraInfoValues, topic: str) -> None:
    if (info.width, info.height) != (camera.width, camera.height):
        msg = (f'{topic}: camera_info says {info.width}x{info.height} but the rig says '
               f'{camera.width}x{camera.height}')
        raise CalibrationError(msg)
    if not np.allclose(info.K, camera.K, rtol=1e-6, atol=1e-6):
        msg = f'{topic}: camera_info K differs from the rig calibration'
        raise CalibrationError(msg)


def frame_sets(bag: str | Path, rig: CameraRig, *, sync: SyncConfig = SyncConfig()
               ) -> Iterator[FrameSet]:
    """Synchronized image sets of ``rig``'s cameras, in time order."""
    names = rig.names
    synchronizer = ApproximateTimeSync(names, sync)
    with BagReader(bag) as reader:
        topics = camera_image_topics(reader.topics, names, str(bag))
        for topic, msgtype, stamp, raw in reader.intact_messages(topics=list(topics)):
            try:
                image = image_from_msg(reader.deserialize(raw, msgtype, topic=topic),
                                       source=topic)
            except HandTrackerError as err:
                LOG.warning('dropping a frame: %s', err)
                continue
            camera = rig[topics[topic]]
            if image.shape[:2] != (camera.height, camera.width):
                LOG.warning('%s: dropping a %dx%d image, calibration says %dx%d', topic,
                            image.shape[1], image.shape[0], camera.width, camera.height)
                continue
            for synced in synchronizer.add(topics[topic], stamp, image):
                yield FrameSet(synced.stamp_ns, tuple(synced.items[n] for n in names))


def ground_truth(bag: str | Path) -> dict[int, HandStateValues]:
    """Ground-truth hand states of a synthetic bag, by stamp (empty if the bag has none)."""
    with BagReader(bag) as reader:
        if GT_STATE_TOPIC not in reader.topics:
            return {}
        return {stamp: hand_state_from_msg(reader.deserialize(raw, msgtype, topic=topic))
                for topic, msgtype, stamp, raw in reader.intact_messages([GT_STATE_TOPIC])}

