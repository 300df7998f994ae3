"""QoS profiles as rosbag2 (Jazzy) records them: ``offered_qos_profiles`` of MCAP channels and bags. No rclpy.

:class:`QosSpec` holds one profile (rmw enum numbers, as rclpy); :func:`offered_qos_yaml` writes a channel's
text and :func:`offered_qos_profiles` a ``metadata.yaml``'s nested sequence, both with the policies' names as
yaml-cpp writes them; :func:`parse_offered_qos` reads either (or older bags' numbers). :func:`request_for_offers`
is the QoS a recorder requests to hear every publisher (rosbag2's rule), :func:`offer_for_replay` what a replay
offers.
"""

from __future__ import annotations

import dataclasses
from typing import Iterable, Sequence

import yaml

__all__ = ['QosSpec', 'INFINITE_NS', 'TF_QOS', 'offered_qos_yaml', 'offered_qos_profiles',
           'parse_offered_qos', 'request_for_offers', 'offer_for_replay']

#: rmw's RMW_DURATION_INFINITE [ns] (written as sec 9223372036, nsec 854775807).
INFINITE_NS = 9223372036854775807

# rmw enum values -> rmw_qos_*_policy_to_str names
_HISTORY = {0: 'system_default', 1: 'keep_last', 2: 'keep_all', 3: 'unknown'}
_RELIABILITY = {0: 'system_default', 1: 'reliable', 2: 'best_effort', 3: 'unknown',
                4: 'best_available'}
_DURABILITY = {0: 'system_default', 1: 'transient_local', 2: 'volatile', 3: 'unknown',
               4: 'best_available'}
_LIVELINESS = {0: 'system_default', 1: 'automatic', 3: 'manual_by_topic', 4: 'unknown',
               5: 'best_available'}
_POLICIES = {'history': _HISTORY, 'reliability': _RELIABILITY, 'durability': _DURABILITY,
             'liveliness': _LIVELINESS}

RELIABLE, BEST_EFFORT = 1, 2
TRANSIENT_LOCAL, VOLATILE = 1, 2
KEEP_LAST = 1


@dataclasses.dataclass(frozen=True)
class QosSpec:
    """One QoS profile: policies as rmw enum values, durations in nanoseconds."""

    history: int = KEEP_LAST
    depth: int = 10
    reliability: int = RELIABLE
    durability: int = VOLATILE
    deadline_ns: int = INFINITE_NS
    lifespan_ns: int = INFINITE_NS
    liveliness: int = 1
    liveliness_lease_duration_ns: int = INFINITE_NS
    avoid_ros_namespace_conventions: bool = False

    def __post_init__(self):
        for name, table in _POLICIES.items():
            if getattr(self, name) not in table:
                raise ValueError(f'unknown {name} policy {getattr(self, name)!r}')


#: What tf2_ros' TransformBroadcaster offers on /tf (reliable, volatile, keep last 100): the
#: QoS of markers_node's live /tf and of the /tf the recorder writes.
TF_QOS = QosSpec(depth=100)


def _sec_nsec(ns: int) -> dict:
    sec, nsec = divmod(int(ns), 1_000_000_000)
    return {'sec': sec, 'nsec': nsec}


def offered_qos_profiles(profiles: Sequence[QosSpec]) -> list[dict]:
    """The profiles as the YAML sequence of a version-9 ``metadata.yaml`` (rosbag2's
    ``convert<rclcpp::QoS>::encode``: policy names, durations as sec/nsec, in this key order)."""
    return [{'history': _HISTORY[p.history], 'depth': int(p.depth),
             'reliability': _RELIABILITY[p.reliability], 'durability': _DURABILITY[p.durability],
             'deadline': _sec_nsec(p.deadline_ns), 'lifespan': _sec_nsec(p.lifespan_ns),
             'liveliness': _LIVELINESS[p.liveliness],
             'liveliness_lease_duration': _sec_nsec(p.liveliness_lease_duration_ns),
             'avoid_ros_namespace_conventions': bool(p.avoid_ros_namespace_conventions)}
            for p in profiles]


