"""The scripted operator of ``rrps-demo --headless --scenario frame_node``: one climbing step across a frame's node.

Through :meth:`~rrps_bringup.operator.ScriptedOperator.climb_step` it requests the crossing (previewed, then executed,
pauses resumed) and checks gravity, the preview's force and holding margin, the refusals and where both rings ended
against :meth:`~rrps_bringup.scenarios.Scenario.crossing` (docs/scenarios.md). :meth:`FrameScript.run`: all passed.
"""

from __future__ import annotations

import threading

import numpy as np

from rrps_bringup.operator import WAIT, Check, ScriptedOperator, print_summary
from rrps_bringup.scenarios import Scenario
from rrps_description.geometry import load_robot
from rrps_description.names import RINGS
from rrps_description.rotations import quat_xyzw_to_matrix
from rrps_description.world import STANDARD_GRAVITY
from rrps_interfaces.climb import ClimbState, odometry_topic
from rrps_runtime.messages import pose_from_msg

__all__ = ['FrameScript', 'END_TOLERANCE']

#: The rings' odometry agrees with the plan's end poses within this [m] (the driver's tracking).
END_TOLERANCE = 4e-3


class FrameScript(ScriptedOperator):
    """Plays the operator of a frame-node :class:`~rrps_bringup.scenarios.Scenario` (module
    docstring)."""

    def __init__(self, scenario: Scenario, **kwargs):
        super().__init__('frame_script', **kwargs)
        self.scenario = scenario
        self.geometry = load_robot(scenario.robot)
        self.plan = scenario.crossing().plan_crossing()

    def run(self, stop: threading.Event, *, viewer=None) -> bool:
        """The scripted crossing; prints each step, the result block and the checks."""
        s = self.scenario
        self._say(f'scenario {s.name}: {s.summary}')
        checks = self.wait_until_up(stop)
        up = checks[0][1] and self._wait(
            lambda: all(self._get(odometry_topic(r)) is not None for r in RINGS)
            and self._climb_state() is not None, WAIT, stop)
        checks.append(('odometry and climb status received', up))
        if up:
            gravity = self._gravity(odometry_topic('ring_a'))
            climbed, final = self.climb_step(stop)
            checks += climbed + self._results(stop, final, gravity)
        if viewer is not None:
            drawn = viewer.viewer.frames_drawn
            checks.append((f'viewer drew {drawn} frames at {viewer.url}', drawn > 0))
        self._say('checks:')
        return print_summary(checks)

    def _gravity(self, topic: str) -> np.ndarray:
        """Gravity [g] in a ring's frame from its world attitude on ``topic`` (odometry)."""
        _, q = pose_from_msg(self._get(topic))
        g = np.asarray(STANDARD_GRAVITY)
        return quat_xyzw_to_matrix(q).T @ g / np.linalg.norm(g)

    def _end_errors(self) -> dict[str, float]:
        """Distance [m] of each ring's odometry from the plan's end pose."""
        end = self.plan.phases[-1]
        planned = {'ring_a': end.world_T_a.position, 'ring_b': end.world_T_b.position}
        return {r: float(np.linalg.norm(pose_from_msg(self._get(odometry_topic(r)))[0] - planned[r]))
                for r in RINGS}

    def _results(self, stop: threading.Event, final, gravity: np.ndarray) -> list[Check]:
        s, g, end = self.scenario, self.geometry, self.plan.phases[-1]
        expected = s.gravity_in_g()
        preview = self._climb_preview()
        status = self._climb_state()
        if final is not None:  # the odometry of the last pose (published at the climb node's rate)
            self._wait(lambda: max(self._end_errors().values()) < END_TOLERANCE, WAIT, stop)
        errors = self._end_errors()
        refusals = int(status is not None and status.refusal is not None)
        peak = preview.peak_force if preview is not None else float('nan')
        margin = preview.min_margin if preview is not None else float('nan')
        print('result:', flush=True)
        print(f'  scenario: {s.name} ({s.summary}); {s.motion}', flush=True)
        print('  support ring: ring_a (move_b), ring_b (move_a)', flush=True)
        print("  gravity in the supporting ring's frame: (" + ', '.join(f'{v:.3f}' for v in gravity) + ') g',
              flush=True)
        if preview is not None:
            print(f'  peak actuator force: {peak:.1f} N (leg_{preview.peak_leg}), max {g.max_force:.0f} N',
                  flush=True)
            print(f'  smallest holding margin: {margin:.3f} ({preview.min_margin_ring}); preview '
                  f'{preview.simulated:.1f} s of robot time in {preview.wall:.1f} s', flush=True)
        print(f'  refusals: {refusals}' + (f' ({status.refusal.value})' if refusals else ''), flush=True)
        if status is not None:
            print(f'  rings: s_a {status.s_a:.3f} m, s_b {status.s_b:.3f} m (planned {end.s_a:.3f}, '
                  f'{end.s_b:.3f}); odometry off the plan: ring_a {errors["ring_a"] * 1e3:.1f} mm, '
                  f'ring_b {errors["ring_b"] * 1e3:.1f} mm', flush=True)
        for ring in RINGS:
            print(f'  {ring} end: (' + ', '.join(f'{v:.4f}' for v in pose_from_msg(
                self._get(odometry_topic(ring)))[0]) + ') m', flush=True)
        node = self.scenario.crossing().structure.forbidden[0][1]  # the node's zone ends here
        past = status is not None and min(status.s_a, status.s_b) >= node
        return [
            (f'gravity from odometry/ring_a is the scenario\'s ({", ".join(f"{v:.3f}" for v in expected)}) g',
             bool(np.allclose(gravity, expected, atol=1e-3))),
            ('step accepted by its preview', preview is not None and preview.accepted),
            (f'step ended IDLE with steps_done {status.steps_done if status else None}',
             status is not None and status.state is ClimbState.IDLE and status.steps_done == 1),
            (f'both rings past the node on the second beam (s >= {node:.3f} m) at the plan\'s end poses '
             f'(ring_a {errors["ring_a"] * 1e3:.1f} mm, ring_b {errors["ring_b"] * 1e3:.1f} mm off)',
             past and max(errors.values()) < END_TOLERANCE),
            (f'peak actuator force {peak:.1f} N (preview) within the limit {g.max_force:.0f} N',
             bool(0.0 < peak < g.max_force)),
            (f'smallest holding margin {margin:.3f} > 0', bool(margin > 0.0)),
        ]
