"""One climbing step and teleoperation through the CANopen backend reach the same poses, along the
same path, as through the simulated backend: the same session on each (climb/step_up from the
home pose; then the master's handle 4 mm up with the deadman held), compared. A teleoperated
motion's length depends on when the mapping engaged (a clutch on a busy machine loses the
master's motion meanwhile), so each backend's teleoperated pose is compared with the target
teleop sent it."""

from __future__ import annotations

import time

import numpy as np
import pytest
from geometry_msgs.msg import PoseStamped

from rrps_description.geometry import load_robot
from rrps_interfaces.climb import CLIMB_STEP_UP, ClimbState, ClimbStatus
from rrps_interfaces.kinematics import TARGET_POSE
from rrps_interfaces.teleop import MASTER_FRAME, MASTER_POSE, MASTER_TARGET_POSE, TeleopStatus
from rrps_runtime.messages import pose_from_msg, pose_to_msg
from rrps_runtime.qos import COMMAND_QOS
from rrps_testing.canopen_stack import call, canopen_stack, climb_state, finish_step, teleop_status
from rrps_testing.ros_harness import header_time, wait_for

pytestmark = [pytest.mark.slow, pytest.mark.ros, pytest.mark.exclusive]  # the drive simulator and driver at SCHED_RR
MASTER = load_robot('master_robot')
#: The pole climber's legs' speed limit [m/s].
SPEED = load_robot('pole_climber').motion_limits.legs.speed
HANDLE_STEP = 0.004
#: Handle motions tried when the mapping clutches before the slave moved (see teleoperate).
MOVE_ATTEMPTS = 4


def flat(msg) -> np.ndarray:
    return np.concatenate(pose_from_msg(msg))


def at_rest(stack, n: int = 100) -> np.ndarray:
    """Wait until the last ``n`` poses are one pose (within 1 um); return it (position, quaternion)."""
    def still():
        last = np.array([flat(m) for _, m in stack.poses[-n:]])
        return len(last) == n and np.ptp(last, axis=0).max() < 1e-6
    assert wait_for(still, timeout=120)
    return flat(stack.poses[-1][1])


def climb(stack) -> tuple[np.ndarray, np.ndarray, float]:
    """One climbing step up from the home pose: (the poses along it, the pose after it, the
    longest gap [s] between the measured poses' stamps during it: the driver's longest stall)."""
    assert wait_for(lambda: climb_state(stack) and climb_state(stack).state is ClimbState.IDLE)
    first = len(stack.poses)
    assert wait_for(lambda: call(stack, CLIMB_STEP_UP)[0], period=0.5), call(stack, CLIMB_STEP_UP)  # a busy machine
    finish_step(stack)
    final = at_rest(stack)
    stamps = np.array([header_time(item) for item in stack.poses[first:]])
    return np.array([flat(m) for _, m in stack.poses[first:]]), final, float(np.diff(stamps).max())


def teleoperate(stack) -> tuple[np.ndarray, np.ndarray, str]:
    """The master's handle 4 mm up with the deadman held: (the slave's pose at rest, the last
    target_pose teleop commanded, what happened meanwhile: see :func:`teleop_trace`). A clutch
    before the slave moved 1 mm (the mapping disengaged on a late stream of a busy machine and
    engaged again, from where the handle then was: a CI run's handle had arrived, and the slave
    stayed for 120 s) is what an operator meets too: release the deadman, bring the handle back
    and move it again, :data:`MOVE_ATTEMPTS` times at most."""
    targets = stack.probe.collect(PoseStamped, TARGET_POSE, qos=COMMAND_QOS)
    master = stack.probe.collect(PoseStamped, MASTER_POSE)
    handle = stack.probe.publisher(PoseStamped, MASTER_TARGET_POSE, command=True)
    home, goal = MASTER.home_position, MASTER.home_position + [0.0, 0.0, HANDLE_STEP]
    first_pose, first_status, first_climb = len(stack.poses), len(stack.teleop_status), len(stack.climb_status)

    def put_handle(position) -> bool:
        handle.publish(pose_to_msg(position, MASTER.home_quaternion_xyzw, frame_id=MASTER_FRAME,
                                   stamp=stack.probe.get_clock().now().to_msg()))
        return bool(master) and np.linalg.norm(flat(master[-1])[:3] - position) < 2e-4

    clutches = []
    for _ in range(MOVE_ATTEMPTS):
        moved, clutch = move_handle(stack, lambda: put_handle(goal))
        if moved:
            break
        clutches.append(clutch)
        stack.deadman.clear()
        assert wait_for(lambda: not teleop_status(stack).engaged)
        assert wait_for(lambda: put_handle(home), period=0.02), flat(master[-1])
    assert moved, f'the slave did not follow the handle: {len(clutches)} clutches ({", ".join(clutches)})'
    for _ in range(150):  # the handle stays at its goal while the slave settles
        put_handle(goal)
        time.sleep(0.02)
    pose = at_rest(stack)
    stack.deadman.clear()
    return pose, flat(targets[-1]), teleop_trace(stack, first_pose, first_status, first_climb, targets)