def offered_qos_yaml(profiles: Sequence[QosSpec]) -> str:
    """The ``offered_qos_profiles`` text of ``profiles``, as rosbag2 writes it on an MCAP channel
    (the block style of yaml-cpp, which PyYAML's emitter writes alike for this sequence)."""
    if not profiles:
        return '[]'
    return yaml.safe_dump(offered_qos_profiles(profiles), sort_keys=False, default_flow_style=False).rstrip('\n')


def _policy(value, table: dict, name: str) -> int:
    if isinstance(value, bool):
        raise ValueError(f'{name}: not a policy: {value!r}')
    if isinstance(value, int):
        if value not in table:
            raise ValueError(f'{name}: unknown value {value}')
        return value
    for number, text in table.items():
        if text == str(value):
            return number
    raise ValueError(f'{name}: unknown policy {value!r}')


def _ns(node) -> int:
    if not isinstance(node, dict):
        raise ValueError(f'a duration must have sec and nsec, got {node!r}')
    return int(node['sec']) * 1_000_000_000 + int(node['nsec'])


def parse_offered_qos(text: str) -> list[QosSpec]:
    """The profiles of an ``offered_qos_profiles`` text (policy names or numbers); ValueError
    when it is not such a list."""
    data = yaml.safe_load(text) if text.strip() else []
    if data is None:
        return []
    if not isinstance(data, list):
        raise ValueError('offered_qos_profiles must be a YAML sequence')
    out = []
    for item in data:
        try:
            out.append(QosSpec(
                history=_policy(item['history'], _HISTORY, 'history'),
                depth=int(item['depth']),
                reliability=_policy(item['reliability'], _RELIABILITY, 'reliability'),
                durability=_policy(item['durability'], _DURABILITY, 'durability'),
                deadline_ns=_ns(item['deadline']), lifespan_ns=_ns(item['lifespan']),
                liveliness=_policy(item['liveliness'], _LIVELINESS, 'liveliness'),
                liveliness_lease_duration_ns=_ns(item['liveliness_lease_duration']),
                avoid_ros_namespace_conventions=bool(item['avoid_ros_namespace_conventions'])))
        except (KeyError, TypeError) as exc:
            raise ValueError(f'malformed QoS profile {item!r}: {exc}') from None
    return out


def request_for_offers(offers: Iterable[QosSpec], *, depth: int = 100) -> QosSpec:
    """What a recorder subscribes with to hear every publisher (rosbag2's rule): reliable only
    if every publisher is, transient-local only if every publisher is; keep last ``depth``."""
    offers = list(offers)
    reliable = bool(offers) and all(o.reliability == RELIABLE for o in offers)
    transient = bool(offers) and all(o.durability == TRANSIENT_LOCAL for o in offers)
    return QosSpec(depth=depth, reliability=RELIABLE if reliable else BEST_EFFORT,
                   durability=TRANSIENT_LOCAL if transient else VOLATILE)


def offer_for_replay(offers: Sequence[QosSpec], *, depth: int = 10) -> QosSpec:
    """What a replay publishes with: the recorded publishers' reliability and durability when
    they all agree (history keep last ``depth``: the depth seen over DDS is not the
    publisher's), else reliable and volatile."""
    if offers and all((o.reliability, o.durability) == (offers[0].reliability, offers[0].durability)
                      for o in offers):
        reliability = offers[0].reliability if offers[0].reliability in (RELIABLE, BEST_EFFORT) \
            else RELIABLE
        durability = offers[0].durability if offers[0].durability in (TRANSIENT_LOCAL, VOLATILE) \
            else VOLATILE
        return QosSpec(depth=depth, reliability=reliability, durability=durability)
    return QosSpec(depth=depth)
