"""Replay of MCAP recordings: reading, timing (rate, pause, seek) and the safety remap. Pure.

:class:`RecordingSet` reads one recording (a bag folder, :func:`rrps_recording.storage.bag.bag_files`, or MCAP
files) with ``mcap``: topics, time span, messages from any time on; a file cut by a crash is scanned once and
replayed up to its last complete chunk. :class:`ReplayClock` maps recording time to wall time (every method
takes ``now``, monotonic s). :func:`replay_topic` moves the command streams
(:data:`rrps_interfaces.recording.COMMAND_TOPICS`) under ``replay/`` unless ``allow_commands``.
"""

from __future__ import annotations

import dataclasses
import math
import os
from pathlib import Path
from typing import Iterator, Sequence

from mcap.exceptions import McapError
from mcap.reader import make_reader

from rrps_interfaces.recording import COMMAND_TOPICS, REPLAY_PREFIX
from rrps_recording.storage.bag import bag_files
from rrps_recording.storage.qos import QosSpec, parse_offered_qos

__all__ = ['RecordedTopic', 'RecordingSet', 'ReplayClock', 'replay_topic', 'is_command_topic']


def is_command_topic(topic: str) -> bool:
    """Whether a recorded (absolute) topic is one of the command streams."""
    return any(topic == f'/{c}' or topic.endswith(f'/{c}') for c in COMMAND_TOPICS)


def replay_topic(topic: str, *, allow_commands: bool = False, prefix: str = REPLAY_PREFIX) -> str:
    """Where a replay publishes ``topic``: the same name, except a command stream, which goes
    to ``<namespace>/<prefix>/<name>`` (``/rrps/target_pose`` -> ``/rrps/replay/target_pose``)
    unless ``allow_commands``."""
    if allow_commands:
        return topic
    for command in sorted(COMMAND_TOPICS, key=len, reverse=True):
        if topic == f'/{command}' or topic.endswith(f'/{command}'):
            namespace = topic[:len(topic) - len(command) - 1]
            return f'{namespace}/{prefix.strip("/")}/{command}'
    return topic


@dataclasses.dataclass(frozen=True)
class RecordedTopic:
    """A channel of a recording."""

    name: str
    type: str
    schema: str
    offered_qos: tuple[QosSpec, ...]
    message_count: int | None = None


class _File:
    def __init__(self, path: Path):
        self.path = path
        self.topics: dict[str, RecordedTopic] = {}
        self.start_ns = math.inf
        self.end_ns = -math.inf
        self.indexed = False
        with open(path, 'rb') as stream:
            summary = None
            try:
                summary = make_reader(stream).get_summary()
            except (McapError, ValueError, EOFError, AssertionError, OSError):
                summary = None
            if summary is not None and summary.statistics is not None and summary.chunk_indexes:
                self.indexed = True
                counts = summary.statistics.channel_message_counts
                for cid, channel in summary.channels.items():
                    self._add(channel, summary.schemas.get(channel.schema_id), counts.get(cid))
                if summary.statistics.message_count:
                    self.start_ns = summary.statistics.message_start_time
                    self.end_ns = summary.statistics.message_end_time
                return
        # No usable summary (a file cut by a crash): scan what was written.
        counts: dict[str, int] = {}
        for schema, channel, message in self._scan():
            self._add(channel, schema, None)
            counts[channel.topic] = counts.get(channel.topic, 0) + 1
            self.start_ns = min(self.start_ns, message.log_time)
            self.end_ns = max(self.end_ns, message.log_time)
        for name, count in counts.items():
            self.topics[name] = dataclasses.replace(self.topics[name], message_count=count)

    def _scan(self):
        """Every complete message of the file, in file order (stops at a cut)."""
        with open(self.path, 'rb') as stream:
            from mcap.reader import NonSeekingReader
            reader = NonSeekingReader(stream, validate_crcs=False)
            try:
                yield from reader.iter_messages(log_time_order=False)
            except (McapError, ValueError, EOFError, AssertionError, OSError):
                return

    def _add(self, channel, schema, count) -> None:
        if channel.topic in self.topics or schema is None:
            return
        try:
            offered = tuple(parse_offered_qos(channel.metadata.get('offered_qos_profiles', '')))
        except ValueError:
            offered = ()
        self.topics[channel.topic] = RecordedTopic(
            name=channel.topic, type=schema.name, schema=schema.data.decode('utf-8', 'replace'),
            offered_qos=offered, message_count=count)

    def messages(self, start_ns: int, topics: frozenset | None) -> Iterator[tuple[str, int, bytes]]:
        if self.indexed:
            with open(self.path, 'rb') as stream:
                reader = make_reader(stream)
                for _, channel, message in reader.iter_messages(
                        topics=None if topics is None else list(topics), starting_at=start_ns,
                        log_time_order=True):
                    yield channel.topic, message.log_time, message.data
            return
        for _, channel, message in sorted(
                ((s, c, m) for s, c, m in self._scan()
                 if m.log_time >= start_ns and (topics is None or c.topic in topics)),
                key=lambda scm: scm[2].log_time):
            yield channel.topic, message.log_time, message.data


