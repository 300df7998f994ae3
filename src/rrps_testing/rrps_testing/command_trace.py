"""A per-hop trace of the command path, taken by an operator probe, for benchmarks/command_path.py.

:class:`CommandTrace` holds the deadman (``teleop/enable``, 20 Hz) and records every message of each hop
(master/pose, target_pose, actuators/command, pose, grippers/state, teleop/status, climb/status, the newest
/diagnostics of each node) with its receipt time and header stamp; :func:`hops` matches them into per-hop
latencies. :func:`claim_probe` puts the probe above the stack's priority; :class:`Canary` shows stops of every
real-time thread as late wake-ups. Nothing here acts on the robot but the deadman.
"""

from __future__ import annotations

import collections
import threading
import time

import numpy as np
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus
from geometry_msgs.msg import PoseStamped
from rclpy.node import Node
from sensor_msgs.msg import JointState
from std_msgs.msg import Bool

from rrps_interfaces.climb import CLIMB_STATUS
from rrps_interfaces.driver import GRIPPERS_STATE
from rrps_interfaces.kinematics import ACTUATORS_COMMAND, POSE, TARGET_POSE
from rrps_interfaces.status import DIAGNOSTICS, source_node
from rrps_interfaces.teleop import DISENGAGED_CODES, MASTER_POSE, TELEOP_ENABLE, TELEOP_STATUS, TeleopCode, TeleopStatus
from rrps_runtime.command_path import claim_executor
from rrps_runtime.qos import COMMAND_QOS, STATE_QOS
from rrps_runtime.scheduling import Request, claim_thread
from rrps_testing.ros_harness import RECORD_COMMAND_QOS, RECORD_STATE_QOS

__all__ = ['CommandTrace', 'Canary', 'claim_probe', 'hops', 'drive_target_times', 'gaps', 'disengagements',
           'percentiles', 'PROBE_PRIORITY']

#: The probe's SCHED_RR priority: above every thread of the stack (the drives' 20, the bus' 12).
PROBE_PRIORITY = 40


def _stamp(msg) -> float:
    return msg.header.stamp.sec + 1e-9 * msg.header.stamp.nanosec


class CommandTrace(Node):
    """The operator probe (module docstring)."""

    def __init__(self, *, context, namespace: str, enable_rate: float = 20.0):
        super().__init__('command_trace', context=context, namespace=namespace)
        self.lock = threading.Lock()
        self.records: dict[str, list] = collections.defaultdict(list)
        self.statuses: list[tuple[float, TeleopCode, bool, float | None]] = []
        self.diagnostics: dict[str, dict[str, str]] = {}
        self.climb_state = ''
        self.climb_log: list[tuple[float, str, str]] = []  # (receipt, state, detail) on each change
        self.holding = False
        for topic, kind, qos in ((MASTER_POSE, PoseStamped, RECORD_STATE_QOS), (TARGET_POSE, PoseStamped,
                                 RECORD_COMMAND_QOS), (POSE, PoseStamped, RECORD_STATE_QOS),
                                 (GRIPPERS_STATE, JointState, RECORD_STATE_QOS)):
            self.create_subscription(kind, topic, self._recorder(topic), qos)
        self.create_subscription(JointState, ACTUATORS_COMMAND, self._on_command, RECORD_COMMAND_QOS)
        self.create_subscription(DiagnosticStatus, TELEOP_STATUS, self._on_teleop, STATE_QOS)
        self.create_subscription(DiagnosticArray, DIAGNOSTICS, self._on_diagnostics, STATE_QOS)
        self.create_subscription(DiagnosticStatus, CLIMB_STATUS, self._on_climb, STATE_QOS)
        self._enable = self.create_publisher(Bool, TELEOP_ENABLE, COMMAND_QOS)
        self.create_timer(1.0 / enable_rate, self._hold)

    def now(self) -> float:
        return self.get_clock().now().nanoseconds * 1e-9

    def _recorder(self, topic: str):
        def record(msg) -> None:
            self.records[topic].append((self.now(), _stamp(msg)))
        return record

    def _on_command(self, msg: JointState) -> None:
        self.records[ACTUATORS_COMMAND].append((self.now(), _stamp(msg), float(msg.position[0])))

    def _on_teleop(self, msg: DiagnosticStatus) -> None:
        try:
            s = TeleopStatus.from_key_values(msg.values)
        except ValueError:
            return
        self.statuses.append((self.now(), s.code, s.engaged, s.slave_age_ms))

    def _on_diagnostics(self, msg: DiagnosticArray) -> None:
        with self.lock:
            for status in msg.status:
                self.diagnostics[source_node(status.name)] = {kv.key: kv.value for kv in status.values}

    def _on_climb(self, msg: DiagnosticStatus) -> None:
        detail = next((kv.value for kv in msg.values if kv.key == 'detail'), '')
        if not self.climb_log or self.climb_log[-1][1:] != (msg.message, detail):
            self.climb_log.append((self.now(), msg.message, detail))
        self.climb_state = msg.message

    def _hold(self) -> None:
        if self.holding:
            self._enable.publish(Bool(data=True))

    def engaged(self) -> bool:
        return bool(self.statuses) and self.statuses[-1][2]

    def values(self, node: str) -> dict[str, str]:
        with self.lock:
            return dict(self.diagnostics.get(node, {}))

    def between(self, topic: str, t0: float, t1: float) -> np.ndarray:
        """The records of ``topic`` received in [t0, t1], as an array (receipt, stamp[, value])."""
        rows = [r for r in list(self.records[topic]) if t0 <= r[0] <= t1]
        return np.array(rows, dtype=float) if rows else np.empty((0, 3))


