"""rosbag2 bag folders (Jazzy, MCAP storage): what ``ros2 bag record -s mcap -o NAME`` leaves. No rclpy.

:class:`BagRecording` writes ``NAME/NAME_<n>.mcap`` (a new file past ``max_bytes`` or ``max_seconds``) and
rewrites ``metadata.yaml`` whole at open, at every split and at close; a folder that exists is refused. After a
crash :func:`bag_files` also returns the unlisted file that was being written. :func:`write_bag` writes a closed
bag of one file at once, in ``NAME.part/`` renamed when complete. See docs/recording.md, 'The bag folder'.
"""

from __future__ import annotations

import os
import re
import threading
from pathlib import Path
from typing import Sequence

from rrps_recording.storage.bag_metadata import (
    METADATA_FILE,
    FileStats,
    TopicInfo,
    bag_metadata,
    read_metadata_file,
    write_metadata_file,
)
from rrps_recording.storage.mcap_files import McapRecording

__all__ = ['BagRecording', 'write_bag', 'bag_files', 'is_bag', 'free_name']


class BagRecording:
    """A bag folder being written (see the module docstring). Thread-safe; every topic added is
    registered in each new file."""

    def __init__(self, folder: str | os.PathLike, *, max_bytes: int = 0, max_seconds: float = 0.0,
                 compression: str = 'zstd', chunk_size: int = 1 << 20, flush_period: float = 1.0,
                 file_name: str | None = None):
        if max_bytes < 0 or max_seconds < 0:
            raise ValueError('max_bytes and max_seconds must be >= 0')
        self.folder = Path(folder)
        if self.folder.exists():
            raise FileExistsError(f'bag folder {self.folder} already exists: not overwriting it')
        self.folder.mkdir(parents=True)
        self._name = file_name or self.folder.name
        self.max_bytes = int(max_bytes)
        self.max_ns = int(max_seconds * 1e9)
        self._options = dict(compression=compression, chunk_size=chunk_size,
                             flush_period=flush_period)
        self._lock = threading.Lock()
        self._topics: dict[str, TopicInfo] = {}
        self._closed_files: list[FileStats] = []
        self._closed_counts: dict[str, int] = {}
        self.files: list[Path] = []
        self.messages = 0
        self.closed_bytes = 0
        self.closed = False
        self._current = self._open()
        self._write_metadata()

    def _open(self) -> McapRecording:
        """The next file, ``<name>_<n>.mcap`` (rosbag2's ``format_storage_uri``)."""
        self._size_checked = 0
        path = self.folder / f'{self._name}_{len(self.files)}.mcap'
        recording = McapRecording(path, **self._options)
        for topic in self._topics.values():
            recording.add_topic(topic)
        self.files.append(path)
        return recording

    def _write_metadata(self) -> None:
        """metadata.yaml of the files closed so far."""
        counts = [(t, self._closed_counts.get(name, 0)) for name, t in self._topics.items()]
        write_metadata_file(self.folder, bag_metadata(counts, self._closed_files))

    def _close_current(self) -> None:
        current = self._current
        current.close()
        self.closed_bytes += current.size
        self._closed_files.append(current.stats())
        for topic, count in current.topic_counts():
            self._closed_counts[topic.name] = self._closed_counts.get(topic.name, 0) + count

    @property
    def path(self) -> Path:
        """The file being written."""
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
                self._close_current()
                current = self._current = self._open()
                self._write_metadata()
            if self.max_bytes and current.message_count - self._size_checked >= 64:
                self._size_checked = current.message_count
            current.write_many(messages)
            self.messages += len(messages)

    @property
    def bytes_written(self) -> int:
        with self._lock:
            return self.closed_bytes + (0 if self.closed else self._current.size)

    def flush(self) -> None:
        with self._lock:
            self._current.flush()

    def close(self) -> None:
        """Close the file being written; metadata.yaml lists every file."""
        with self._lock:
            if self.closed:
                return
            self._close_current()
            self._write_metadata()
            self.closed = True


def write_bag(folder: str | os.PathLike, topics: Sequence[TopicInfo],
              messages: Sequence[tuple[str, int, bytes]], *, compression: str = 'zstd') -> Path:
    """A closed bag ``folder`` of one file holding ``messages`` ((topic, log time [ns], CDR
    bytes), any order: written sorted by log time) on ``topics``, written in ``<folder>.part``
    and renamed when complete; returns the path of its MCAP file."""
    folder = Path(folder)
    if folder.exists():
        raise FileExistsError(f'bag folder {folder} already exists: not overwriting it')
    part = folder.with_name(folder.name + '.part')
    bag = BagRecording(part, compression=compression, flush_period=3600.0, file_name=folder.name)
    try:
        for topic in topics:
            bag.add_topic(topic)
        for topic, log_time, data in sorted(messages, key=lambda m: m[1]):
            if bag.has_topic(topic):
                bag.write(topic, log_time, data)
    finally:
        bag.close()
    os.replace(part, folder)
    return folder / bag.files[0].name


def free_name(parent: str | os.PathLike, name: str, taken=()) -> str:
    """``name``, else ``name_1``, ``name_2``, ...: the first with no folder (nor ``.part``
    folder) in ``parent`` and not in ``taken``."""
    parent = Path(parent)
    candidate, n = name, 1
    while (candidate in taken or (parent / candidate).exists()
           or (parent / f'{candidate}.part').exists()):
        candidate, n = f'{name}_{n}', n + 1
    return candidate


def is_bag(path: str | os.PathLike) -> bool:
    """Whether ``path`` is a bag folder (a folder with metadata.yaml or MCAP files)."""
    path = Path(path)
    return path.is_dir() and ((path / METADATA_FILE).is_file() or any(path.glob('*.mcap')))


def _index(path: Path) -> tuple[int, str]:
    match = re.search(r'_(\d+)\.mcap$', path.name)
    return (int(match.group(1)) if match else -1, path.name)


def bag_files(folder: str | os.PathLike) -> list[Path]:
    """The MCAP files of a bag folder in order: those metadata.yaml lists, then any other MCAP
    file there (the one a crash cut, unlisted), by their index. ValueError when ``folder`` is
    not a bag or a listed file is missing."""
    folder = Path(folder)
    if not is_bag(folder):
        raise ValueError(f'{folder} is not a bag folder (no metadata.yaml, no .mcap file)')
    listed: list[Path] = []
    if (folder / METADATA_FILE).is_file():
        metadata = read_metadata_file(folder)
        if metadata.get('storage_identifier') != 'mcap':
            raise ValueError(f'{folder}: storage {metadata.get("storage_identifier")!r}, not mcap')
        listed = [folder / Path(name).name for name in metadata.get('relative_file_paths') or []]
        missing = [str(p) for p in listed if not p.is_file()]
        if missing:
            raise ValueError(f'{folder}: files of metadata.yaml missing: {", ".join(missing)}')
    others = sorted((p for p in folder.glob('*.mcap') if p not in listed), key=_index)
    return listed + others