def teleop_trace(stack, first_pose: int, first_status: int, first_climb: int, targets: list) -> str:
    """What teleoperation did, for a failure's message: the slave's highest and final height, the
    last targets' heights (above the pose teleop started from), teleop's codes and climb_node's
    states in turn."""
    z = np.array([m.pose.position.z for _, m in stack.poses[first_pose:]])
    codes = [TeleopStatus.from_key_values(m.values).code.name for _, m in stack.teleop_status[first_status:]]
    states = [ClimbStatus.from_key_values(m.values).state.name for _, m in stack.climb_status[first_climb:]]
    return (f'slave z above start: highest {(z.max() - z[0]) * 1e3:.2f} mm, last {(z[-1] - z[0]) * 1e3:.2f} mm; '
            f'last targets {[round((m.pose.position.z - z[0]) * 1e3, 2) for m in targets[-5:]]} mm; '
            f'teleop {turns(codes)}; climb {turns(states)}')


def turns(seq: list) -> list:
    """``seq`` without repeats in a row."""
    return [x for i, x in enumerate(seq) if i == 0 or seq[i - 1] != x]


def move_handle(stack, hold_handle) -> tuple[bool, str]:
    """Press the deadman and call ``hold_handle()`` (it publishes the handle's goal) until the slave moved
    1 mm up or the mapping clutched: (moved, the code that disengaged it, '' when none)."""
    stack.deadman.set()
    assert wait_for(lambda: teleop_status(stack) is not None and teleop_status(stack).engaged)
    seen, start = len(stack.teleop_status), flat(stack.poses[-1][1])

    def moved() -> bool:
        return flat(stack.poses[-1][1])[2] - start[2] > 1e-3

    def clutched() -> str:
        return next((s.code.name for s in (TeleopStatus.from_key_values(m.values)
                                            for _, m in stack.teleop_status[seen:]) if not s.engaged), '')

    def following() -> bool:
        hold_handle()
        return moved()
    assert wait_for(lambda: following() or clutched(), period=0.02, timeout=120), (
        teleop_status(stack), stack.probe.latest())
    if not moved():   # engaged again after the clutch: whatever follows, follows
        wait_for(following, period=0.02, timeout=2.0)
    return moved(), clutched()


def distance_to_path(points: np.ndarray, path: np.ndarray) -> np.ndarray:
    """Each point's distance [m] to the polyline ``path`` (positions only)."""
    a, b = path[:-1, :3], path[1:, :3]
    ab = b - a
    t = np.clip(np.einsum('sk,psk->ps', ab, points[:, None, :3] - a) / np.maximum(np.einsum('sk,sk->s', ab, ab),
                                                                                 1e-18), 0.0, 1.0)
    nearest = a + t[..., None] * ab
    return np.linalg.norm(points[:, None, :3] - nearest, axis=2).min(axis=1)


def test_a_climbing_step_and_teleop_reach_the_same_poses_on_both_backends(ros_context, ros_domain_id):
    results = {}
    for hardware in ('simulated', 'canopen'):
        with canopen_stack(ros_context, ros_domain_id, hardware=hardware) as stack:
            path, end, stall = climb(stack)
            pose, commanded, trace = teleoperate(stack)
            results[hardware] = (path, end, pose, commanded, stall, trace)
    path_sim, end_sim, _, _, stall_sim, _ = results['simulated']
    path_can, end_can, _, _, stall_can, _ = results['canopen']
    assert np.abs(end_sim[:3] - end_can[:3]).max() < 5e-4, (end_sim, end_can)
    assert np.abs(np.abs(end_sim[3:] @ end_can[3:]) - 1.0) < 1e-6, (end_sim, end_can)
    assert np.ptp(path_can[:, 2]) > 0.01  # it climbed
    # The same path within 1 mm, and what a stall of the driver's loop adds: a starved process on a
    # busy machine holds the legs' targets, then they jump by up to the legs' speed times the stall
    # and each leg's actuator catches up on its own, within its speed limit, off the path (a CI run
    # measured 1.1 mm, a loaded one 3.1 mm on the simulated backend).
    allowed = 1e-3 + SPEED * max(stall_sim, stall_can)
    apart = distance_to_path(path_can[::10], path_sim).max(), distance_to_path(path_sim[::10], path_can).max()
    print(f'paths apart {apart[0] * 1e3:.3f} / {apart[1] * 1e3:.3f} mm; longest driver stall {stall_sim * 1e3:.0f} ms '
          f'(simulated), {stall_can * 1e3:.0f} ms (canopen); allowed {allowed * 1e3:.2f} mm')
    assert max(apart) < allowed, (apart, stall_sim, stall_can)
    for hardware, (_, end, pose, commanded, _, trace) in results.items():  # teleop: each reached what it was sent
        assert pose[2] - end[2] > 1e-3, (hardware, trace)
        assert np.abs(pose[:3] - commanded[:3]).max() < 2e-4, (hardware, pose, commanded, trace)
