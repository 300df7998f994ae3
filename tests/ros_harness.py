"""Launch-free ROS test harness: nodes spun in-process by one executor on a private Context.

Usage (with the ``ros_context`` fixture of conftest.py, which gives a private domain id)::

    probe = Probe(context=ros_context)
    poses = probe.collect(PoseStamped, 'pose')
    with Spinner(ros_context, [IkNode(context=ros_context), probe]):
        probe.publisher(PoseStamped, 'target_pose').publish(msg)
        wait_for(lambda: poses, timeout=2.0)
"""

from __future__ import annotations

import threading
import time
from typing import Callable, Sequence

from rclpy.node import Node

from rrps_kinematics.nodes.common import COMMAND_QOS, STATE_QOS, make_executor, spin_until_shutdown


def wait_for(predicate: Callable[[], object], timeout: float = 2.0, period: float = 0.002) -> bool:
    """Poll ``predicate`` until it is truthy or ``timeout`` s pass; return its last truthiness."""
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        if predicate():
            return True
        time.sleep(period)
    return bool(predicate())


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
        self._thread.join(timeout=5.0)
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

    def collect(self, msg_type, topic: str, *, qos=STATE_QOS, stamped: bool = False) -> list:
        """Subscribe and return the (growing) list of received messages, or (t_monotonic, msg)."""
        received: list = []

        def callback(msg) -> None:
            with self._lock:
                received.append((time.monotonic(), msg) if stamped else msg)

        self.create_subscription(msg_type, topic, callback, qos)
        return received

    def publisher(self, msg_type, topic: str, *, command: bool = False):
        """A publisher with the command QoS (best effort, depth 1) or the state QoS."""
        return self.create_publisher(msg_type, topic, COMMAND_QOS if command else STATE_QOS)
