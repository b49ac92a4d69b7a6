"""Read rosbag2 bags (sqlite3 or mcap, auto-detected) with rosbags' ``AnyReader``.

Accepted paths: a bag directory holding ``metadata.yaml`` (any storage), or a bare
``.mcap`` file. Every failure is a :class:`BagFormatError` naming the file.

Damaged files. A truncated mcap (a recorder killed before it wrote the summary and footer)
is refused when the bag is opened: rosbags finds no valid end magic. The message says the file
is truncated or corrupt; :func:`hand_tracker_ros.bags.recover.readable_bag` copies its intact
records into a complete file for callers that want the part that survived (``track`` does, with
a warning), so nothing returns part of a recording silently. Damage that is only
found while iterating (a bad record in a chunk, a wrong CRC, a corrupt sqlite3 page) is
raised as :class:`BagFormatError` from :meth:`BagReader.messages` when it is reached; the
messages yielded before stay valid (rosbags reads an mcap chunk at a time, so the error can
come before the first message of the damaged chunk). Undecodable CDR payloads are raised by
:meth:`BagReader.decoded`; :meth:`BagReader.intact_messages` stops at the damage with a
warning instead. rosbags writes mcap chunks without a CRC, so damage inside a
payload that keeps the CDR structure valid (e.g. image pixels) is not detectable. A fuzz run
(500 random byte-range corruptions of small mcap and sqlite3 bags) gave only clean reads or
:class:`BagFormatError`, never another exception and never a hang.
"""
from __future__ import annotations

import logging
from collections.abc import Collection, Iterator
from dataclasses import dataclass
from pathlib import Path
from types import TracebackType
from typing import Any

import yaml
from rosbags.highlevel import AnyReader
from rosbags.interfaces import Connection, QosReliability

from hand_tracker_ros.bags.typestore import typestore
from hand_tracker_ros.errors import BagFormatError

LOG = logging.getLogger(__name__)
# Every mcap file starts and ends with these bytes (mcap spec, 'Magic').
MCAP_MAGIC = b'\x89MCAP0\r\n'


@dataclass(frozen=True, slots=True)
class TopicSummary:
    """One topic of a bag.

    Attributes
    ----------
    msgtype : str
        ROS 2 type name, e.g. ``sensor_msgs/msg/Image``.
    count : int
        Number of messages.
    best_effort : bool
        True if every recorded publisher offered best-effort reliability (camera topics);
        a player should then publish best effort too.
    """

    msgtype: str
    count: int
    best_effort: bool


def _is_best_effort(connections: Collection[Connection]) -> bool:
    profiles = [q for c in connections for q in getattr(c.ext, 'offered_qos_profiles', [])]
    return bool(profiles) and all(q.reliability == QosReliability.BEST_EFFORT for q in profiles)


def check_bag_path(path: Path) -> None:
    """Raise :class:`BagFormatError` unless ``path`` looks like a rosbag2 bag."""
    if not path.exists():
        msg = f'{path}: bag not found'
        raise BagFormatError(msg)
    if path.is_dir() and not (path / 'metadata.yaml').is_file():
        msg = f'{path}: not a rosbag2 bag (no metadata.yaml in the directory)'
        raise BagFormatError(msg)
    if path.is_file() and path.suffix != '.mcap':
        msg = f'{path}: not a rosbag2 bag (expected a bag directory or an .mcap file)'
        raise BagFormatError(msg)


def truncated_mcap_files(path: Path) -> list[Path]:
    """The mcap files of the bag at ``path`` (a bare file or a bag directory) that do not end
    with the mcap magic, i.e. lack their footer."""
    files = [path] if path.is_file() else sorted(path.glob('*.mcap'))
    damaged = []
    for file in files:
        with file.open('rb') as stream:
            stream.seek(max(file.stat().st_size - len(MCAP_MAGIC), 0))
            if stream.read() != MCAP_MAGIC:
                damaged.append(file)
    return damaged


