"""A :class:`~rrps_climbing.step_machine.ClimbStepMachine` in a simulated system, without ROS (the
step machine's unit tests): a robot that reaches every target at once (``track`` False stops it), a driver that
switches a gripper at the next tick, an operator station heard every tick, a plan made as soon as the machine
asks for it (as climb_node's worker, without the wait), and a fake clock. The pole climber
on a 3 m pole, ticks of :data:`DT`, steps of :data:`STEP` from :data:`START`."""

from __future__ import annotations

import numpy as np

from rrps_climbing.gait import GaitPlanner
from rrps_climbing.path_brake import brake_time
from rrps_climbing.step_io import GripperRequest, StepConfig
from rrps_climbing.step_machine import ClimbStepMachine
from rrps_climbing.step_plan import plan_step
from rrps_description.geometry import load_robot
from rrps_description.motion_limits import stream_limits
from rrps_description.pose import Pose
from rrps_description.structures import pole
from rrps_interfaces.climb import ClimbState

__all__ = ['POLE', 'PLANNER', 'HOME', 'DT', 'STEP', 'START', 'EXECUTING', 'PAUSED', 'IDLE', 'FAILED',
           'BRAKE', 'ClimbRig', 'assert_brakes', 'in_phase', 'started']

POLE = load_robot('pole_climber')
PLANNER = GaitPlanner(POLE, pole(3.0))
HOME = Pose(POLE.home_position, POLE.home_quaternion_xyzw)
DT = 0.02       # tick period [s]
STEP = 0.06     # [m]
START = 0.2     # ring_a's route position [m]
EXECUTING, PAUSED, IDLE, FAILED = ClimbState.EXECUTING, ClimbState.PAUSED, ClimbState.IDLE, ClimbState.FAILED
BRAKE = brake_time(stream_limits(POLE.motion_limits.legs))   # a paused stream's brake [s]


class ClimbRig:
    """The machine in a simulated system (see the module docstring)."""

    def __init__(self, *, pose: Pose = HOME, step_length: float = STEP, auto_steps: int = 0,
                 preview: bool = False, **config):
        self.t = 100.0
        config = {'period': DT, **config}
        self.machine = ClimbStepMachine(PLANNER, StepConfig(**config), start=START, step_length=step_length,
                                        auto_steps=auto_steps, clock=lambda: self.t, preview=preview)
        self.pose = pose
        self.grippers = {'ring_a': True, 'ring_b': True}
        self.state = self.operator = self.driver_active = self.track = self.switch = True
        self.engaged = False
        self.answer = (True, '')
        self.pending: list[GripperRequest] = []
        self.outputs: list = []     # (t, output) of every call
        self.both_open = False

    def tick(self):
        self.t += DT
        m = self.machine
        for request in self.pending:   # the driver answers last tick's requests and switches
            m.on_gripper_answer(request, *self.answer)
            if self.answer[0] and self.switch:
                self.grippers[request.ring] = request.close
        self.pending = []
        self.both_open |= not any(self.grippers.values())
        if self.state:
            m.pose_received()
            m.on_grippers(self.grippers)
            self.outputs.append((self.t, m.on_pose(self.pose)))
        if self.operator:
            m.on_teleop(self.engaged)
        m.on_driver_active(self.driver_active)
        out = self._planned(m.tick(self.t))
        if out.target is not None and self.track:
            self.pose = out.target.a_T_b
        if out.gripper is not None:
            self.pending.append(out.gripper)
        return out

    def call(self, request, *args):
        return self._planned(request(*args, self.t))

    def _planned(self, out):
        """``out``, or, when it asks for a plan, the machine's output once the plan is made (both kept)."""
        self.outputs.append((self.t, out))
        if out.plan is None:
            return out
        planned = self.machine.on_plan(plan_step(PLANNER, out.plan), self.t)
        self.outputs.append((self.t, planned))
        return planned

    def run_until(self, done, max_ticks: int = 3000) -> list:
        outs = []
        for _ in range(max_ticks):
            outs.append(self.tick())
            if done(self.machine.status()):
                return outs
        raise AssertionError(f'not reached in {max_ticks} ticks: {self.machine.status()}')

    def statuses(self) -> list:
        return [(t, out.status) for t, out in self.outputs if out.status is not None]

    def requests(self) -> list:
        return [(t, out.gripper) for t, out in self.outputs if out.gripper is not None]


def in_phase(name: str):
    """Whether a status shows phase ``name`` executing."""
    return lambda s: s.state is EXECUTING and s.phase == name


def started(rig: ClimbRig, direction: int = +1):
    """One tick, then a step in ``direction`` (+1 up) asked for and started; its output."""
    rig.tick()
    out = rig.call(rig.machine.step, direction)
    assert out.reply[0], out.reply
    return out


def assert_brakes(before: list, outs: list) -> int:
    """The targets of ``outs`` (the ticks after a pause) slow along the path to rest as a brake of
    :data:`BRAKE` does: one per tick, no step longer than two of the stream's steps ``before`` it
    (the tick that saw a pause sends none; 5 % for a path still speeding up), each step shorter than
    the one before once the longest is past, the last almost none, nothing after them; their number."""
    targets = [o.target for o in outs]
    n = next((k for k, t in enumerate(targets) if t is None), len(targets))
    assert 0.5 * BRAKE / DT <= n <= BRAKE / DT + 1 and all(t is None for t in targets[n:]), targets
    last = np.linalg.norm(before[-1].a_T_b.position - before[-2].a_T_b.position)
    positions = [before[-1].a_T_b.position] + [t.a_T_b.position for t in targets[:n]]
    steps = np.linalg.norm(np.diff(positions, axis=0), axis=1)
    slowing = steps[int(np.argmax(steps)):]
    assert 0 < np.max(steps) <= 2.1 * last and np.all(np.diff(slowing) < 0) and steps[-1] < 0.05 * last, steps
    return n
