"""At most one message per ``period`` per topic, the newest one: what a live viewer needs of a
500 Hz stream. A message that comes too soon is held (replacing any held before it) and sent by
:meth:`Throttle.due` once its topic's period has passed, so the last state of a burst is never
lost. Every method takes ``now`` (monotonic seconds). Pure: no rclpy."""

from __future__ import annotations

__all__ = ['Throttle']


class Throttle:
    """Per-topic rate bound (see the module docstring); topics in ``unthrottled`` pass whole."""

    def __init__(self, max_rate: float, unthrottled=()):
        if not max_rate > 0.0:
            raise ValueError(f'max_rate must be > 0, got {max_rate}')
        self.period = 1.0 / max_rate
        self.unthrottled = frozenset(unthrottled)
        self._last: dict[str, float] = {}
        self._held: dict[str, object] = {}
        self.passed = 0
        self.dropped = 0

    def offer(self, topic: str, message, now: float) -> bool:
        """True: send ``message`` now. False: it is held (or replaced a held one)."""
        if topic in self.unthrottled:
            self.passed += 1
            return True
        if now - self._last.get(topic, -float('inf')) >= self.period:
            self._last[topic] = now
            if self._held.pop(topic, None) is not None:
                self.dropped += 1  # a newer one goes instead
            self.passed += 1
            return True
        if topic in self._held:
            self.dropped += 1
        self._held[topic] = message
        return False

    def due(self, now: float) -> list[tuple[str, object]]:
        """The held messages whose topic's period has passed, to send now."""
        out = []
        for topic in [t for t in self._held if now - self._last[t] >= self.period]:
            out.append((topic, self._held.pop(topic)))
            self._last[topic] = now
            self.passed += 1
        return out
