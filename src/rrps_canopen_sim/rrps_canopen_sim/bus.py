"""The simulated devices of one CAN bus and the physics behind them, stepped on each SYNC.

:class:`SimulatedBus` puts a :class:`~rrps_canopen_sim.drive.SimulatedDrive` per leg (and the
grippers' CiA 401 module) on the robot YAML's bus. Legs in position mode move as ``rrps_sim``'s
kinematic actuators; a master's legs in torque mode are masses held by the operator's hand
(:class:`HandModel`). :meth:`SimulatedBus.control` takes a test's requests. Pure Python.
"""

from __future__ import annotations

import math
import threading
import time
from collections import deque

import can
import numpy as np

from rrps_canopen.drive_set import CAN_ERR_BUSOFF
from rrps_canopen.network import open_network, resolve_eds
from rrps_canopen_sim.behaviour import behaviours
from rrps_canopen_sim.drive import SimulatedDrive
from rrps_canopen_sim.heartbeat import HeartbeatProducer
from rrps_canopen_sim.io import Clamp, SimulatedIoModule
from rrps_description.geometry import RobotGeometry
from rrps_description.names import RINGS
from rrps_sim.kinematic_actuators import KinematicActuators

__all__ = ['SimulatedBus', 'HandModel', 'FAULTS']

#: The faults a drive takes (SimulatedDrive.inject), and those of its link.
FAULTS = ('current', 'fault_bit', 'following_error', 'blocked', 'silent', 'reboot')
#: Longest physics step [s] (a SYNC that comes late is integrated in steps of this).
MAX_STEP = 0.01


class HandModel:
    """A master's legs: each a ``mass`` [kg] held by the operator's hand, a spring ``stiffness``
    [N/m] and ``damping`` [N s/m] to ``hand`` [m], within the stroke (inelastic ends)."""

    def __init__(self, lengths, stroke: tuple[float, float], *, mass: float = 0.3, stiffness: float = 300.0,
                 damping: float = 4.0):
        self.x = np.array(lengths, dtype=float)
        self.v = np.zeros_like(self.x)
        self.hand = self.x.copy()
        self.stroke, self.mass, self.stiffness, self.damping = stroke, mass, stiffness, damping
        self.work = np.zeros_like(self.x)  # [J] done on each leg by its drive

    def step(self, force: np.ndarray, dt: float) -> None:
        """Semi-implicit Euler in steps of at most 0.5 ms; ``force`` [N] from the drives."""
        n = max(1, math.ceil(dt / 5e-4))
        h = dt / n
        for _ in range(n):
            a = (force + self.stiffness * (self.hand - self.x) - self.damping * self.v) / self.mass
            v = self.v + h * a
            x = np.clip(self.x + h * v, *self.stroke)
            v = np.where(x != self.x + h * v, 0.0, v)
            self.work += force * (x - self.x)
            self.x, self.v = x, v


