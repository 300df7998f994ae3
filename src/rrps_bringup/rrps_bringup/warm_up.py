"""Compile the numba kernels once, at install (``./rrps install`` runs ``python -m rrps_bringup.warm_up``).

Runs each kernel group once with the stack's argument types (IK, FK, workspace, limits, assembly modes, teleop guards,
statics, a short preview, climb_node's worker), so that no running node waits for numba (numba compiles a kernel anew
for read-only arrays, a Pose's, and for writable ones: both are loaded); they are cached on disk
(:func:`rrps_kinematics.backend.jit`). Nothing is compiled when numba is off (``RRPS_NUMBA=0``) or missing.
"""

from __future__ import annotations

import contextlib
import multiprocessing
import pickle
import sys
import time

import numpy as np

from rrps_description.geometry import load_robot
from rrps_description.pose import Pose
from rrps_kinematics.backend import numba_enabled

__all__ = ['warm_up', 'main']

#: The robot whose calls compile the kernels (every robot has the same argument types).
ROBOT = 'pole_climber'


def warm_up(robot: str = ROBOT) -> float:
    """Run every compiled kernel once; returns the seconds it took (0 when numba is off). The
    dynamics' and the guards' kernels compile in a second process meanwhile (both cores)."""
    if not numba_enabled():
        return 0.0
    start = time.perf_counter()
    other = multiprocessing.get_context('spawn').Process(target=_dynamics_kernels, args=(robot,),
                                                         name='rrps-warm-up')
    other.start()
    try:
        _kinematics_kernels(robot)
    finally:
        other.join()
    if other.exitcode != 0:
        raise RuntimeError(f'the warm-up of the dynamics kernels failed (exit code {other.exitcode})')
    return time.perf_counter() - start


@contextlib.contextmanager
def _say(what: str):
    """Print when the kernels of ``what`` are compiled (or loaded from the cache), with the time."""
    start = time.perf_counter()
    yield
    print(f'rrps:   numba: {what}: ready in {time.perf_counter() - start:.0f} s', file=sys.stderr, flush=True)


def _kinematics_kernels(robot: str) -> None:
    """IK, FK (single; batches serial and parallel), the workspace, the limits, assembly modes."""
    from rrps_kinematics import assembly_modes, forward_kinematics, inverse_kinematics, leg_lengths, margins
    from rrps_kinematics.backend import PARALLEL_BATCH
    from rrps_kinematics.limits import pose_margins
    from rrps_kinematics.workspace import reachable_workspace

    g = load_robot(robot)
    p, q = np.array(g.home_position, dtype=float), np.array(g.home_quaternion_xyzw, dtype=float)
    with _say('IK and FK, single and batches'):
        forward_kinematics(g, g.home_lengths)
        for n in (2, PARALLEL_BATCH):         # the serial and the parallel batch kernels
            forward_kinematics(g, np.tile(g.home_lengths, (n, 1)))
            leg_lengths(g, np.tile(p, (n, 1)), np.tile(q, (n, 1)))
    with _say('the reachable workspace'):
        stroke = g.max_length - g.min_length
        for resolution in (stroke, stroke / 10):
            reachable_workspace(g, resolution=resolution)
    with _say('the assembly modes (homotopy)'):
        assembly_modes(g, g.home_lengths)     # the homotopy kernels and the batch FK that polishes
    with _say("the limits of a pose and of a batch"):
        pose_margins(g, p, q)
        home = Pose(p, q)     # read-only arrays, as the nodes pass them
        pose_margins(g, home.position, home.quaternion_xyzw)
        margins(g, inverse_kinematics(g, p, q))


def _dynamics_kernels(robot: str) -> None:
    """The teleop guards, the statics, a short preview on either ring."""
    from rrps_loads.loads import static_solution
    from rrps_sim.preview import PreviewMotion, preview_step
    from rrps_teleop.guards import pose_step
    from rrps_teleop.mapping import TeleopMapping

    g = load_robot(robot)
    p, q = np.array(g.home_position, dtype=float), np.array(g.home_quaternion_xyzw, dtype=float)
    home = Pose(p, q)
    with _say('the teleop guards'):
        TeleopMapping(g)                  # compiles the guards' kernels on construction
        pose_step(home.position, home.quaternion_xyzw, p, q, 0.5)   # from read-only (a Pose's) arrays too
        pose_step(home.position, home.quaternion_xyzw, home.position, home.quaternion_xyzw, 0.5)
    with _say("a climbing step's preview (the dynamics, on either ring)"):
        path = p + np.outer(np.linspace(0.0, 0.002, 3), [0.0, 0.0, 1.0])
        motions = [PreviewMotion(f'warm-up on {ring}', ring, np.array([0.0, 0.0, 0.0, 1.0]), path,
                                 np.tile(q, (3, 1)), 0.01) for ring in ('ring_a', 'ring_b')]
        preview_step(g, motions, settle=0.0)
    with _say("a climbing step's plan and preview as climb_node's worker makes them"):
        _climb_worker_kernels(robot)
    with _say('the statics'):
        static_solution(g, (p[None], q[None]))
        static_solution(g, home, support='ring_a', world_q_support=q, gravity=(0.0, 0.0, -9.81))


def _climb_worker_kernels(robot: str) -> None:
    """What climb_node's step worker loads when it starts, with the node's default parameters and its
    argument types (without this its start compiled for a minute after an install)."""
    from rrps_climbing.climb_planner import climb_planner, preview_config, step_machine
    from rrps_climbing.nodes.climb_node import PARAMETERS
    from rrps_climbing.step_worker import load_kernels

    values = {**PARAMETERS.defaults(), 'robot': robot}
    g = load_robot(robot)
    planner = climb_planner(g, values)
    machine = step_machine(planner, values)
    # as the worker gets them: pickled (NumPy arrays come out writable; numba compiles read-only and
    # writable arrays apart)
    load_kernels(*pickle.loads(pickle.dumps((planner, machine.plan_request(machine.step_length, 1), g,
                                             preview_config(values)))))


def main() -> None:
    seconds = warm_up()
    if seconds:
        print(f'rrps: numba kernels compiled (or loaded from the cache) in {seconds:.1f} s', file=sys.stderr)
    else:
        print('rrps: numba is off: no kernels to compile', file=sys.stderr)


if __name__ == '__main__':
    main()