class BagReader:
    """Context manager reading one rosbag2 bag.

    Parameters
    ----------
    path : str or Path
        Bag directory (with ``metadata.yaml``) or ``.mcap`` file.

    Raises
    ------
    BagFormatError
        On entering: missing path, not a bag, truncated or corrupt storage, a type hash
        that does not match the stored definition.
    """

    def __init__(self, path: str | Path) -> None:
        self.path = Path(path)
        self._reader: AnyReader | None = None

    def __enter__(self) -> BagReader:
        check_bag_path(self.path)
        try:
            reader = AnyReader([self.path], default_typestore=typestore())
            reader.open()
        # rosbags raises many types for damaged input (ReaderError, AnyReaderError, apsw and
        # sqlite3 errors, struct.error, zstd errors, UnicodeDecodeError...); at this boundary
        # they all mean "unreadable bag", so they are reported as one error naming the file.
        except Exception as err:
            raise self._error(self._open_failure(), err) from err
        self._reader = reader
        return self

    def __exit__(self, exc_type: type[BaseException] | None, exc: BaseException | None,
                 tb: TracebackType | None) -> None:
        if self._reader is not None:
            reader, self._reader = self._reader, None
            reader.close()

    def _open_failure(self) -> str:
        """Say which file is damaged when we can tell (a truncated mcap lacks its end magic)."""
        if damaged := truncated_mcap_files(self.path):
            return (f'mcap file {damaged[0].name} is truncated (no footer: the recorder '
                    'stopped before closing it) or corrupt')
        return 'cannot open bag (corrupt storage or metadata)'

    def _error(self, what: str, err: BaseException) -> BagFormatError:
        return BagFormatError(f'{self.path}: {what}: {type(err).__name__}: {err}')

    def _open_reader(self) -> AnyReader:
        if self._reader is None:
            msg = f'{self.path}: the bag is not open (use `with BagReader(...) as bag:`)'
            raise BagFormatError(msg)
        return self._reader

    @property
    def topics(self) -> dict[str, TopicSummary]:
        """Topic name -> :class:`TopicSummary`, for every topic of the bag."""
        reader = self._open_reader()
        return {name: TopicSummary(msgtype=info.msgtype or '', count=info.msgcount,
                                   best_effort=_is_best_effort(info.connections))
                for name, info in reader.topics.items()}

    @property
    def storage(self) -> str:
        """Storage plugin: ``mcap`` for a bare .mcap file, else the ``storage_identifier`` of
        the bag's ``metadata.yaml`` (``mcap`` or ``sqlite3``)."""
        self._open_reader()
        if self.path.is_file():
            return 'mcap'
        metadata = yaml.safe_load((self.path / 'metadata.yaml').read_text())
        return str(metadata['rosbag2_bagfile_information']['storage_identifier'])

    @property
    def start_ns(self) -> int:
        """Bag time of the first message, ns."""
        return self._open_reader().start_time

    @property
    def end_ns(self) -> int:
        """Bag time just after the last message (last stamp + 1), ns."""
        return self._open_reader().end_time

    def _connections(self, topics: Collection[str] | None) -> list[Connection]:
        reader = self._open_reader()
        if topics is None:
            return list(reader.connections)
        if missing := sorted(set(topics) - {c.topic for c in reader.connections}):
            msg = (f'{self.path}: topics not in the bag: {", ".join(missing)} '
                   f'(the bag has {", ".join(sorted(reader.topics))})')
            raise BagFormatError(msg)
        return [c for c in reader.connections if c.topic in topics]

    def messages(self, topics: Collection[str] | None = None, start_ns: int | None = None,
                 stop_ns: int | None = None) -> Iterator[tuple[str, str, int, bytes]]:
        """Yield ``(topic, msgtype, stamp_ns, raw CDR bytes)`` in bag-time order.

        Parameters
        ----------
        topics : collection of str, optional
            Only these topics (all by default; an empty collection yields nothing); an absent
            topic is an error.
        start_ns, stop_ns : int, optional
            Only messages with ``start_ns <= stamp_ns < stop_ns`` (bag time, ns).
        """
        connections = self._connections(topics)
        if not connections:   # rosbags reads an empty connection list as "every connection"
            return
        iterator = self._open_reader().messages(connections, start=start_ns, stop=stop_ns)
        while True:
            try:
                item = next(iterator, None)
            # Same reason as in __enter__: any library error here is a damaged file.
            except Exception as err:
                raise self._error('bag is damaged after the messages read so far', err) from err
            if item is None:
                return
            connection, stamp_ns, raw = item
            yield connection.topic, connection.msgtype, stamp_ns, bytes(raw)

    def intact_messages(self, topics: Collection[str] | None = None
                        ) -> Iterator[tuple[str, str, int, bytes]]:
        """Like :meth:`messages`, but damage met while iterating ends the iteration with a
        warning (naming the bag and the bag time reached) instead of an error."""
        last_ns = None
        try:
            for item in self.messages(topics):
                last_ns = item[2]
                yield item
        except BagFormatError as err:
            LOG.warning('%s; using the messages before the damage (up to bag time %s ns)',
                        err, last_ns)

    def deserialize(self, raw: bytes, msgtype: str, *, topic: str = '?') -> Any:
        """Return the message object of ``raw`` CDR bytes of type ``msgtype``."""
        reader = self._open_reader()
        if msgtype not in reader.typestore.fielddefs:
            msg = f'{self.path}: unknown message type {msgtype!r} on topic {topic!r}'
            raise BagFormatError(msg)
        try:
            return reader.typestore.deserialize_cdr(raw, msgtype)
        except Exception as err:
            raise self._error(f'cannot decode {msgtype} on {topic!r}', err) from err

    def decoded(self, topics: Collection[str] | None = None, start_ns: int | None = None,
                stop_ns: int | None = None) -> Iterator[tuple[str, str, int, Any]]:
        """Like :meth:`messages`, yielding deserialized message objects instead of bytes."""
        for topic, msgtype, stamp_ns, raw in self.messages(topics, start_ns, stop_ns):
            yield topic, msgtype, stamp_ns, self.deserialize(raw, msgtype, topic=topic)
