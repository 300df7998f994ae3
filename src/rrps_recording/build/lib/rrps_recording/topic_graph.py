"""What the recorder and the Foxglove bridge read from the ROS graph about a topic: the QoS its
publishers offer (as :class:`rrps_recording.storage.qos.QosSpec`), a subscription QoS that hears
them all (rosbag2's rule), and the type hash as rosbag2 writes it."""

from __future__ import annotations

from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy

from rrps_recording.storage.qos import QosSpec, request_for_offers

__all__ = ['qos_spec', 'subscription_qos', 'type_hash_text', 'offered', 'subscription_for']


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
