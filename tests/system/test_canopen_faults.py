"""Faults of the CANopen drives, each injected in a simulated drive at a random moment of a
teleoperation session and of a climbing step: every drive holds, driver_node reports which drive
and why (ERROR on /diagnostics, DriverStatus.faults), no gripper output switches, and after the
operator's fault reset and activation the robot works again. Real processes, real CANopen
traffic on a loopback bus of the test's own. ``-s`` prints each episode (the fault table of
docs/connecting-a-robot.md)."""

from __future__ import annotations

import time

import numpy as np
import pytest

from rrps_description.geometry import load_robot
from rrps_interfaces.climb import CLIMB_STEP_UP, ClimbState
from rrps_testing.canopen_stack import (
    STEP_DEADLINE,
    call,
    canopen_stack,
    climb_state,
    engage,
    fault_episode,
    finish_step,
)
from rrps_testing.ros_harness import wait_for

pytestmark = [pytest.mark.slow, pytest.mark.ros, pytest.mark.exclusive]  # the drive simulator and driver at SCHED_RR
POLE = load_robot('pole_climber')
#: The faults of a drive (rrps_canopen_sim) and of the bus, in the order they are injected.
FAULTS = ('current', 'fault_bit', 'blocked', 'silent', 'reboot', 'bus')


def check(episode, max_speed: float) -> None:
    print(f'\n  {episode.kind:>10} {episode.drive}: reported after {episode.report_delay * 1e3:.0f} ms, held '
          f'{episode.time_to_hold * 1e3:.0f} ms after it, moved {episode.motion * 1e3:.2f} mm, '
          f'{episode.gripper_switches} gripper switches, "{episode.report}", recovered: {episode.recovered} '
          f'({episode.reset_message})', flush=True)
    assert np.isfinite(episode.report_delay), episode
    assert episode.gripper_switches == 0, episode
    assert episode.motion <= max_speed * (episode.time_to_hold + 0.02) + 1e-3, episode
    assert episode.recovered, episode


def test_faults_during_teleoperation(ros_context, ros_domain_id):
    rng = np.random.default_rng(20250402)
    with canopen_stack(ros_context, ros_domain_id) as stack:
        master = stack.nodes['master_node']
        from rclpy.parameter import Parameter
        master.set_parameters([Parameter('trajectory', value='circle'), Parameter('amplitude', value=0.004),
                               Parameter('period', value=4.0)])
        for kind in FAULTS:
            engage(stack)
            time.sleep(rng.uniform(0.2, 1.5))
            drive = f'leg_{rng.integers(1, 7)}'
            check(fault_episode(stack, kind, drive), POLE.max_speed)
        engage(stack)


def test_faults_during_climbing(ros_context, ros_domain_id):
    rng = np.random.default_rng(20250403)
    with canopen_stack(ros_context, ros_domain_id) as stack:
        # A following error leaves its leg off the planned path: the paused step cannot resume on
        # it (climb/resume refuses a robot off the paused path), so it comes last.
        for kind in sorted(FAULTS, key=lambda k: k == 'blocked'):
            assert wait_for(lambda: climb_state(stack) and climb_state(stack).state is ClimbState.IDLE)
            assert wait_for(lambda: call(stack, CLIMB_STEP_UP)[0], period=0.5), climb_state(stack)  # a busy machine
            # started once previewed (IDLE until then; over a minute beside --load): running, or
            # already paused by a late state on a busy machine
            assert wait_for(lambda: climb_state(stack).state in (ClimbState.EXECUTING, ClimbState.PAUSED),
                            timeout=STEP_DEADLINE), climb_state(stack)
            time.sleep(rng.uniform(0.3, 4.0))
            drive = f'leg_{rng.integers(1, 7)}'
            check(fault_episode(stack, kind, drive), POLE.max_speed)
            if kind != 'blocked':
                finish_step(stack)