class Canary:
    """A SCHED_RR thread at ``priority`` that sleeps 1 ms at a time and keeps how late it woke."""

    def __init__(self, priority: int = PROBE_PRIORITY + 5):
        self.priority = priority
        self.late: list[tuple[float, float]] = []  # (monotonic time, lateness [s]) above 2 ms
        self.granted = None
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, name='rt-canary', daemon=True)

    def _run(self) -> None:
        self.granted = claim_thread(Request(self.priority), 'rt-canary')
        while not self._stop.is_set():
            t = time.monotonic()
            time.sleep(0.001)
            late = time.monotonic() - t - 0.001
            if late > 0.002:
                self.late.append((t, late))

    def __enter__(self) -> 'Canary':
        self._thread.start()
        return self

    def __exit__(self, *exc) -> None:
        self._stop.set()
        self._thread.join(5.0)

    def stops(self, t0: float, t1: float, longer_than: float = 0.02) -> list[float]:
        """The wake-ups in [t0, t1] (monotonic) later than ``longer_than`` s: every real-time
        thread stopped (RT throttling) or this one waited for a CPU."""
        return [late for t, late in list(self.late) if t0 <= t <= t1 and late > longer_than]


def claim_probe(executor, cpus: tuple[int, ...] = ()):
    """The probe's executor (spun by the calling thread), its timer threads (the deadman's) and
    the middleware's threads at :data:`PROBE_PRIORITY` (on ``cpus``: all when empty); what they got."""
    return claim_executor(Request(PROBE_PRIORITY, tuple(cpus)), executor)


def percentiles(values_ms) -> tuple[int, float, float, float, float]:
    """(n, p50, p99, p99.9, max) of a set of milliseconds (NaN when empty)."""
    v = np.asarray(values_ms, dtype=float)
    if v.size == 0:
        return 0, np.nan, np.nan, np.nan, np.nan
    p = np.percentile(v, [50.0, 99.0, 99.9])
    return int(v.size), float(p[0]), float(p[1]), float(p[2]), float(v.max())


def gaps(receipts: np.ndarray) -> np.ndarray:
    """Gaps [ms] between successive receipt times [s]."""
    return 1e3 * np.diff(np.sort(receipts))


