"""ROS glue shared by every rrps node: QoS, message conversion, parameters, diagnostics, main().

Only conversion and plumbing live here; all equations are in the pure modules.
"""

from __future__ import annotations

import gc
import math
import signal
import sys
import threading
from typing import Callable, Iterable, Sequence

import numpy as np
import rclpy
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
from geometry_msgs.msg import PoseStamped
from rcl_interfaces.msg import FloatingPointRange, IntegerRange, ParameterDescriptor, ParameterType
from rclpy.exceptions import ParameterException
from rclpy.executors import ExternalShutdownException, SingleThreadedExecutor
from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy
from rclpy.signals import SignalHandlerOptions
from rclpy.task import Future
from sensor_msgs.msg import JointState

from ..geometry import RobotDescriptionError, RobotGeometry, load_robot, shipped_robots
from ..interfaces import DIAGNOSTICS, LEG_NAMES, StatusValues
from ..supervision import exit_with_parent

__all__ = [
    'freeze_startup_objects',
    'LEG_NAMES',
    'COMMAND_QOS',
    'STATE_QOS',
    'LATEST_QOS',
    'OK',
    'WARN',
    'ERROR',
    'STALE',
    'declare_parameter',
    'declare_robot_parameter',
    'pose_from_msg',
    'pose_to_msg',
    'joint_state_msg',
    'lengths_from_joint_state',
    'stamp_to_seconds',
    'Diagnostics',
    'make_executor',
    'spin_until_shutdown',
    'run_nodes',
]


# Command streams best-effort depth 1 (+ a staleness check); state and status reliable (README: the ROS interface).
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

OK = DiagnosticStatus.OK
WARN = DiagnosticStatus.WARN
ERROR = DiagnosticStatus.ERROR
STALE = DiagnosticStatus.STALE


def declare_parameter(node: Node, name: str, default, description: str, *,
                      min_value: float | None = None, max_value: float | None = None,
                      read_only: bool = False, additional_constraints: str = ''):
    """Declare a parameter with a descriptor (and a range for numbers); return its value."""
    descriptor = ParameterDescriptor(description=description, read_only=read_only,
                                     additional_constraints=additional_constraints)
    if isinstance(default, bool):
        descriptor.type = ParameterType.PARAMETER_BOOL
    elif isinstance(default, int) and min_value is not None and max_value is not None:
        descriptor.type = ParameterType.PARAMETER_INTEGER
        descriptor.integer_range = [IntegerRange(from_value=int(min_value), to_value=int(max_value),
                                                 step=0)]
    elif isinstance(default, float) and min_value is not None and max_value is not None:
        descriptor.type = ParameterType.PARAMETER_DOUBLE
        descriptor.floating_point_range = [FloatingPointRange(from_value=float(min_value),
                                                              to_value=float(max_value), step=0.0)]
    return node.declare_parameter(name, default, descriptor).value


def declare_robot_parameter(node: Node, name: str = 'robot', default: str = 'pole_climber',
                            description: str | None = None) -> RobotGeometry:
    """Declare the ``robot`` parameter (a shipped robot name or a YAML path) and load it.

    Raises RobotDescriptionError with the file and key when the description is invalid, so a
    node with a bad robot refuses to start with a clear message.
    """
    value = declare_parameter(
        node, name, default,
        description or f'shipped robot name ({", ".join(shipped_robots())}) or a robot YAML path',
        read_only=True)
    return load_robot(value)


def stamp_to_seconds(stamp) -> float:
    """builtin_interfaces/Time -> float seconds."""
    return stamp.sec + 1e-9 * stamp.nanosec


def pose_from_msg(msg: PoseStamped) -> tuple[np.ndarray, np.ndarray]:
    """PoseStamped -> (position (3,), quaternion_xyzw (4,)), unvalidated floats."""
    p = msg.pose.position
    q = msg.pose.orientation
    return np.array([p.x, p.y, p.z]), np.array([q.x, q.y, q.z, q.w])


