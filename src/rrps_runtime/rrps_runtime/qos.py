"""The QoS profiles of the rrps topics: commands best effort, depth 1, checked for staleness by the receiver
(:mod:`rrps_runtime.freshness`); state and status reliable; latched topics transient local; link state best effort
keep-last-1 (a lost sample is replaced by the next, never resent) and link events latched (:mod:`rrps_interfaces.link`).
"""

from __future__ import annotations

from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy

__all__ = ['COMMAND_QOS', 'STATE_QOS', 'LATEST_QOS', 'LATCHED_QOS', 'LINK_STATE_QOS', 'LINK_EVENT_QOS',
           'CLOCK_QOS']

COMMAND_QOS = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=1,
                         reliability=ReliabilityPolicy.BEST_EFFORT,
                         durability=DurabilityPolicy.VOLATILE)
STATE_QOS = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=10,
                       reliability=ReliabilityPolicy.RELIABLE,
                       durability=DurabilityPolicy.VOLATILE)
#: Subscriber side of a state stream whose reader only needs the newest sample (a pose, a
#: state it draws or checks): reliable, keep last 1. After a stall the reader sees the newest
#: sample once instead of working through a backlog of old ones (compatible with STATE_QOS).
LATEST_QOS = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=1,
                        reliability=ReliabilityPolicy.RELIABLE,
                        durability=DurabilityPolicy.VOLATILE)
#: A latched topic (robot_description as robot_state_publisher publishes it, /tf_static as
#: tf2_ros' StaticTransformBroadcaster does): reliable, transient local, keep last 1.
LATCHED_QOS = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=1,
                         reliability=ReliabilityPolicy.RELIABLE,
                         durability=DurabilityPolicy.TRANSIENT_LOCAL)
#: A link state stream (link/pose, link/actuators/state, ...), both sides: best effort, keep
#: last 1. A best-effort reader also matches a reliable writer (the robot's own topics).
LINK_STATE_QOS = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=1,
                            reliability=ReliabilityPolicy.BEST_EFFORT,
                            durability=DurabilityPolicy.VOLATILE)
#: A link event stream (link/grippers/state, link/diagnostics), both sides: latched, so that a
#: reader that joins late (an operator station switching to this robot) gets the newest at once.
LINK_EVENT_QOS = LATCHED_QOS
#: /clock, as rclcpp's ClockQoS offers it and rclpy's TimeSource reads it: best effort, keep
#: last 1 (a late tick is worthless once the next one is out).
CLOCK_QOS = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=1,
                       reliability=ReliabilityPolicy.BEST_EFFORT,
                       durability=DurabilityPolicy.VOLATILE)