class RecordingSet:
    """One recording: bag folders and MCAP files (see the module docstring)."""

    def __init__(self, paths: Sequence[str | os.PathLike]):
        if not paths:
            raise ValueError('no recording file given')
        files = []
        for p in paths:
            path = Path(p)
            if path.is_dir():
                files += [_File(f) for f in bag_files(path)]
            elif path.is_file():
                files.append(_File(path))
            else:
                raise FileNotFoundError(f'no such recording: {path}')
        self.files = sorted((f for f in files if f.end_ns >= f.start_ns),
                            key=lambda f: f.start_ns)
        if not self.files:
            raise ValueError(f'no message in {", ".join(str(p) for p in paths)}')
        self.topics: dict[str, RecordedTopic] = {}
        for f in self.files:
            for name, topic in f.topics.items():
                if name in self.topics and self.topics[name].message_count is not None:
                    before = self.topics[name]
                    topic = dataclasses.replace(
                        before, message_count=(before.message_count or 0) + (topic.message_count or 0))
                self.topics[name] = topic
        self.start_ns = int(min(f.start_ns for f in self.files))
        self.end_ns = int(max(f.end_ns for f in self.files))

    @property
    def duration(self) -> float:
        """Seconds from the first to the last message."""
        return (self.end_ns - self.start_ns) * 1e-9

    def messages(self, start_ns: int | None = None,
                 topics: Sequence[str] | None = None) -> Iterator[tuple[str, int, bytes]]:
        """(topic, log time [ns], CDR bytes) from ``start_ns`` on, in log-time order per file,
        files in time order; only ``topics`` when given."""
        start = self.start_ns if start_ns is None else int(start_ns)
        wanted = None if topics is None else frozenset(topics)
        for f in self.files:
            if f.end_ns < start:
                continue
            yield from f.messages(start, wanted)


class ReplayClock:
    """Recording time <-> wall time for a replay (see the module docstring)."""

    def __init__(self, start_ns: int, end_ns: int, *, rate: float = 1.0, paused: bool = False,
                 now: float = 0.0):
        if end_ns < start_ns:
            raise ValueError('end_ns must not be before start_ns')
        self._check_rate(rate)
        self.start_ns = int(start_ns)
        self.end_ns = int(end_ns)
        self.rate = float(rate)
        self.paused = bool(paused)
        self._anchor_wall = now
        self._anchor_ns = self.start_ns
        #: incremented by every seek: a publisher restarts its reading at :attr:`read_from`
        self.epoch = 0
        #: recording time [ns] a reader starts from: the start, or the last seek's target
        self.read_from = self.start_ns

    @staticmethod
    def _check_rate(rate: float) -> None:
        if not (math.isfinite(rate) and rate > 0.0):
            raise ValueError(f'rate must be a finite number > 0, got {rate}')

    def position(self, now: float) -> int:
        """Recording time [ns] at wall time ``now``, within [start, end]."""
        if self.paused:
            t = self._anchor_ns
        else:
            t = self._anchor_ns + int((now - self._anchor_wall) * self.rate * 1e9)
        return min(max(t, self.start_ns), self.end_ns)

    def _reanchor(self, now: float) -> None:
        self._anchor_ns = self.position(now)
        self._anchor_wall = now

    def set_rate(self, rate: float, now: float) -> None:
        self._check_rate(rate)
        self._reanchor(now)
        self.rate = float(rate)

    def set_paused(self, paused: bool, now: float) -> None:
        self._reanchor(now)
        self.paused = bool(paused)

    def seek(self, position_ns: int, now: float) -> None:
        """Jump to a recording time (clamped to the recording)."""
        self._anchor_ns = min(max(int(position_ns), self.start_ns), self.end_ns)
        self._anchor_wall = now
        self.read_from = self._anchor_ns
        self.epoch += 1

    def wait(self, log_time_ns: int, now: float) -> float:
        """Seconds until the message at ``log_time_ns`` is due (<= 0: now; inf while paused)."""
        if self.paused:
            return math.inf
        return (log_time_ns - self._anchor_ns) / (self.rate * 1e9) + self._anchor_wall - now

    def elapsed(self, now: float) -> float:
        """Seconds of recording replayed so far (the timeline's position)."""
        return (self.position(now) - self.start_ns) * 1e-9