def pose_to_msg(position: Sequence[float], quaternion_xyzw: Sequence[float], *, frame_id: str,
                stamp) -> PoseStamped:
    """(position, quaternion_xyzw) -> PoseStamped in ``frame_id``."""
    msg = PoseStamped()
    msg.header.frame_id = frame_id
    msg.header.stamp = stamp
    msg.pose.position.x, msg.pose.position.y, msg.pose.position.z = (float(v) for v in position)
    (msg.pose.orientation.x, msg.pose.orientation.y, msg.pose.orientation.z,
     msg.pose.orientation.w) = (float(v) for v in quaternion_xyzw)
    return msg


def joint_state_msg(stamp, positions: Iterable[float], velocities: Iterable[float] | None = None,
                    efforts: Iterable[float] | None = None,
                    names: Sequence[str] = LEG_NAMES) -> JointState:
    """A JointState for the six legs: position = lengths [m], velocity [m/s], effort [N]."""
    msg = JointState()
    msg.header.stamp = stamp
    msg.name = list(names)
    msg.position = [float(v) for v in positions]
    if velocities is not None:
        msg.velocity = [float(v) for v in velocities]
    if efforts is not None:
        msg.effort = [float(v) for v in efforts]
    return msg


def lengths_from_joint_state(msg: JointState, names: Sequence[str] = LEG_NAMES) -> np.ndarray:
    """Leg lengths in leg order from a JointState, matched by name (any order).

    Raises ValueError naming what is wrong: missing or duplicated names, sizes that differ,
    NaN or infinite values. An unnamed message with exactly six positions is taken in order.
    """
    if len(msg.position) == len(names) and tuple(msg.name) == tuple(names):  # the usual message
        values = np.array(msg.position, dtype=float)
        if not np.isfinite(values).all():
            raise ValueError('positions contain NaN or infinite values')
        return values
    positions = list(msg.position)
    if not msg.name:
        if len(positions) != len(names):
            raise ValueError(f'expected {len(names)} positions, got {len(positions)}')
        values = np.asarray(positions, dtype=float)
    else:
        if len(msg.name) != len(positions):
            raise ValueError(f'{len(msg.name)} names but {len(positions)} positions')
        if len(set(msg.name)) != len(msg.name):
            raise ValueError('duplicated joint names')
        index = {n: i for i, n in enumerate(msg.name)}
        missing = [n for n in names if n not in index]
        if missing:
            raise ValueError(f'missing joints {missing}')
        values = np.array([positions[index[n]] for n in names], dtype=float)
    if not np.all(np.isfinite(values)):
        raise ValueError('positions contain NaN or infinite values')
    return values


class Diagnostics:
    """Publishes one DiagnosticStatus of a node on /diagnostics, at most ``rate_hz`` per second
    unless the level or message changes (so a rejection is reported at once)."""

    def __init__(self, node: Node, name: str, *, hardware_id: str = '', rate_hz: float = 2.0):
        self._node = node
        self._name = f'{node.get_name()}: {name}'
        self._hardware_id = hardware_id
        self._period = 1.0 / rate_hz
        self._pub = node.create_publisher(DiagnosticArray, DIAGNOSTICS, STATE_QOS)
        self._last_key: tuple[bytes, str] | None = None
        self._last_time = -math.inf
        self.level = OK
        self.message = ''

    def report(self, level: bytes, message: str, values: StatusValues | dict | None = None, *,
               force: bool = False) -> None:
        """Publish a status now if it changed, if forced, or if the period has elapsed.

        ``values``: the node's typed status (:class:`rrps_kinematics.interfaces.StatusValues`),
        or a plain dict for values no other node reads."""
        self.level, self.message = level, message
        now = self._node.get_clock().now()
        t = now.nanoseconds * 1e-9
        key = (bytes(level), message)
        if not force and key == self._last_key and t - self._last_time < self._period:
            return
        self._last_key, self._last_time = key, t
        status = DiagnosticStatus(level=level, name=self._name, message=message,
                                  hardware_id=self._hardware_id)
        if isinstance(values, StatusValues):
            status.values = [KeyValue(key=k, value=v) for k, v in values.to_values().items()]
        else:
            status.values = [KeyValue(key=str(k), value=_format_value(v))
                             for k, v in (values or {}).items()]
        msg = DiagnosticArray()
        msg.header.stamp = now.to_msg()
        msg.status = [status]
        self._pub.publish(msg)


