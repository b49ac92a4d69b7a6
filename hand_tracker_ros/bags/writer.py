"""Write rosbag2 bags (mcap or sqlite3, metadata version 9) with rosbags, without ROS.

Messages are serialized to CDR with the shared type store
(:func:`hand_tracker_ros.bags.typestore.typestore`), which also supplies each topic's message
definition and RIHS01 type hash. Each topic records the QoS profile its publisher would offer,
so ``ros2 bag play`` (and our player) replays camera topics best-effort and the rest reliable.
"""
from __future__ import annotations

import logging
from pathlib import Path
from types import TracebackType
from typing import Any, Literal

from rosbags.interfaces import (
    Connection,
    Qos,
    QosDurability,
    QosHistory,
    QosLiveliness,
    QosReliability,
    QosTime,
)
from rosbags.rosbag2 import StoragePlugin, Writer

from hand_tracker_ros.bags.typestore import typestore
from hand_tracker_ros.errors import BagFormatError

logger = logging.getLogger(__name__)

_STORAGES = {'mcap': StoragePlugin.MCAP, 'sqlite3': StoragePlugin.SQLITE3}
# {0, 0} is RMW_DURATION_UNSPECIFIED: the player uses its default (infinite) durations.
_UNSPECIFIED = QosTime(sec=0, nsec=0)


def _qos(reliability: QosReliability, depth: int,
         durability: QosDurability = QosDurability.VOLATILE) -> Qos:
    return Qos(history=QosHistory.KEEP_LAST, depth=depth, reliability=reliability,
               durability=durability, deadline=_UNSPECIFIED,
               lifespan=_UNSPECIFIED, liveliness=QosLiveliness.AUTOMATIC,
               liveliness_lease_duration=_UNSPECIFIED, avoid_ros_namespace_conventions=False)


# rclpy's defaults for outputs (reliable, depth 10), qos_profile_sensor_data, and a latched
# topic (transient local, depth 1: robot_description), replayed to late subscribers.
QOS_PROFILES = {'reliable': _qos(QosReliability.RELIABLE, 10),
                'sensor_data': _qos(QosReliability.BEST_EFFORT, 5),
                'latched': _qos(QosReliability.RELIABLE, 1, QosDurability.TRANSIENT_LOCAL)}


class BagWriter:
    """Context manager writing one new rosbag2 bag directory.

    Parameters
    ----------
    path : str or Path
        Bag directory to create; it must not exist.
    storage : {'mcap', 'sqlite3'}
        Storage plugin.

    Examples
    --------
    >>> with BagWriter(out_dir) as bag:                                # doctest: +SKIP
    ...     bag.add_topic('/cam0/image_raw', 'sensor_msgs/msg/Image', qos='sensor_data')
    ...     bag.write('/cam0/image_raw', stamp_ns, image_msg(rgb, stamp_ns, 'cam0'))
    """

    def __init__(self, path: str | Path, *, storage: Literal['mcap', 'sqlite3'] = 'mcap'
                 ) -> None:
        self.path = Path(path)
        if storage not in _STORAGES:
            msg = f'unknown bag storage {storage!r} (use one of {", ".join(_STORAGES)})'
            raise BagFormatError(msg)
        if self.path.exists():
            msg = f'{self.path}: refusing to overwrite an existing path'
            raise BagFormatError(msg)
        self.storage = storage
        self._writer: Writer | None = None
        self._connections: dict[str, Connection] = {}

    def __enter__(self) -> BagWriter:
        self._writer = Writer(self.path, version=9, storage_plugin=_STORAGES[self.storage])
        self._writer.open()
        return self

    def __exit__(self, exc_type: type[BaseException] | None, exc: BaseException | None,
                 tb: TracebackType | None) -> None:
        self.close()

    def close(self) -> None:
        """Finish the bag (writes ``metadata.yaml``); a second call does nothing."""
        if self._writer is not None:
            writer, self._writer = self._writer, None
            writer.close()
            logger.debug('closed bag %s', self.path)

    def _open_writer(self) -> Writer:
        if self._writer is None:
            msg = f'{self.path}: the bag is not open (use `with BagWriter(...) as bag:`)'
            raise BagFormatError(msg)
        return self._writer

    def add_topic(self, topic: str, msgtype: str, *,
                  qos: Literal['reliable', 'sensor_data', 'latched'] = 'reliable') -> None:
        """Declare ``topic`` with ROS 2 type ``msgtype`` (e.g. ``sensor_msgs/msg/Image``).

        Raises
        ------
        BagFormatError
            If the topic exists, the type is unknown to the type store, or ``qos`` is unknown.
        """
        writer = self._open_writer()
        store = typestore()
        if topic in self._connections:
            msg = f'{self.path}: topic {topic!r} was already added'
            raise BagFormatError(msg)
        if msgtype not in store.fielddefs:
            msg = f'{self.path}: unknown message type {msgtype!r} for topic {topic!r}'
            raise BagFormatError(msg)
        if qos not in QOS_PROFILES:
            msg = f'{self.path}: unknown qos {qos!r} for {topic!r} (use {", ".join(QOS_PROFILES)})'
            raise BagFormatError(msg)
        self._connections[topic] = writer.add_connection(
            topic, msgtype, typestore=store, offered_qos_profiles=[QOS_PROFILES[qos]])

    def _connection(self, topic: str) -> Connection:
        connection = self._connections.get(topic)
        if connection is None:
            msg = f'{self.path}: topic {topic!r} was not added (call add_topic first)'
            raise BagFormatError(msg)
        return connection

    def write(self, topic: str, stamp_ns: int, msg: Any) -> None:
        """Serialize ``msg`` (a type store message of the topic's type) and write it.

        ``stamp_ns`` is the bag (receive) time in int ns; it is usually the header stamp.
        """
        connection = self._connection(topic)
        try:
            raw = typestore().serialize_cdr(msg, connection.msgtype)
        except (AttributeError, TypeError, ValueError, KeyError) as err:
            text = (f'{self.path}: cannot serialize {type(msg).__name__} as '
                    f'{connection.msgtype} on {topic!r}: {err}')
            raise BagFormatError(text) from err
        self._open_writer().write(connection, int(stamp_ns), raw)

    def write_raw(self, topic: str, stamp_ns: int, raw: bytes | memoryview) -> None:
        """Write already serialized CDR bytes (e.g. from a raw subscription) unchanged."""
        self._open_writer().write(self._connection(topic), int(stamp_ns), raw)