class SimulatedBus:
    """Every simulated device of ``geometry``'s bus (see the module docstring)."""

    def __init__(self, geometry: RobotGeometry, *, lengths=None, master: bool = False, time_constant: float = 0.02,
                 behaviour: dict | None = None):
        bus = geometry.bus
        if bus is None:
            raise ValueError(f'robot {geometry.name!r} has no bus section')
        self.geometry, self.config, self.master = geometry, bus, master
        x0 = np.array(geometry.home_lengths if lengths is None else lengths, dtype=float)
        stroke = (geometry.min_length, geometry.max_length)
        self.lock = threading.Lock()
        self.network = open_network(bus)
        self.heartbeats = HeartbeatProducer(self.network)
        kinds = behaviours(behaviour, [d.actuator for d in bus.drives])
        self.drives = [SimulatedDrive(self.network, d, resolve_eds(d.eds, bus.base_dir), stroke, float(x),
                                      kinds[d.actuator], self.lock) for d, x in zip(bus.drives, x0)]
        self.legs = KinematicActuators(*stroke, geometry.max_speed, time_constant, x0)
        self.hand = HandModel(x0, stroke) if master else None
        io = bus.grippers
        self.clamps = {ring: Clamp(True, geometry.motion_limits.grippers[ring]) for ring in RINGS}
        self.module = (SimulatedIoModule(self.network, io.node_id, resolve_eds(io.eds, bus.base_dir))
                       if io is not None and io.io == 'cia401' else None)
        self.down = False
        self.syncs: deque[float] = deque(maxlen=200_000)  # monotonic time of each SYNC received
        self.trace: list[tuple] = []        # (time, targets [m], positions [m], forces [N], speeds [m/s])
        self.tracing = False
        self._last: float | None = None
        self.network.subscribe(0x80, self._on_sync)

    def close(self) -> None:
        for d in self.drives:
            d.node.nmt.stop_heartbeat()
        if self.module is not None:
            self.module.node.nmt.stop_heartbeat()
        self.heartbeats.close()
        self.network.disconnect()

    # --- one SYNC ---

    def _on_sync(self, can_id: int, data: bytes, timestamp: float) -> None:
        now = time.monotonic()
        with self.lock:
            if self.down:
                return
            self.syncs.append(now)
            self.heartbeats.send_due(now)  # a late heartbeat before any PDO, as a drive's own MCU sends it
            dt = 0.0 if self._last is None else min(now - self._last, MAX_STEP * 10)
            self._last = now
            devices = [*self.drives, *([self.module] if self.module else [])]
            for device in devices:
                device.take_rpdos()
            self._step(dt, now)
            self._grippers(dt)
            for device in devices:
                device.send_tpdos()

    def _step(self, dt: float, now: float) -> None:
        if self.hand is not None:
            force = np.array([d.force() for d in self.drives])
            self.hand.step(force, dt)
            for d, x, v, f in zip(self.drives, self.hand.x, self.hand.v, force):
                d.sense(float(x), float(v), float(f), now)
            if self.tracing:
                self.trace.append((now, self.hand.hand.tolist(), self.hand.x.tolist(), force.tolist(),
                                   self.hand.v.tolist()))
            return
        legs = self.legs
        reference = np.array([d.reference() for d in self.drives])
        speed = np.where([d.homing for d in self.drives], [d.homing_speed() for d in self.drives],
                         self.geometry.max_speed)
        legs.max_speed = np.minimum(speed, self.geometry.max_speed)
        for i, d in enumerate(self.drives):
            if d.blocked and not legs.stuck[i]:  # an obstacle pushes the leg back and holds it
                legs.positions[i] = max(self.geometry.min_length, legs.positions[i] - 2.0 * d.following_window())
                legs.stuck[i] = True
            elif legs.stuck[i] and not d.machine.enabled:
                d.blocked, legs.stuck[i] = False, False
        legs.step(reference, dt)
        for d, x, v in zip(self.drives, legs.positions, legs.velocities):
            d.sense(float(x), float(v), 0.0, now)
        if self.tracing:
            self.trace.append((now, reference.tolist(), legs.positions.tolist(), [0.0] * 6, legs.velocities.tolist()))

    def _grippers(self, dt: float) -> None:
        io = self.config.grippers
        if io is None:
            return
        drives = {d.config.actuator: d for d in self.drives}
        for ring, channel in io.rings.items():
            device = self.module if io.io == 'cia401' else drives[channel.drive]
            outputs = device.outputs if io.io == 'cia401' else device.digital_outputs
            clamp = self.clamps[ring]
            clamp.step(bool(outputs >> channel.output & 1), dt)
            bit = 1 << channel.sensor
            field = 'inputs' if io.io == 'cia401' else 'digital_inputs'
            word = getattr(device, field)
            setattr(device, field, (word | bit) if clamp.sensor() else (word & ~bit))

    # --- a test's requests ---

    def _drive(self, name: str) -> SimulatedDrive:
        for d in self.drives:
            if d.config.actuator == name:
                return d
        raise ValueError(f'no drive {name!r}')

    def control(self, request: dict) -> dict:
        """One request: ``{'cmd': 'status'}``, ``{'cmd': 'fault', 'drive': 'leg_3', 'kind': k}``
        (k one of :data:`FAULTS`), ``{'cmd': 'restore', 'drive': ...}`` (a silent drive answers
        again), ``{'cmd': 'bus', 'up': bool}``, ``{'cmd': 'bus_off'}`` (the error frame a CAN
        controller reports its bus-off with), ``{'cmd': 'sensor', 'ring': r, 'stuck': bool|None}``,
        ``{'cmd': 'hand', 'lengths': [...]}``, ``{'cmd': 'trace', 'on': bool}``, ``{'cmd': 'syncs'}``."""
        cmd = request.get('cmd')
        with self.lock:
            if cmd == 'status':
                return self._status()
            if cmd == 'fault':
                return self._fault(self._drive(request['drive']), request['kind'])
            if cmd == 'restore':
                self._drive(request['drive']).set_silent(False)
                return {'ok': True}
            if cmd == 'bus':
                return self._bus(bool(request['up']))
            if cmd == 'bus_off':
                self.network.bus.send(can.Message(arbitration_id=CAN_ERR_BUSOFF, is_error_frame=True,
                                                  is_extended_id=False, dlc=8, data=bytes(8)))
                return {'ok': True, 'time': time.monotonic()}
            if cmd == 'sensor':
                self.clamps[request['ring']].stuck_sensor = request.get('stuck')
                return {'ok': True, 'time': time.monotonic()}
            if cmd == 'hand':
                self.hand.hand = np.array(request['lengths'], dtype=float)
                return {'ok': True}
            if cmd == 'trace':
                trace, self.trace, self.tracing = self.trace, [], bool(request['on'])
                return {'ok': True, 'trace': trace}
            if cmd == 'syncs':
                syncs = list(self.syncs)
                self.syncs.clear()
                return {'ok': True, 'syncs': syncs}
        raise ValueError(f'unknown request {request!r}')

    def _fault(self, drive: SimulatedDrive, kind: str) -> dict:
        if kind == 'silent':
            drive.set_silent(True)
        elif kind == 'reboot':
            drive.hold_at = drive.x
            drive.reboot()
        elif kind in FAULTS:
            drive.inject(kind)
        else:
            raise ValueError(f'unknown fault {kind!r}; known: {", ".join(FAULTS)}')
        return {'ok': True, 'time': time.monotonic()}

    def _bus(self, up: bool) -> dict:
        """The bus is cut (every device falls silent, as seen from the master) or back."""
        devices = [*self.drives, *([self.module] if self.module else [])]
        self.down = not up
        for device in devices:
            device.set_silent(not up)
        self._last = None
        return {'ok': True, 'time': time.monotonic()}

    def _status(self) -> dict:
        drives = {d.config.actuator: {
            'state': d.machine.state.value, 'nmt': d.node.nmt.state, 'operational': d.operational,
            'homed': d.homed, 'mode': int(d.mode_display), 'position': d.x, 'target': d.length(d.target),
            'counts': d.counts(), 'error_code': d.error_code, 'silent': d.silent, 'pdos': d.pdo_states(),
            'homing': None if d.run is None else d.run.phase.value} for d in self.drives}
        status = {'ok': True, 'drives': drives, 'grippers': {r: c.closed for r, c in self.clamps.items()},
                  'syncs': len(self.syncs)}
        if self.hand is not None:
            status['work'] = self.hand.work.tolist()
        if self.module is not None:
            status['io'] = {'nmt': self.module.node.nmt.state, 'outputs': self.module.outputs,
                            'inputs': self.module.inputs}
        return status
