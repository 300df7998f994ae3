"""Who may drive the robot from a browser: the operator-control state machine (pure, no viser).

Token, one controller, hand-over, loss of control on disconnect, and the deadman (``teleop/enable``): docs/viewer.md,
"Driving the robot from the browser". Thread-safe: viser calls in from its thread pool, the ROS timer reads ``enable``.
"""

from __future__ import annotations

import hmac
import threading
import time
from dataclasses import dataclass
from typing import Callable

__all__ = ['OperatorControl', 'ControlResult']


@dataclass(frozen=True)
class ControlResult:
    """The outcome of an operator request: ``ok`` and a message to show to that operator."""

    ok: bool
    message: str


class OperatorControl:
    """Token check, single controller, hand-over, clutch and deadman for the viewer's clients.

    ``clock`` returns seconds (monotonic); tests pass a fake one. ``max_attempts`` wrong tokens
    from one client lock that client out of further attempts for ``lockout`` s.
    """

    def __init__(self, *, token: str, deadman_timeout: float = 0.25, max_attempts: int = 5,
                 lockout: float = 30.0, clock: Callable[[], float] = time.monotonic):
        if not isinstance(token, str) or len(token) < 4:
            raise ValueError('the operator token must be a string of at least 4 characters')
        if not deadman_timeout > 0.0:
            raise ValueError(f'deadman_timeout must be > 0 s, got {deadman_timeout}')
        self._token = token.encode()
        self._deadman_timeout = deadman_timeout
        self._max_attempts = max_attempts
        self._lockout = lockout
        self._clock = clock
        self._lock = threading.Lock()
        self._clients: set[int] = set()
        self._authenticated: set[int] = set()
        self._failures: dict[int, int] = {}
        self._locked_until: dict[int, float] = {}
        self._controller: int | None = None
        self._clutch_engaged = False
        self._hold_until = -float('inf')
        self._dragging = False
        self.version = 0  # bumped on every change of who controls what (the GUI refreshes)

    # --- clients ---------------------------------------------------------------------------

    def connect(self, client_id: int) -> None:
        """A browser connected: it is read-only."""
        with self._lock:
            self._clients.add(client_id)
            self._changed()

    def disconnect(self, client_id: int) -> bool:
        """A browser left; return True if it held control (now lost: the robot holds)."""
        with self._lock:
            self._clients.discard(client_id)
            self._authenticated.discard(client_id)
            self._failures.pop(client_id, None)
            self._locked_until.pop(client_id, None)
            lost = self._controller == client_id
            if lost:
                self._drop_control()
            self._changed()
            return lost

    def authenticate(self, client_id: int, token: str) -> ControlResult:
        """Check the operator token entered by a client (constant-time comparison)."""
        with self._lock:
            if client_id not in self._clients:
                return ControlResult(False, 'unknown client')
            now = self._clock()
            if self._locked_until.get(client_id, -float('inf')) > now:
                return ControlResult(False, 'too many wrong tokens: try again later')
            if hmac.compare_digest(str(token).strip().encode(), self._token):
                self._authenticated.add(client_id)
                self._failures.pop(client_id, None)
                self._changed()
                return ControlResult(True, 'token accepted')
            failures = self._failures.get(client_id, 0) + 1
            self._failures[client_id] = failures
            if failures >= self._max_attempts:
                self._failures[client_id] = 0
                self._locked_until[client_id] = now + self._lockout
                return ControlResult(False, f'wrong token; locked out for {self._lockout:.0f} s')
            return ControlResult(False, 'wrong token')

    # --- who controls ----------------------------------------------------------------------

    def take_control(self, client_id: int) -> ControlResult:
        """An authenticated client takes control if nobody holds it."""
        with self._lock:
            if client_id not in self._authenticated:
                return ControlResult(False, 'read-only: enter the operator token first')
            if self._controller == client_id:
                return ControlResult(True, 'you already have control')
            if self._controller is not None:
                return ControlResult(False, f'operator {self._controller} has control; '
                                            'ask them to hand it over')
            self._controller = client_id
            self._changed()
            return ControlResult(True, 'you have control')

    def release(self, client_id: int) -> ControlResult:
        """The controller gives control up (the robot holds)."""
        with self._lock:
            if self._controller != client_id:
                return ControlResult(False, 'you do not have control')
            self._drop_control()
            self._changed()
            return ControlResult(True, 'control released')

    def hand_over(self, client_id: int, to_client: int) -> ControlResult:
        """The controller passes control to another authenticated client (clutch released)."""
        with self._lock:
            if self._controller != client_id:
                return ControlResult(False, 'you do not have control')
            if to_client == client_id:
                return ControlResult(False, 'you already have control')
            if to_client not in self._authenticated:
                return ControlResult(False, f'operator {to_client} has not entered the token')
            self._drop_control()
            self._controller = to_client
            self._changed()
            return ControlResult(True, f'control handed over to operator {to_client}')

    # --- clutch and deadman ------------------------------------------------------------------

    def set_clutch(self, client_id: int, engaged: bool) -> ControlResult:
        """Engage (True) or release (False) the clutch; only the controller can."""
        with self._lock:
            if self._controller != client_id:
                return ControlResult(False, 'read-only: you do not have control')
            self._clutch_engaged = bool(engaged)
            if not engaged:
                self._hold_until = -float('inf')
            self._changed()
            return ControlResult(True, 'clutch engaged' if engaged else 'clutch released')

    def release_clutch(self) -> None:
        """Release the clutch and the deadman, whoever controls (the robot driven changed: the
        operator engages again on purpose)."""
        with self._lock:
            self._clutch_engaged = False
            self._hold_until = -float('inf')
            self._dragging = False
            self._changed()

    def hold(self, client_id: int) -> bool:
        """A hold event of the hold-to-move button; refreshes the deadman for the controller."""
        with self._lock:
            if self._controller != client_id:
                return False
            self._hold_until = self._clock() + self._deadman_timeout
            return True

    def set_dragging(self, client_id: int, dragging: bool) -> bool:
        """The controller grabbed (True) or let go of (False) the master's gizmo."""
        with self._lock:
            if self._controller != client_id:
                return False
            self._dragging = bool(dragging)
            return True

    def enable(self) -> bool:
        """The deadman value to publish on ``teleop/enable`` now."""
        with self._lock:
            if self._controller is None or not self._clutch_engaged:
                return False
            return self._dragging or self._clock() < self._hold_until

    # --- queries -----------------------------------------------------------------------------

    @property
    def controller(self) -> int | None:
        with self._lock:
            return self._controller

    @property
    def clutch_engaged(self) -> bool:
        with self._lock:
            return self._clutch_engaged

    def may_control(self, client_id: int) -> bool:
        """True only for the client holding control."""
        with self._lock:
            return self._controller == client_id

    def is_authenticated(self, client_id: int) -> bool:
        with self._lock:
            return client_id in self._authenticated

    def authenticated_clients(self) -> list[int]:
        with self._lock:
            return sorted(self._authenticated)

    def clients(self) -> list[int]:
        with self._lock:
            return sorted(self._clients)

    def role(self, client_id: int) -> str:
        """``'controller'``, ``'operator'`` (token entered, not in control) or ``'viewer'``."""
        with self._lock:
            if self._controller == client_id:
                return 'controller'
            return 'operator' if client_id in self._authenticated else 'viewer'

    # --- internals ---------------------------------------------------------------------------

    def _drop_control(self) -> None:
        self._controller = None
        self._clutch_engaged = False
        self._hold_until = -float('inf')
        self._dragging = False

    def _changed(self) -> None:
        self.version += 1
