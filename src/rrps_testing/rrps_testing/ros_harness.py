"""Launch-free ROS test harness: nodes spun in-process by one executor on a private Context.

:class:`Spinner` spins nodes (with conftest.py's ``ros_context``: a private domain id); a :class:`Probe`
publishes and collects. A test never sleeps to let something happen: it waits for the thing itself
(:func:`wait_for`, up to :data:`DEADLINE`); one that asserts that nothing happens measures its window with the
messages' stamps or the receipt times :meth:`Probe.collect` records.
"""

from __future__ import annotations

import threading
import time
from typing import Callable, Sequence

from rclpy.node import Node
from rclpy.parameter import Parameter
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy

from rrps_runtime.process import make_executor, spin_until_shutdown
from rrps_runtime.qos import COMMAND_QOS, STATE_QOS

#: What a Probe records a stream with: a deep history, so that a stall of the test's executor
#: loses no sample (the recorded sequence is complete). Reliable for state streams (compatible
#: with STATE_QOS), best effort for command streams (compatible with COMMAND_QOS).
RECORD_STATE_QOS = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=1000,
                              reliability=ReliabilityPolicy.RELIABLE,
                              durability=DurabilityPolicy.VOLATILE)
RECORD_COMMAND_QOS = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=1000,
                                reliability=ReliabilityPolicy.BEST_EFFORT,
                                durability=DurabilityPolicy.VOLATILE)


#: Deadline [s] of a wait for something that must happen: far above any stall of a loaded
#: 2-core machine, never reached when the behaviour is right.
DEADLINE = 60.0
#: The age [s] of a command the driver and IK nodes of a test's in-process stack act on (their
#: ``timeout``, 0.1 s by default): relaxed for a loaded machine (docs/tests.md).
IN_PROCESS_COMMAND_TIMEOUT = 1.0


def params(**values) -> list:
    """rclpy Parameters from keyword values (a node's ``parameter_overrides``)."""
    return [Parameter(k, value=v) for k, v in values.items()]


def wait_for(predicate: Callable[[], object], timeout: float = DEADLINE, period: float = 0.005) -> bool:
    """Poll ``predicate`` until it is truthy or ``timeout`` s pass; return its last truthiness.

    ``timeout`` is a deadline, not a duration: keep it generous (the default) for anything that
    should happen. A predicate that publishes (streams a target until it is reached) publishes
    once per ``period``.
    """
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        if predicate():
            return True
        time.sleep(period)
    return bool(predicate())


def settled(value: Callable[[], object], quiet: float = 0.5, timeout: float = DEADLINE) -> object:
    """``value()`` once it has not changed for ``quiet`` s (messages still queued when a stream
    stopped are taken first), or its value at ``timeout``."""
    deadline = time.monotonic() + timeout
    last, since = value(), time.monotonic()
    while time.monotonic() < deadline:
        time.sleep(0.02)
        now = value()
        if now != last:
            last, since = now, time.monotonic()
        elif time.monotonic() - since >= quiet:
            break
    return last


class Spinner:
    """Spin ``nodes`` in a background thread (EventsExecutor by default); destroy them on exit."""

    def __init__(self, context, nodes: Sequence[Node], *, executor_kind: str = 'events'):
        self._context = context
        self._nodes = list(nodes)
        self._stop = threading.Event()
        self._executor = make_executor(context, executor_kind)
        for node in self._nodes:
            self._executor.add_node(node)
        self._thread = threading.Thread(target=self._spin, daemon=True)
        self.error: BaseException | None = None

    def _spin(self) -> None:
        try:
            spin_until_shutdown(self._executor, self._context, self._stop, period=0.01)
        except BaseException as exc:  # surfaced to the test by __exit__
            self.error = exc

    def __enter__(self) -> 'Spinner':
        self._thread.start()
        return self

    def __exit__(self, *exc_info) -> None:
        self._stop.set()
        self._thread.join(timeout=DEADLINE)  # returns as soon as the spin slice ends
        for node in self._nodes:
            node.destroy_node()
        if self._thread.is_alive():
            raise RuntimeError('executor thread did not stop')
        if self.error is not None and exc_info[0] is None:
            raise self.error


class Probe(Node):
    """A test-side node: collects messages and offers publishers with the project's QoS."""

    def __init__(self, *, context, name: str = 'probe', namespace: str = ''):
        super().__init__(name, context=context, namespace=namespace)
        self._lock = threading.Lock()

    def collect(self, msg_type, topic: str, *, qos=STATE_QOS, stamped: bool = False,
                clock: str = 'monotonic') -> list:
        """Subscribe and return the (growing) list of received messages, or with ``stamped``
        (t_received, msg) on ``clock`` 'monotonic' or 'ros' (the clock of the header stamps); ``qos``
        (STATE_QOS or COMMAND_QOS) picks the matching deep-history RECORD_*_QOS."""
        if clock not in ('monotonic', 'ros'):
            raise ValueError(f"clock must be 'monotonic' or 'ros', got {clock!r}")
        if qos.reliability == ReliabilityPolicy.BEST_EFFORT:
            qos = RECORD_COMMAND_QOS
        else:
            qos = RECORD_STATE_QOS
        received: list = []
        now = time.monotonic if clock == 'monotonic' else self.now

        def callback(msg) -> None:
            with self._lock:
                received.append((now(), msg) if stamped else msg)

        self.create_subscription(msg_type, topic, callback, qos)
        return received

    def now(self) -> float:
        """This node's ROS clock [s] (the clock of the header stamps)."""
        return self.get_clock().now().nanoseconds * 1e-9

    def publisher(self, msg_type, topic: str, *, command: bool = False):
        """A publisher with the command QoS (best effort, depth 1) or the state QoS."""
        return self.create_publisher(msg_type, topic, COMMAND_QOS if command else STATE_QOS)


def stamped_between(messages: list, t0: float, t1: float = float('inf')) -> list:
    """The messages (or (t, msg) items) whose header stamp lies in [t0, t1] [s]."""
    return [m for m in list(messages) if t0 <= header_time(m) <= t1]


def header_time(item) -> float:
    """The header stamp [s] of a message or of a (t, msg) item."""
    msg = item[1] if isinstance(item, tuple) else item
    return msg.header.stamp.sec + 1e-9 * msg.header.stamp.nanosec