def _format_value(value) -> str:
    if isinstance(value, float):
        return f'{value:.6g}'
    if isinstance(value, np.ndarray):
        return np.array2string(value, precision=6, separator=',', max_line_width=10_000)
    return str(value)


def make_executor(context, kind: str = 'events'):
    """An EventsExecutor (about 5x lower latency here) or a SingleThreadedExecutor."""
    if kind == 'events':
        from rclpy.experimental import EventsExecutor
        return EventsExecutor(context=context)
    if kind == 'single':
        return SingleThreadedExecutor(context=context)
    raise ValueError(f"executor kind must be 'events' or 'single', got {kind!r}")


def spin_until_shutdown(executor, context, stop: threading.Event | None = None, *,
                        period: float = 0.1) -> None:
    """Spin until the context shuts down, ``stop`` is set, or Ctrl-C.

    rclpy 7.1's EventsExecutor.spin() blocks in C++ and never sees SIGINT (and shutting it down
    from another thread hangs), so spin in slices of ``period`` s (on a future that never
    completes: every event of a slice is handled in C++, cheaper than one spin_once per event)
    and check between them.
    """
    never = Future()
    while context.ok() and not (stop is not None and stop.is_set()):
        executor.spin_until_future_complete(never, timeout_sec=period)


def freeze_startup_objects() -> None:
    """Move every object alive now (modules, compiled kernels, the nodes) out of the garbage
    collector's reach (``gc.freeze``), once a process has started its nodes.

    A full collection otherwise walks them all: about 150,000 objects, 70-100 ms here with the
    GIL held, long enough for a 0.1 s command timeout to reject a message queued behind it.
    """
    gc.collect()
    gc.freeze()


def run_nodes(factories: Sequence[Callable[..., Node]], args=None, *, executor_kind: str = 'events') -> None:
    """Jazzy ``main()`` pattern: init, spin the nodes in one executor, clean Ctrl-C shutdown.

    ``factories`` are node classes (or callables) taking ``context=``. A node that cannot start
    (an invalid robot description or parameter) prints one line and exits with status 2.
    SIGINT and SIGTERM end the spin between callbacks (never inside one), then nodes are destroyed.
    A process started by :func:`rrps_kinematics.supervision.start_child` also stops when its
    supervisor is gone.
    """
    stop = threading.Event()
    exit_with_parent(stop.set)
    context = rclpy.Context()
    rclpy.init(args=args, context=context, signal_handler_options=SignalHandlerOptions.NO)
    previous = {sig: signal.signal(sig, lambda *_: stop.set()) for sig in (signal.SIGINT, signal.SIGTERM)}
    nodes: list[Node] = []
    try:
        try:
            for factory in factories:
                nodes.append(factory(context=context))
        except (RobotDescriptionError, ValueError, ParameterException) as exc:
            print(f'error: {exc}', file=sys.stderr)
            raise SystemExit(2) from None
        executor = make_executor(context, executor_kind)
        for node in nodes:
            executor.add_node(node)
        freeze_startup_objects()
        spin_until_shutdown(executor, context, stop)
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    finally:
        for sig, handler in previous.items():
            signal.signal(sig, handler)
        for node in nodes:
            node.destroy_node()
        rclpy.try_shutdown(context=context)
