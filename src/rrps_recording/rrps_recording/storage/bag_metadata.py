"""A bag's metadata as rosbag2 (Jazzy) writes it: ``metadata.yaml`` and the MCAP ``rosbag2`` record.

rosbag2's ``BagMetadata`` version 9, ordered as its ``YAML::convert<BagMetadata>::encode``
(``rosbag2_storage/yaml.hpp``; the fields: docs/recording.md, 'The bag folder'). ``metadata.yaml`` wraps it in
``rosbag2_bagfile_information``; the MCAP record holds it unwrapped under ``serialized_metadata``.
:func:`yaml_text` writes both in yaml-cpp's block style (PyYAML's emitter). Pure Python, no rclpy.
"""

from __future__ import annotations

import dataclasses
import os
from pathlib import Path
from typing import Sequence

import yaml

from rrps_recording.storage.qos import QosSpec, offered_qos_profiles, offered_qos_yaml
from rrps_recording.storage.schemas import type_hash

__all__ = ['TopicInfo', 'FileStats', 'bag_metadata', 'yaml_text', 'metadata_file_text',
           'write_metadata_file', 'read_metadata_file', 'METADATA_FILE', 'ROS_DISTRO',
           'METADATA_VERSION', 'NO_START']

ROS_DISTRO = 'jazzy'
METADATA_VERSION = 9
METADATA_FILE = 'metadata.yaml'
#: rosbag2's starting time of a bag or file without messages (``nanoseconds::max()``).
NO_START = 2**63 - 1


@dataclasses.dataclass(frozen=True)
class TopicInfo:
    """A recorded topic: full name, type ('pkg/msg/Type'), the publishers' offered QoS."""

    name: str
    type: str
    offered_qos: tuple[QosSpec, ...] = ()
    type_hash: str = ''

    @property
    def type_description_hash(self) -> str:
        """``RIHS01_...``: the publishers' hash, else the installed type's, else ''."""
        return self.type_hash or type_hash(self.type)

    def channel_metadata(self) -> dict[str, str]:
        """The MCAP channel metadata rosbag2's MCAP storage writes."""
        return {'offered_qos_profiles': offered_qos_yaml(self.offered_qos),
                'topic_type_hash': self.type_description_hash}


@dataclasses.dataclass(frozen=True)
class FileStats:
    """One file of a bag: its name in the bag folder, first and last log time [ns] (None when
    empty) and message count."""

    path: str
    start_ns: int | None
    end_ns: int | None
    message_count: int

    def span(self) -> tuple[int, int]:
        """(starting_time, duration) as rosbag2 writes them."""
        if self.start_ns is None or self.end_ns is None:
            return NO_START, 0
        return self.start_ns, self.end_ns - self.start_ns


def bag_metadata(topic_counts: Sequence[tuple[TopicInfo, int]], files: Sequence[FileStats]) -> dict:
    """rosbag2's BagMetadata (version 9) of ``files`` holding ``topic_counts`` (each topic with
    its message count over those files), as a dict in rosbag2's key order."""
    spans = [f for f in files if f.start_ns is not None and f.end_ns is not None]
    if spans:
        start = min(f.start_ns for f in spans)
        duration = max(f.end_ns for f in spans) - start
    else:
        start, duration = NO_START, 0
    file_entries = []
    for f in files:
        f_start, f_duration = f.span()
        file_entries.append({'path': f.path, 'starting_time': {'nanoseconds_since_epoch': f_start},
                             'duration': {'nanoseconds': f_duration}, 'message_count': f.message_count})
    return {
        'version': METADATA_VERSION,
        'storage_identifier': 'mcap',
        'duration': {'nanoseconds': duration},
        'starting_time': {'nanoseconds_since_epoch': start},
        'message_count': sum(f.message_count for f in files),
        'topics_with_message_count': [
            {'topic_metadata': {'name': t.name, 'type': t.type, 'serialization_format': 'cdr',
                                'offered_qos_profiles': offered_qos_profiles(t.offered_qos),
                                'type_description_hash': t.type_description_hash},
             'message_count': count} for t, count in topic_counts],
        # chunk compression is the MCAP storage's own: rosbag2 leaves these empty
        'compression_format': '',
        'compression_mode': '',
        'relative_file_paths': [f.path for f in files],
        'files': file_entries,
        'custom_data': None,
        'ros_distro': ROS_DISTRO,
    }


class _YamlCppStyle(yaml.SafeDumper):
    """PyYAML's emitter in yaml-cpp's block style: sequences indented under their key, '~' for
    null, an empty string as "" (the rest of rosbag2's metadata it writes alike)."""

    def increase_indent(self, flow=False, indentless=False):
        return super().increase_indent(flow, False)


_YamlCppStyle.add_representer(type(None), lambda dumper, _: dumper.represent_scalar('tag:yaml.org,2002:null', '~'))
_YamlCppStyle.add_representer(str, lambda dumper, text: dumper.represent_scalar(
    'tag:yaml.org,2002:str', text, style='"' if text == '' else None))


def yaml_text(value) -> str:
    """The mapping ``value`` (of dicts, lists, str, int, bool, None) as yaml-cpp writes rosbag2's metadata:
    two-space indents, sequences indented under their key, '~' for null, quoted only when
    needed, no final newline."""
    return yaml.dump(value, Dumper=_YamlCppStyle, sort_keys=False, default_flow_style=False,
                     width=float('inf')).rstrip('\n')


def metadata_file_text(metadata: dict) -> str:
    """The text of ``metadata.yaml`` for a BagMetadata dict."""
    return yaml_text({'rosbag2_bagfile_information': metadata})


def write_metadata_file(folder: str | os.PathLike, metadata: dict) -> Path:
    """Write ``<folder>/metadata.yaml`` whole (a temporary file renamed over the old one)."""
    path = Path(folder) / METADATA_FILE
    part = path.with_name(METADATA_FILE + '.part')
    part.write_text(metadata_file_text(metadata), encoding='utf-8')
    os.replace(part, path)
    return path


def read_metadata_file(folder: str | os.PathLike) -> dict:
    """The BagMetadata of ``<folder>/metadata.yaml`` (ValueError when it is not one)."""
    path = Path(folder) / METADATA_FILE
    try:
        data = yaml.safe_load(path.read_text(encoding='utf-8'))
    except yaml.YAMLError as exc:
        raise ValueError(f'{path}: not YAML: {exc}') from None
    if not isinstance(data, dict) or not isinstance(data.get('rosbag2_bagfile_information'), dict):
        raise ValueError(f'{path}: no rosbag2_bagfile_information')
    return data['rosbag2_bagfile_information']
