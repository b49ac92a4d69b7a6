"""Read what a truncated mcap bag still holds (the idea of the mcap CLI's ``mcap recover``).

A recorder killed before it closed its mcap file leaves no summary and no footer, and rosbags
refuses the file (:mod:`hand_tracker_ros.bags.reader`). Its complete records are still valid:
the ``mcap`` library's ``StreamReader`` reads them in file order up to the truncation, and its
``Writer`` writes them into a new, complete file in a temporary directory, which rosbags then
reads like any bag. A chunk cut by the truncation is lost whole (its compressed payload cannot
be read in part), so "the intact part" ends with the last complete chunk.
"""
from __future__ import annotations

import logging
import tempfile
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import BinaryIO

from mcap.records import Channel, Header, Message, Metadata, Schema
from mcap.stream_reader import StreamReader
from mcap.writer import Writer

from hand_tracker_ros.bags.reader import check_bag_path, truncated_mcap_files
from hand_tracker_ros.errors import BagFormatError

LOG = logging.getLogger(__name__)


@contextmanager
def readable_bag(path: str | Path) -> Iterator[Path]:
    """Yield a bag path that :class:`~hand_tracker_ros.bags.reader.BagReader` can open.

    That is ``path`` itself, unless the bag is one truncated mcap file: then a temporary
    complete copy of its intact records, removed on exit, after a warning that names the file
    and how many messages survived.

    Raises
    ------
    BagFormatError
        ``path`` is not a bag, or the truncation left no complete message.
    """
    path = Path(path)
    check_bag_path(path)
    damaged = truncated_mcap_files(path)
    if len(damaged) != 1 or (path.is_dir() and len(list(path.glob('*.mcap'))) != 1):
        yield path   # intact, or a layout we do not repair: BagReader explains what is wrong
        return
    with tempfile.TemporaryDirectory(prefix='hand_tracker_recovered_') as tmp:
        copy = Path(tmp) / damaged[0].name
        with damaged[0].open('rb') as source, copy.open('wb') as target:
            count, last_ns = _copy_intact_records(source, target)
        if count == 0:
            msg = (f'{path}: mcap file {damaged[0].name} is truncated before its first '
                   'complete chunk: no message to recover')
            raise BagFormatError(msg)
        LOG.warning('%s: mcap file %s is truncated (the recorder stopped before closing it); '
                    'using the %d messages before the damage (up to bag time %d ns)', path,
                    damaged[0].name, count, last_ns)
        yield copy


def _copy_intact_records(source: BinaryIO, target: BinaryIO) -> tuple[int, int]:
    """Copy header, schemas, channels, messages and metadata of ``source`` until it breaks.

    Returns
    -------
    count : int
        Messages copied.
    last_ns : int
        Log time of the last one, ns (0 if none).
    """
    writer = Writer(target)
    schemas: dict[int, int] = {}
    channels: dict[int, int] = {}
    count, last_ns = 0, 0
    records = StreamReader(source).records
    started = False
    while True:
        try:
            record = next(records, None)
        # The stream ends in a cut record: EndOfFile, or (cut inside a chunk) zstd/lz4/struct
        # errors, depending on where. Every one of them means "the intact part ends here".
        except Exception:
            break
        if record is None:
            break
        if isinstance(record, Header):
            writer.start(record.profile, record.library)
            started = True
        elif isinstance(record, Schema) and record.id not in schemas:
            schemas[record.id] = writer.register_schema(record.name, record.encoding,
                                                        record.data)
        elif isinstance(record, Channel) and record.id not in channels:
            channels[record.id] = writer.register_channel(
                record.topic, record.message_encoding, schemas.get(record.schema_id, 0),
                record.metadata)
        elif isinstance(record, Message) and record.channel_id in channels:
            writer.add_message(channels[record.channel_id], record.log_time, record.data,
                               record.publish_time, record.sequence)
            count, last_ns = count + 1, record.log_time
        elif isinstance(record, Metadata):
            writer.add_metadata(record.name, record.metadata)
    if not started:
        writer.start()
    writer.finish()
    return count, last_ns
