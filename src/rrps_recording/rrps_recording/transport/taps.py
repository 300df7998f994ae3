"""Which topics the recorder takes from recording taps, and when their messages happened. No rclpy.

:class:`TapRouter` takes a topic from the bundles (:mod:`rrps_runtime.recording_bundle`) when **every** publisher
of it taps it, else from the recorder's own subscription, ignoring the bundles' copies. A switch loses and
doubles nothing: for ``TRANSITION_NS`` after it both sources are taken, and a message whose CDR bytes were just
recorded (within ``RECENT_NS``) is dropped (every tapped message carries a stamp: equal bytes are the same
publication). A bundled message is logged at its publish time plus the node's smallest (receipt - send) delay
of its last ``OFFSET_WINDOW`` bundles: the clock offset between the hosts plus the quickest delivery.
"""

from __future__ import annotations

import collections
from typing import Iterable

from rrps_runtime.recording_bundle import Bundle

__all__ = ['TapRouter', 'OFFSET_WINDOW', 'fully_qualified_node']

#: Bundles over which a node's smallest delay is taken (5 s at 10 bundles/s).
OFFSET_WINDOW = 50
#: After a switch, both sources are taken, without doubles, for this long [ns].
TRANSITION_NS = 1_000_000_000
#: Each topic's messages of this last span [ns] are remembered for a switch (a bundle holds at
#: most its flush period, 0.1 s, of messages).
RECENT_NS = 2_000_000_000


def fully_qualified_node(namespace: str, name: str) -> str:
    """'/rrps/fk_node' from a graph entry's namespace and name (what a bundle names itself)."""
    return f'{namespace.rstrip("/")}/{name}'


class TapRouter:
    """Routes bundle messages to the recording; see the module docstring."""

    def __init__(self, *, offset_window: int = OFFSET_WINDOW):
        self._tables: dict[str, frozenset[str]] = {}
        self._delays: dict[str, collections.deque] = {}
        self._offset_window = offset_window
        self._tapped: set[str] = set()
        self._recent: dict[str, collections.deque] = {}
        self._transitions: dict[str, tuple[int, set[bytes]]] = {}

    def covers(self, topic: str, publisher_nodes: Iterable[str]) -> bool:
        """True when every publisher of ``topic`` (at least one) taps it."""
        nodes = set(publisher_nodes)
        return bool(nodes) and all(topic in self._tables.get(n, ()) for n in nodes)

    def is_tapped(self, topic: str) -> bool:
        return topic in self._tapped

    @property
    def tapped_topics(self) -> tuple[str, ...]:
        return tuple(sorted(self._tapped))

    def set_tapped(self, topic: str, tapped: bool, now_ns: int) -> bool:
        """Take ``topic`` from the bundles (or from the subscription) from now on; True if it
        changed (both sources are then taken for TRANSITION_NS, without doubles)."""
        if tapped == (topic in self._tapped):
            return False
        if tapped:
            self._tapped.add(topic)
        else:
            self._tapped.discard(topic)
        recent = self._recent.get(topic, ())
        self._transitions[topic] = (now_ns + TRANSITION_NS, {data for _, data in recent})
        return True

    def forget(self, alive_nodes: Iterable[str]) -> None:
        """Drop what is known of the nodes not in ``alive_nodes`` (their bundle topic is gone)."""
        alive = set(alive_nodes)
        for node in [n for n in self._tables if n not in alive]:
            del self._tables[node]
            self._delays.pop(node, None)

    def _take(self, topic: str, data: bytes, now_ns: int, *, from_bundle: bool) -> bool:
        """Whether to record a message; remembers it for a switch."""
        transition = self._transitions.get(topic)
        if transition is not None and now_ns >= transition[0]:
            del self._transitions[topic]
            transition = None
        if transition is not None:
            if data in transition[1]:
                return False
            transition[1].add(data)
        elif from_bundle != (topic in self._tapped):
            return False
        recent = self._recent.get(topic)
        if recent is None:
            recent = self._recent[topic] = collections.deque()
        recent.append((now_ns, data))
        if recent[0][0] < now_ns - RECENT_NS:
            horizon = now_ns - RECENT_NS
            while recent[0][0] < horizon:
                recent.popleft()
        return True

    def subscribed(self, topic: str, data: bytes, received_ns: int) -> bool:
        """Whether to record a message the recorder's subscription received (False: a bundle
        gave it already, or the topic is tapped)."""
        return self._take(topic, data, received_ns, from_bundle=False)

    def receive(self, bundle: Bundle, received_ns: int) -> tuple[bool, list]:
        """Learn ``bundle``'s table and delay; returns (its table changed, the messages to
        record as (topic, log time [ns], CDR bytes))."""
        table = frozenset(name for name, _ in bundle.topics)
        changed = self._tables.get(bundle.node) != table
        self._tables[bundle.node] = table
        delays = self._delays.get(bundle.node)
        if delays is None:
            delays = self._delays[bundle.node] = collections.deque(maxlen=self._offset_window)
        delays.append(received_ns - bundle.sent_ns)
        offset = min(delays)
        out = []
        for index, publish_ns, data in bundle.frames:
            topic = bundle.topics[index][0]
            if self._take(topic, data, received_ns, from_bundle=True):
                out.append((topic, publish_ns + offset, data))
        return changed, out
