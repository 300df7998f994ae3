"""The contract of the robot ↔ operator link: the link topics and how an operator station names a
robot's topics (docs/deployment.md, 'Field links'). Pure Python, no ROS import.

``link_relay_node`` republishes the robot's state on the ``LINK_*`` topics (relative, in the robot's
namespace) at its link profile's rates; the 500 Hz streams stay on the robot host. An operator-station
node reads a robot's state ``'direct'`` or over ``'link'`` (:func:`robot_topic`).
"""

from __future__ import annotations

import dataclasses

from rrps_interfaces.status import StatusValues

__all__ = ['LINK_POSE', 'LINK_STATE', 'LINK_TARGET', 'LINK_GRIPPERS', 'LINK_DIAGNOSTICS', 'SOURCES',
           'link_odometry_topic', 'LINK_TOPICS', 'robot_topic', 'namespaced', 'normalize_namespace',
           'LinkRelayStatus']

LINK_POSE = 'link/pose'
LINK_STATE = 'link/actuators/state'
LINK_TARGET = 'link/target_pose'
LINK_GRIPPERS = 'link/grippers/state'
LINK_DIAGNOSTICS = 'link/diagnostics'
#: how an operator station reads a robot's state: its own topics or the link relay's
SOURCES = ('direct', 'link')


def link_odometry_topic(ring: str) -> str:
    return f'link/odometry/{ring}'


#: the robot's topic -> its link topic
LINK_TOPICS = {
    'pose': LINK_POSE,
    'actuators/state': LINK_STATE,
    'target_pose': LINK_TARGET,
    'grippers/state': LINK_GRIPPERS,
    '/diagnostics': LINK_DIAGNOSTICS,
    'odometry/ring_a': link_odometry_topic('ring_a'),
    'odometry/ring_b': link_odometry_topic('ring_b'),
    'odometry/support': 'link/odometry/support',
}


def normalize_namespace(namespace: str) -> str:
    """'' (the reader's own namespace) or an absolute namespace without a trailing slash;
    ValueError for a malformed one."""
    ns = namespace.strip()
    if ns in ('', '/'):
        return '' if ns == '' else '/'
    if not ns.startswith('/') or ns.endswith('/') or '//' in ns or not all(
            part.replace('_', 'a').isalnum() and not part[0].isdigit() for part in ns[1:].split('/')):
        raise ValueError(f'a robot namespace is absolute, like /robot_1, got {namespace!r}')
    return ns


def namespaced(topic: str, namespace: str) -> str:
    """``topic`` (relative) in ``namespace`` ('' leaves it relative: the reader's own)."""
    if topic.startswith('/') or not namespace:
        return topic
    return f'{namespace.rstrip("/")}/{topic}'


def robot_topic(topic: str, namespace: str = '', source: str = 'direct') -> str:
    """The name under which an operator station reads the robot topic ``topic`` of the robot in
    ``namespace``: ``robot_topic('pose', '/robot_2', 'link')`` is '/robot_2/link/pose';
    '/diagnostics' read over the link is the robot's ``link/diagnostics``, read directly from a
    robot in another namespace (a fleet's, whose statuses stay in its namespace:
    ``-r /diagnostics:=diagnostics``) its ``diagnostics``."""
    if source not in SOURCES:
        raise ValueError(f'source must be one of {SOURCES}, got {source!r}')
    if source == 'direct' and topic == '/diagnostics' and namespace:
        return namespaced('diagnostics', namespace)
    if source == 'link':
        if topic not in LINK_TOPICS:
            raise ValueError(f'{topic!r} has no link topic; link topics: {", ".join(LINK_TOPICS)}')
        topic = LINK_TOPICS[topic]
    return namespaced(topic, namespace)


@dataclasses.dataclass(frozen=True)
class LinkRelayStatus(StatusValues):
    """link_relay_node's /diagnostics values: samples received and sent since it started, and
    the rates [Hz] it sent over the last second (pose, actuators/state, all link topics)."""

    samples_in: int = 0
    samples_out: int = 0
    pose_rate: float = 0.0
    state_rate: float = 0.0
    out_rate: float = 0.0
