"""A node's ROS 2 actions, and its services whose reply waits, served whatever executor the node runs on.

rclpy's EventsExecutor serves no action and no coroutine callback, so a node's action servers and clients,
and services whose reply awaits work done elsewhere, live on a node of their own
(``<node>_actions``, without parameter services) spun by a SingleThreadedExecutor in a thread until
:meth:`ActionHost.close`. Their callbacks run in that thread: what they share with the node's needs a lock.
"""

from __future__ import annotations

import threading

from rclpy.executors import ExternalShutdownException, SingleThreadedExecutor
from rclpy.node import Node

__all__ = ['ActionHost']


class ActionHost:
    """The node ``host.node`` on which ``owner``'s actions are created, and the thread spinning it."""

    def __init__(self, owner: Node):
        self.node = Node(f'{owner.get_name()}_actions', namespace=owner.get_namespace(), context=owner.context,
                         start_parameter_services=False)
        self._executor = SingleThreadedExecutor(context=owner.context)
        self._executor.add_node(self.node)
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._spin, name=f'{owner.get_name()}-actions', daemon=True)
        self._thread.start()

    def _spin(self) -> None:
        while not self._stop.is_set() and self.node.context.ok():
            try:
                self._executor.spin_once(timeout_sec=0.05)
            except ExternalShutdownException:
                return

    def stop(self) -> None:
        """Stop the thread: the node's actions can be destroyed (not while it waits on them)."""
        self._stop.set()
        self._thread.join(timeout=5.0)

    def close(self) -> None:
        """Stop the thread and destroy the node (the owner's destroy_node calls this)."""
        self.stop()
        self._executor.remove_node(self.node)
        self.node.destroy_node()
