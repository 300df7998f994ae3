"""MCAP files in the ``ros2`` profile, as ``ros2 bag record -s mcap`` (Jazzy) writes them. No rclpy.

One ``ros2msg`` schema per type (:func:`rrps_recording.storage.schemas.message_schema`), one ``cdr`` channel per
topic, the CDR bytes as received (log and publish time: the receipt time [ns since the epoch]), compressed chunks
and a ``rosbag2`` metadata record (:mod:`rrps_recording.storage.bag_metadata`): docs/recording.md, 'The MCAP
files'. :class:`McapRecording` writes one file, flushed at least every ``flush_period`` s of log time (what a
crash can lose); the splits are :mod:`rrps_recording.storage.bag`'s. Written with Foxglove's SDK, read with mcap.
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import Iterable, Sequence

import foxglove
from foxglove.mcap import MCAPCompression, MCAPWriteOptions

from rrps_recording.storage.bag_metadata import FileStats, TopicInfo, bag_metadata, yaml_text
from rrps_recording.storage.schemas import message_schema

__all__ = ['TopicInfo', 'McapRecording', 'write_recording', 'COMPRESSIONS']

COMPRESSIONS = {'zstd': MCAPCompression.Zstd, 'lz4': MCAPCompression.Lz4, 'none': None}
#: zstd's quickest level, in the writer's thread (the recorder's), with no compression threads
#: of its own.
COMPRESSION_LEVEL = 1


class McapRecording:
    """One MCAP file being written (see the module docstring). Not thread-safe by itself:
    :class:`RotatingRecording` serialises the calls."""

    def __init__(self, path: str | os.PathLike, *, compression: str = 'zstd',
                 chunk_size: int = 1 << 20, flush_period: float = 1.0):
        if compression not in COMPRESSIONS:
            raise ValueError(f'compression must be one of {sorted(COMPRESSIONS)}, '
                             f'got {compression!r}')
        self.path = Path(path)
        # A context of its own: the file gets this recording's channels only.
        self._context = foxglove.Context()
        self._writer = foxglove.open_mcap(
            self.path, allow_overwrite=True, context=self._context,
            writer_options=MCAPWriteOptions(profile='ros2', compression=COMPRESSIONS[compression],
                                            compression_level=COMPRESSION_LEVEL,
                                            chunk_size=chunk_size, compression_threads=0))
        self._channels: dict[str, foxglove.Channel] = {}
        self._topics: dict[str, TopicInfo] = {}
        self.counts: dict[str, int] = {}
        self.message_count = 0
        self.start_ns: int | None = None
        self.end_ns: int | None = None
        self._flush_ns = int(flush_period * 1e9)
        self._last_flush_ns: int | None = None
        self.closed = False

    def add_topic(self, topic: TopicInfo) -> None:
        """Register the topic's channel (its schema is written once per type)."""
        if topic.name in self._channels:
            return
        schema = foxglove.Schema(name=topic.type, encoding='ros2msg',
                                 data=message_schema(topic.type).encode('utf-8'))
        self._channels[topic.name] = foxglove.Channel(
            topic.name, schema=schema, message_encoding='cdr', context=self._context,
            metadata=topic.channel_metadata())
        self._topics[topic.name] = topic
        self.counts[topic.name] = 0

    def has_topic(self, name: str) -> bool:
        return name in self._channels

    def write(self, topic: str, log_time_ns: int, data: bytes) -> None:
        """Append one message of a registered topic (CDR bytes)."""
        self.write_many(((topic, log_time_ns, data),))

    def write_many(self, messages: Iterable[tuple[str, int, bytes]]) -> None:
        """Append messages (topic, log time [ns], CDR bytes) of registered topics, in order."""
        channels, counts = self._channels, self.counts
        start, end = self.start_ns, self.end_ns
        n = 0
        for topic, log_time_ns, data in messages:
            channels[topic].base.log(data, log_time_ns, None)  # Channel.log, for bytes
            counts[topic] += 1
            n += 1
            if start is None or log_time_ns < start:
                start = log_time_ns
            if end is None or log_time_ns > end:
                end = log_time_ns
        if n == 0:
            return
        self.start_ns, self.end_ns = start, end
        self.message_count += n
        if self._last_flush_ns is None:
            self._last_flush_ns = end
        elif end - self._last_flush_ns >= self._flush_ns:
            self.flush()
            self._last_flush_ns = end

    def flush(self) -> None:
        """Write the chunk in progress to the file (readable up to here after a crash)."""
        self._writer.flush()

    @property
    def size(self) -> int:
        """Bytes in the file so far (chunks written)."""
        return self.path.stat().st_size

    def stats(self) -> FileStats:
        """This file's entry of a bag's ``files`` list."""
        return FileStats(self.path.name, self.start_ns, self.end_ns, self.message_count)

    def topic_counts(self) -> list[tuple[TopicInfo, int]]:
        """Each topic of this file with its message count, in the order they were added."""
        return [(t, self.counts[t.name]) for t in self._topics.values()]

    def close(self) -> None:
        """Write the ``rosbag2`` metadata record (this file as a bag of its own) and the
        summary; close the file."""
        if self.closed:
            return
        metadata = bag_metadata(self.topic_counts(), [self.stats()])
        self._writer.write_metadata('rosbag2', {'serialized_metadata': yaml_text(metadata)})
        self._writer.close()
        for channel in self._channels.values():
            channel.close()
        self.closed = True


def write_recording(path: str | os.PathLike, topics: Iterable[TopicInfo],
                    messages: Sequence[tuple[str, int, bytes]], *,
                    compression: str = 'zstd') -> Path:
    """One closed MCAP file of ``messages`` ((topic, log time [ns], CDR bytes), any order:
    written sorted by log time) on ``topics``; returns its path."""
    recording = McapRecording(path, compression=compression, flush_period=3600.0)
    try:
        for topic in topics:
            recording.add_topic(topic)
        for topic, log_time, data in sorted(messages, key=lambda m: m[1]):
            if recording.has_topic(topic):
                recording.write(topic, log_time, data)
    finally:
        recording.close()
    return recording.path
