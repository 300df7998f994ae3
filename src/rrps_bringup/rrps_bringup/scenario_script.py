"""The scripted operator of ``rrps-demo --headless --scenario NAME``: a load scenario over ROS.

It opens ring_b's gripper, teleoperates ring_b along the scenario's motion, closes it, climbs one step up
(:mod:`rrps_bringup.step_report`) and prints a result block of checks: support and gravity, peak and resting
efforts against the statics (:func:`rrps_loads.loads.static_solution`; not on ``canopen``, whose axes carry no load),
holding margin, refusals, and the step's timing and loads (docs/scenarios.md). :meth:`ScenarioScript.run`: all passed.
"""

from __future__ import annotations

import threading
import time

import numpy as np
from geometry_msgs.msg import PoseStamped
from sensor_msgs.msg import JointState
from std_srvs.srv import SetBool

from rrps_bringup.operator import WAIT, Check, ScriptedOperator, print_summary
from rrps_bringup.scenarios import Scenario
from rrps_bringup.step_report import StepReport
from rrps_description.geometry import load_robot
from rrps_description.loads import Payload
from rrps_description.names import LEG_NAMES, RINGS
from rrps_description.rotations import quat_xyzw_to_matrix
from rrps_description.world import STANDARD_GRAVITY
from rrps_interfaces.climb import odometry_topic
from rrps_interfaces.driver import GRIPPERS_STATE, gripper_service, gripper_states
from rrps_interfaces.kinematics import ACTUATORS_STATE, POSE
from rrps_interfaces.teleop import TeleopCode, TeleopStatus
from rrps_loads.loads import static_solution
from rrps_runtime.messages import pose_from_msg
from rrps_runtime.qos import STATE_QOS

__all__ = ['ScenarioScript', 'HALTING_CODES']

#: Teleop codes that refuse the operator's motion (the slave stops short of it).
HALTING_CODES = frozenset(code for code in TeleopCode
                          if code.name.startswith('HALT') or code in (TeleopCode.INVALID, TeleopCode.JOINT_BOUND))
#: Codes of an engaged mapping following the master unhindered.
_NOMINAL = frozenset({TeleopCode.NO_WARNING})
#: The received poses kept for the holding margin: at most one per this many seconds.
POSE_SAMPLE_PERIOD = 0.05
#: The driver's efforts at rest agree with the statics of the held pose within this [N].
EFFORT_TOLERANCE = 0.5


