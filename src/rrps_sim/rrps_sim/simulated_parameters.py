"""The simulated robot's parameters (:class:`rrps_sim.simulated_robot.SimulatedRobot`), declared
once: the actuators' fidelity and limits, the dynamic mode's force loop, the initial state and the
state file, the faults for tests, the world's attitude of ring_a at the start and the payload. The
driver shows them with ``hardware:=simulated``."""

from __future__ import annotations

from rrps_description.world import IDENTITY_QUATERNION
from rrps_interfaces.driver import ActuatorMode
from rrps_runtime.parameter_schema import PAYLOAD, Parameter

__all__ = ['SIMULATED_ROBOT_PARAMETERS']

SIMULATED_ROBOT_PARAMETERS = (
    Parameter('mode', ActuatorMode.KINEMATIC.value, 'actuator fidelity',
              choices=tuple(m.value for m in ActuatorMode)),
    Parameter('time_constant', 0.02, 'first-order lag of the actuators; 0 = none', unit='s', range=(0.0, 10.0)),
    Parameter('limit_speed', True, "limit the actuators to the robot's max_speed"),
    Parameter('jerk_limited', True, "the legs follow the commands' jerk-limited setpoints (Ruckig, the limits')"),
    Parameter('kp', 1.0e5, 'dynamic mode: PD stiffness per leg', unit='N/m', range=(0.0, 1e8)),
    Parameter('kd', 1.0e3, 'dynamic mode: PD damping per leg', unit='N s/m', range=(0.0, 1e6)),
    Parameter('dynamics_step', 1e-3, 'dynamic mode: largest integration step', unit='s', range=(1e-5, 0.01)),
    Parameter('ring_rotation_speed', 1.0, 'speed of the extra ring DOF (robots that have one)', unit='rad/s',
              range=(1e-3, 100.0)),
    Parameter('initial_lengths', None, 'initial leg lengths (6)', unit='m', type=tuple,
              unset_note='the home pose (or the state file)'),
    Parameter('stuck_legs', None, 'fault: legs (1..6) that ignore commands and keep their length',
              type=tuple, item_type=int, range=(1, 6), dynamic=True, unset_note='none'),
    Parameter('sensor_noise', 0.0, 'fault: std of Gaussian noise on the published lengths', unit='m',
              range=(0.0, 0.1), dynamic=True),
    Parameter('drop_probability', 0.0, 'fault: probability of dropping an actuators/state message',
              range=(0.0, 1.0), dynamic=True),
    Parameter('fault_seed', 0, 'seed of the fault injection', range=(0, 2**31 - 1)),
    Parameter('state_file', '', "file that keeps the robot's physical state across driver restarts "
              '(lengths, ring angles, grippers); empty: none'),
    Parameter('world_q_support', IDENTITY_QUATERNION, "ring_a's attitude in the world at the start "
              '(x, y, z, w): the gravity of efforts and dynamics; handed over at each grip change, then '
              'the odometry/support attitude'),
    *PAYLOAD,
)
