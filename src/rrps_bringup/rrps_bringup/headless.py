"""The scripted operator of ``rrps-demo --headless``: a teleop session and a climb, no browser, on the same topics and
services as a person at the viewer (:class:`rrps_bringup.operator.ScriptedOperator`'s teleop session, then one
climbing step), checking the robot's answer."""

from __future__ import annotations

import threading

from rrps_bringup.operator import WAIT, ScriptedOperator, print_summary
from rrps_interfaces.climb import odometry_topic

#: Master handle displacement of the scripted session [m] (the slave moves translation_scale x).
HANDLE_STEP = 0.004


class DemoScript(ScriptedOperator):
    """Plays the operator; :meth:`run` returns True when every check passed."""

    def __init__(self, **kwargs):
        super().__init__('demo_script', **kwargs)

    def run(self, stop: threading.Event, *, viewer=None) -> bool:
        """The scripted session; prints each step and returns overall success."""
        checks = self.wait_until_up(stop)
        if checks[0][1]:
            checks += self.teleop_session(stop, (0.0, 0.0, HANDLE_STEP), 'up')
        if not stop.is_set():
            checks += self._climb(stop)
        if viewer is not None:
            drawn = viewer.viewer.frames_drawn
            checks.append((f'viewer drew {drawn} frames at {viewer.url}', drawn > 0))
        self._say('summary:')
        return print_summary(checks)

    def _climb(self, stop: threading.Event) -> list[tuple[str, bool]]:
        rings = ('ring_a', 'ring_b')

        def missing() -> list[str]:
            return [ring for ring in rings if self._position(odometry_topic(ring)) is None]

        # the first samples may come after the teleop session (discovery on a busy machine)
        self._wait(lambda: not missing(), WAIT, stop)
        before = {ring: self._position(odometry_topic(ring)) for ring in rings}
        checks, final = self.climb_step(stop)
        if final is None:
            return checks
        after = {ring: self._position(odometry_topic(ring)) for ring in rings}
        if not missing() and all(p is not None for p in before.values()):
            rise = {ring: float(after[ring][2] - before[ring][2]) for ring in rings}
            checks.append((f'both rings climbed: ring_a {rise["ring_a"] * 1e3:+.0f} mm, ring_b '
                           f'{rise["ring_b"] * 1e3:+.0f} mm (world odometry)',
                           min(rise.values()) > 0.01))
        else:
            late = [ring for ring in rings if before[ring] is None]
            checks.append((f'world odometry of both rings received (missing {WAIT:.0f} s before the step: '
                           f'{late}, after it: {missing()})', False))
        return checks
