"""What the recorder and the Foxglove bridge read from the ROS graph about a topic: whether their
``topics`` parameter selects it, the QoS its publishers offer (as
:class:`rrps_recording.storage.qos.QosSpec`), a subscription QoS that hears them all (rosbag2's
rule), the type hash as rosbag2 writes it, and the topic as a recording holds it."""

from __future__ import annotations

from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy

from rrps_recording.storage.bag_metadata import TopicInfo
from rrps_recording.storage.qos import QosSpec, request_for_offers
from rrps_recording.storage.schemas import message_class, message_schema

__all__ = ['selected', 'qos_spec', 'subscription_qos', 'type_hash_text', 'offered', 'subscription_for',
           'recorded_topic']

#: Topics never recorded nor bridged.
IGNORED = ('/rosout', '/parameter_events')


def selected(name: str, namespace: str, entries, absolute) -> bool:
    """Whether the ``topics`` parameter's ``entries`` select topic ``name``: the entry '' selects
    the topics of ``namespace`` (every topic in the root namespace) and the ``absolute`` ones;
    another entry selects that topic and the ones under it. :data:`IGNORED` never."""
    if name in IGNORED:
        return False
    ns = namespace.rstrip('/')
    for entry in entries:
        if entry == '':
            if name in absolute or not ns or name.startswith(ns + '/'):
                return True
        elif name == entry or name.startswith(entry.rstrip('/') + '/'):
            return True
    return False


def qos_spec(profile) -> QosSpec:
    """An rclpy QoSProfile as plain values."""
    def ns(duration) -> int:
        return int(duration.nanoseconds)
    return QosSpec(history=int(profile.history), depth=int(profile.depth),
                   reliability=int(profile.reliability), durability=int(profile.durability),
                   deadline_ns=ns(profile.deadline), lifespan_ns=ns(profile.lifespan),
                   liveliness=int(profile.liveliness),
                   liveliness_lease_duration_ns=ns(profile.liveliness_lease_duration),
                   avoid_ros_namespace_conventions=bool(profile.avoid_ros_namespace_conventions))


def type_hash_text(type_hash) -> str:
    """rclpy's TypeHash as rosbag2 writes it ('RIHS01_<hex>'; '' when unset)."""
    if type_hash is None or getattr(type_hash, 'version', -1) != 1:
        return ''
    return f'RIHS{type_hash.version:02d}_{bytes(type_hash.value).hex()}'


def subscription_qos(spec: QosSpec) -> QoSProfile:
    """The rclpy QoSProfile of a subscription that requests ``spec`` (history keep-last)."""
    return QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=spec.depth,
                      reliability=ReliabilityPolicy(spec.reliability),
                      durability=DurabilityPolicy(spec.durability))


def offered(infos) -> tuple[QosSpec, ...]:
    """The QoS each publisher (rclpy TopicEndpointInfo) offers."""
    return tuple(qos_spec(info.qos_profile) for info in infos)


def subscription_for(offers, depth: int) -> QoSProfile:
    """A subscription that connects to every publisher of ``offers`` (keep last ``depth``)."""
    return subscription_qos(request_for_offers(offers, depth=depth))


def recorded_topic(name: str, type_name: str, infos) -> TopicInfo:
    """Topic ``name`` of type ``type_name`` as a recording holds it, from its publishers' endpoint
    infos; ValueError saying why when the type has no message class or ``ros2msg`` schema here."""
    try:
        message_class(type_name)
        message_schema(type_name)
    except (ImportError, AttributeError, ValueError, LookupError) as exc:
        raise ValueError(f'{type_name}: {exc}') from None
    return TopicInfo(name, type_name, offered(infos), type_hash_text(infos[0].topic_type_hash))