def hops(trace: CommandTrace, t0: float, t1: float, drive_targets: np.ndarray | None = None) -> dict[str, np.ndarray]:
    """Per-hop latencies [ms] of the messages received in [t0, t1] (this host's ROS clock), by hop:
    ``master -> teleop out`` (a target_pose's stamp minus the master sample received last before it),
    ``teleop -> robot`` (a target_pose's receipt minus its stamp), ``IK`` (an actuators/command's receipt minus
    that of the target_pose of its stamp), on CANopen ``IK -> drive target`` and ``next command -> drive target``
    (:func:`drive_target_times`; docs/measurements.md, 'The command path, hop by hop'), ``state -> operator`` (a
    pose's receipt minus its stamp) and ``end to end`` (a master sample's stamp to its command's receipt, or to
    its drive target on CANopen)."""
    master, targets = trace.between(MASTER_POSE, t0, t1), trace.between(TARGET_POSE, t0, t1)
    commands, poses = trace.between(ACTUATORS_COMMAND, t0, t1), trace.between(POSE, t0, t1)
    out: dict[str, np.ndarray] = {}
    if len(master) and len(targets):
        order = np.argsort(master[:, 0])
        m_recv, m_stamp = master[order, 0], master[order, 1]
        k = np.searchsorted(m_recv, targets[:, 1], side='right') - 1
        ok = k >= 0
        out['master -> teleop out'] = 1e3 * (targets[ok, 1] - m_recv[k[ok]])
        origin = dict(zip(targets[ok, 1], m_stamp[k[ok]]))
    else:
        origin = {}
    if len(targets):
        out['teleop -> robot'] = 1e3 * (targets[:, 0] - targets[:, 1])
    if len(commands) and len(targets):
        sent = dict(zip(targets[:, 1], targets[:, 0]))
        pairs = [(c[0], sent[c[1]]) for c in commands if c[1] in sent]
        out['IK'] = 1e3 * np.array([c - t for c, t in pairs])
    end = []
    if drive_targets is not None and len(commands) and len(drive_targets):
        reached = drive_target_times(commands, drive_targets)
        out['IK -> drive target'] = 1e3 * (reached[:, 1] - reached[:, 0])
        out['next command -> drive target'] = 1e3 * (reached[:, 1] - reached[:, 2])[np.isfinite(reached[:, 2])]
        end = [hit - origin[stamp] for _, hit, _, stamp in reached if stamp in origin]
    elif len(commands):
        end = [c[0] - origin[c[1]] for c in commands if c[1] in origin]
    if len(poses):
        out['state -> operator'] = 1e3 * (poses[:, 0] - poses[:, 1])
    out['end to end'] = 1e3 * np.array(end)
    return out


def drive_target_times(commands: np.ndarray, drive_targets: np.ndarray) -> np.ndarray:
    """For each command (rows of receipt, stamp, leg_1 length) where leg_1 moves at a quarter of
    its usual speed or more (:func:`hops`): its receipt, the first time the drives' leg_1 target
    (rows of SYNC time, target) reaches its length, the receipt of the next command (nan for the
    last) and its stamp, as rows."""
    times, values = drive_targets[:, 0], drive_targets[:, 1]
    commands = commands[np.argsort(commands[:, 0])]
    speed = np.abs(np.gradient(commands[:, 2], commands[:, 1])) if len(commands) > 2 else np.zeros(len(commands))
    moving = speed >= 0.25 * np.percentile(speed, 95)
    rows = []
    for k, (received, stamp, length) in enumerate(commands):
        hit = _reached(times, values, length, received - 0.005, received + 1.0) if moving[k] else None
        if hit is not None:
            rows.append((received, hit, commands[k + 1, 0] if k + 1 < len(commands) else np.nan, stamp))
    return np.array(rows, dtype=float).reshape(-1, 4)


def _reached(times: np.ndarray, values: np.ndarray, length: float, t0: float, t1: float) -> float | None:
    """The first time in [t0, t1) at which ``values`` equal ``length`` (within 0.5 um) or pass it
    since the sample before; None if they never do."""
    i, j = np.searchsorted(times, t0), np.searchsorted(times, t1)
    v = values[max(i - 1, 0):j] - length
    hit = np.flatnonzero((np.abs(v[1:]) < 5e-7) | (v[:-1] * v[1:] < 0.0))
    return float(times[max(i - 1, 0) + 1 + hit[0]]) if hit.size else None


def disengagements(trace: CommandTrace, t0: float, t1: float) -> collections.Counter:
    """How many times teleop went from engaged to a disengaged code in [t0, t1], by code."""
    counts: collections.Counter = collections.Counter()
    engaged = None
    for t, code, is_engaged, _ in list(trace.statuses):
        if t0 <= t <= t1 and engaged and code in DISENGAGED_CODES:
            counts[code.name] += 1
        engaged = is_engaged
    return counts
