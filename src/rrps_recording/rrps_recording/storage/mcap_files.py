"""MCAP files in the ``ros2`` profile, as ``ros2 bag record -s mcap`` (Jazzy) writes them.

* Profile ``ros2``; one Schema per message type: encoding ``ros2msg``, name ``pkg/msg/Type``,
  data the definition with its dependencies (:func:`rrps_recording.storage.schemas.message_schema`).
* One Channel per topic: message encoding ``cdr``, metadata ``offered_qos_profiles`` (the QoS
  each publisher offered, :func:`rrps_recording.storage.qos.offered_qos_yaml`) and
  ``topic_type_hash`` (``RIHS01_...``, empty when unknown).
* Messages: the CDR bytes as received (log time = receipt time [ns since the epoch], publish
  time the same), a sequence number per channel (from 1).
* Chunks compressed (zstd by default), with message indexes and a summary; a Metadata record
  ``rosbag2`` whose ``serialized_metadata`` is the bag's metadata (version 9, what rosbag2's
  MCAP storage reads to know how to parse the QoS text).

:class:`McapRecording` writes one file; it is flushed (the chunk in progress written) at
least every ``flush_period`` s of log time, so a process that dies loses at most that much.
:class:`RotatingRecording` starts a new file ``<prefix>_<n>.mcap`` past ``max_bytes`` or
``max_seconds``, as rosbag2 splits a bag. No rclpy.

The writer is Foxglove's SDK (``foxglove-sdk``, its MCAP writer compiled from Rust), quicker
than the pure-Python ``mcap`` writer (docs/measurements.md). Files are read back with the
``mcap`` reader (replay, tests).
"""

from __future__ import annotations

import dataclasses
import os
import threading
from pathlib import Path
from typing import Iterable, Sequence

import foxglove
import yaml
from foxglove.mcap import MCAPCompression, MCAPWriteOptions

from rrps_recording.storage.qos import QosSpec, offered_qos_yaml
from rrps_recording.storage.schemas import message_schema, type_hash

__all__ = ['TopicInfo', 'McapRecording', 'RotatingRecording', 'write_recording',
           'COMPRESSIONS', 'ROS_DISTRO', 'METADATA_VERSION']

ROS_DISTRO = 'jazzy'
METADATA_VERSION = 9
COMPRESSIONS = {'zstd': MCAPCompression.Zstd, 'lz4': MCAPCompression.Lz4, 'none': None}
#: zstd's quickest level, in the writer's thread (the recorder's), with no compression threads
#: of its own.
COMPRESSION_LEVEL = 1


@dataclasses.dataclass(frozen=True)
class TopicInfo:
    """A recorded topic: full name, type ('pkg/msg/Type'), the publishers' offered QoS."""

    name: str
    type: str
    offered_qos: tuple[QosSpec, ...] = ()
    type_hash: str = ''

    def channel_metadata(self) -> dict[str, str]:
        return {'offered_qos_profiles': offered_qos_yaml(self.offered_qos),
                'topic_type_hash': self.type_hash or type_hash(self.type)}


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

    def bag_metadata(self) -> dict:
        """rosbag2's BagMetadata of this file (what ``ros2 bag info`` shows)."""
        start = self.start_ns or 0
        duration = (self.end_ns - start) if self.end_ns is not None else 0
        return {
            'version': METADATA_VERSION,
            'storage_identifier': 'mcap',
            'duration': {'nanoseconds': duration},
            'starting_time': {'nanoseconds_since_epoch': start},
            'message_count': self.message_count,
            'topics_with_message_count': [
                {'topic_metadata': {'name': t.name, 'type': t.type,
                                    'serialization_format': 'cdr',
                                    'offered_qos_profiles': offered_qos_yaml(t.offered_qos),
                                    'type_description_hash': t.type_hash or type_hash(t.type)},
                 'message_count': self.counts[t.name]} for t in self._topics.values()],
            'compression_format': '',
            'compression_mode': '',
            'relative_file_paths': [self.path.name],
            'files': [{'path': self.path.name,
                       'starting_time': {'nanoseconds_since_epoch': start},
                       'duration': {'nanoseconds': duration},
                       'message_count': self.message_count}],
            'custom_data': {},
            'ros_distro': ROS_DISTRO,
        }

    def close(self) -> None:
        """Write the rosbag2 metadata record and the summary; close the file."""
        if self.closed:
            return
        self._writer.write_metadata('rosbag2', {
            'serialized_metadata': yaml.safe_dump(self.bag_metadata(), sort_keys=False),
            'ROS_DISTRO': ROS_DISTRO})
        self._writer.close()
        for channel in self._channels.values():
            channel.close()
        self.closed = True


class RotatingRecording:
    """Files ``<directory>/<prefix>_<n>.mcap``, a new one past ``max_bytes`` (0: no limit) or
    ``max_seconds`` of log time (0: no limit). Thread-safe; every topic added is registered
    in each new file."""

    def __init__(self, directory: str | os.PathLike, prefix: str, *, max_bytes: int = 0,
                 max_seconds: float = 0.0, compression: str = 'zstd',
                 chunk_size: int = 1 << 20, flush_period: float = 1.0):
        if max_bytes < 0 or max_seconds < 0:
            raise ValueError('max_bytes and max_seconds must be >= 0')
        self.directory = Path(directory)
        self.directory.mkdir(parents=True, exist_ok=True)
        self.prefix = prefix
        self.max_bytes = int(max_bytes)
        self.max_ns = int(max_seconds * 1e9)
        self._options = dict(compression=compression, chunk_size=chunk_size,
                             flush_period=flush_period)
        self._lock = threading.Lock()
        self._topics: dict[str, TopicInfo] = {}
        self.files: list[Path] = []
        self.messages = 0
        self.closed_bytes = 0
        self._current = self._open()

    def _open(self) -> McapRecording:
        self._size_checked = 0
        path = self.directory / f'{self.prefix}_{len(self.files)}.mcap'
        recording = McapRecording(path, **self._options)
        for topic in self._topics.values():
            recording.add_topic(topic)
        self.files.append(path)
        return recording

    @property
    def path(self) -> Path:
        return self._current.path

    def add_topic(self, topic: TopicInfo) -> None:
        with self._lock:
            if topic.name not in self._topics:
                self._topics[topic.name] = topic
                self._current.add_topic(topic)

    def has_topic(self, name: str) -> bool:
        return name in self._topics

    def write(self, topic: str, log_time_ns: int, data: bytes) -> None:
        self.write_many(((topic, log_time_ns, data),))

    def write_many(self, messages: Sequence[tuple[str, int, bytes]]) -> None:
        """Append messages (topic, log time [ns], CDR bytes); a batch goes to one file."""
        if not messages:
            return
        with self._lock:
            current = self._current
            if ((self.max_ns and current.start_ns is not None
                 and messages[-1][1] - current.start_ns >= self.max_ns)
                    or (self.max_bytes and current.message_count - self._size_checked >= 64
                        and current.size >= self.max_bytes)):
                current.close()
                self.closed_bytes += current.size
                current = self._current = self._open()
            if self.max_bytes and current.message_count - self._size_checked >= 64:
                self._size_checked = current.message_count
            current.write_many(messages)
            self.messages += len(messages)

    @property
    def bytes_written(self) -> int:
        with self._lock:
            return self.closed_bytes + self._current.size

    def flush(self) -> None:
        with self._lock:
            self._current.flush()

    def close(self) -> None:
        with self._lock:
            self._current.close()


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