class ScenarioScript(ScriptedOperator):
    """Plays the operator of one :class:`~rrps_bringup.scenarios.Scenario` (module docstring)."""

    def __init__(self, scenario: Scenario, *, hardware: str = 'simulated', **kwargs):
        super().__init__('scenario_script', **kwargs)
        self.scenario = scenario
        self.hardware = hardware   # the driver's: 'simulated' models the loads, 'canopen' drives do not
        self.step: StepReport | None = None
        self.geometry = load_robot(scenario.robot)
        self.payload = (Payload(ring=scenario.payload_ring, mass=scenario.payload_mass,
                                com=np.asarray(scenario.payload_com, dtype=float))
                        if scenario.payload_mass > 0.0 else self.geometry.payload)
        self._peak = (0.0, '')  # the largest |effort| [N] received, and its leg
        self._efforts: np.ndarray | None = None
        self._poses: list[tuple[np.ndarray, np.ndarray]] = []
        self._pose_time = -np.inf
        self._halts: dict[str, int] = {}
        self._warnings: set[str] = set()
        self.create_subscription(JointState, ACTUATORS_STATE, self._on_state, STATE_QOS)
        self.create_subscription(JointState, GRIPPERS_STATE, lambda m: self._store(GRIPPERS_STATE, m), STATE_QOS)
        self.create_subscription(PoseStamped, POSE, self._on_pose, STATE_QOS)
        self._grippers = {ring: self.create_client(SetBool, gripper_service(ring)) for ring in RINGS}

    # --- what the robot says --------------------------------------------------------------

    def _on_state(self, msg: JointState) -> None:
        efforts = dict(zip(msg.name, msg.effort))
        if not all(leg in efforts for leg in LEG_NAMES):
            return
        f = np.array([efforts[leg] for leg in LEG_NAMES], dtype=float)
        i = int(np.argmax(np.abs(f)))
        with self._lock:
            self._efforts = f
            if abs(f[i]) > self._peak[0]:
                self._peak = (float(abs(f[i])), LEG_NAMES[i])

    def _on_pose(self, msg: PoseStamped) -> None:
        now = time.monotonic()
        with self._lock:
            if now - self._pose_time >= POSE_SAMPLE_PERIOD:
                self._pose_time = now
                self._poses.append(pose_from_msg(msg))

    def _on_teleop_status(self, status: TeleopStatus) -> None:
        if not status.engaged:
            return
        if status.code in HALTING_CODES:
            self._halts[status.code.name] = self._halts.get(status.code.name, 0) + 1
        elif status.code not in _NOMINAL:
            self._warnings.add(status.code.name)

    def _closed(self) -> dict[str, bool] | None:
        msg = self._get(GRIPPERS_STATE)
        return None if msg is None else gripper_states(msg.name, msg.position)

    # --- the session ------------------------------------------------------------------------

    def run(self, stop: threading.Event, *, viewer=None) -> bool:
        """The scripted scenario; prints each step, the result block and the checks."""
        s = self.scenario
        self._say(f'scenario {s.name}: {s.summary}')
        checks = self.wait_until_up(stop)
        up = checks[0][1] and self._wait(
            lambda: all(self._get(t) is not None for t in (odometry_topic('ring_a'), GRIPPERS_STATE))
            and self._efforts is not None and self._climb_state() is not None, WAIT, stop)
        checks.append(('odometry, grippers, actuator states and climb status received', up))
        if up:
            opened = self._set_gripper('ring_b', False, stop)
            checks.append(("ring_b's gripper opened: ring_a alone holds the robot", opened))
            support = self._support_ring()
            if opened:
                checks += self.teleop_session(stop, s.handle_step, s.motion)
            checks += self._results(stop, support)
            if opened:
                checks.append(("ring_b's gripper closed again", self._set_gripper('ring_b', True, stop)))
            checks += self._climb(stop)
        if viewer is not None:
            drawn = viewer.viewer.frames_drawn
            checks.append((f'viewer drew {drawn} frames at {viewer.url}', drawn > 0))
        self._say('checks:')
        return print_summary(checks)

    def _climb(self, stop: threading.Event) -> list[Check]:
        """One climbing step up; the driver's peak force while it executes (:attr:`step`)."""
        before = self._climb_state()
        with self._lock:
            self._peak = (0.0, '')
            self.climb_clock.reset()
        checks, final = self.climb_step(stop)
        with self._lock:
            peak = self._peak[0]
            executed, paused = self.climb_clock.executing, self.climb_clock.paused
        if final is not None:
            self.step = StepReport(status=final, preview=self._climb_preview(), climbed=final.s_a - before.s_a,
                                   executed=executed, paused=paused, max_force=float(self.geometry.max_force),
                                   measured_peak=peak if self.hardware == 'simulated' else None,
                                   hardware=self.hardware)
            for line in self.step.lines():
                print(f'  {line}', flush=True)
            checks += self.step.checks()
        return checks

    def _set_gripper(self, ring: str, close: bool, stop: threading.Event) -> bool:
        client = self._grippers[ring]
        if not client.wait_for_service(timeout_sec=WAIT):
            return False
        future = client.call_async(SetBool.Request(data=close))
        answered = self._wait(future.done, WAIT, stop)
        response = future.result() if answered else None
        self._say(f'{ring} gripper {"close" if close else "open"} -> '
                  f'{response.message if response is not None else "no answer"!r}')
        if response is None or not response.success:
            with self._lock:
                self._halts['gripper refused'] = self._halts.get('gripper refused', 0) + 1
            return False
        return self._wait(lambda: (self._closed() or {}).get(ring) is close, WAIT, stop)

    def _support_ring(self) -> str:
        closed = self._closed() or {}
        return 'ring_b' if closed.get('ring_b') and not closed.get('ring_a') else 'ring_a'

    def _gravity_received(self) -> np.ndarray:
        """Gravity [g] in ring_a's frame from its world attitude on odometry/ring_a."""
        _, q = pose_from_msg(self._get(odometry_topic('ring_a')))
        g = np.asarray(STANDARD_GRAVITY)
        return quat_xyzw_to_matrix(q).T @ g / np.linalg.norm(g)

    def _results(self, stop: threading.Event, support_ring: str) -> list[Check]:
        s, g = self.scenario, self.geometry
        support = s.support()
        gravity = self._gravity_received()
        expected = s.gravity_in_g()

        def solve(poses):
            return static_solution(g, (np.array([p for p, _ in poses]), np.array([q for _, q in poses])),
                                   support=support, payload=self.payload)

        # the driver at rest: its efforts against the statics of the held pose (refreshed in 0.2 s)
        def at_rest() -> float:
            pose = pose_from_msg(self._get(POSE))
            with self._lock:
                efforts = self._efforts
            return float(np.max(np.abs(efforts - solve([pose]).actuator_forces[0])))
        loaded = self.hardware == 'simulated'   # the canopen drives' axes carry no load
        if loaded:
            self._wait(lambda: at_rest() < EFFORT_TOLERANCE, WAIT, stop)
        rest_error = at_rest()
        with self._lock:
            peak, leg = self._peak
            poses = list(self._poses)
            halts, warnings = dict(self._halts), sorted(self._warnings)
        margins = solve(poses).holding_margin
        margin = float(np.nanmin(margins)) if np.any(np.isfinite(margins)) else float('nan')
        refusals = sum(halts.values())
        print('result:', flush=True)
        print(f'  scenario: {s.name} ({s.summary}); {s.motion}', flush=True)
        print(f'  support ring: {support_ring}', flush=True)
        print("  gravity in the supporting ring's frame: (" + ', '.join(f'{v:.3f}' for v in gravity) + ') g',
              flush=True)
        print(f'  peak actuator force: {peak:.1f} N ({leg}), max {g.max_force:.0f} N'
              + ('' if loaded else f' (the {self.hardware} drives: no load on their axes)'), flush=True)
        print(f'  smallest holding margin: {margin:.3f} ({support_ring}, {len(poses)} poses)', flush=True)
        print(f'  refusals: {refusals}' + (f' ({", ".join(f"{k} x{n}" for k, n in halts.items())})' if halts else '')
              + f'; teleop warnings: {", ".join(warnings) or "none"}', flush=True)
        return [
            (f'support ring {support_ring} (ring_a expected)', support_ring == 'ring_a'),
            (f'gravity from odometry/ring_a is the scenario\'s ({", ".join(f"{v:.3f}" for v in expected)}) g',
             bool(np.allclose(gravity, expected, atol=1e-3))),
            *([(f'peak actuator force {peak:.1f} N within the limit {g.max_force:.0f} N', 0.0 < peak < g.max_force),
               (f"the driver's efforts at rest match the statics in the scenario's world "
                f'(max difference {rest_error:.3f} N)', rest_error < EFFORT_TOLERANCE)] if loaded else []),
            (f'smallest holding margin {margin:.3f} > 0', bool(margin > 0.0)),
            (f'no refusals ({refusals})', refusals == 0),
        ]
