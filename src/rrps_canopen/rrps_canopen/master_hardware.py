"""A master robot's drives on CANopen: master_node's ``hardware: canopen``.

:class:`CanopenMaster` reads the six leg encoders (drives in cyclic synchronous torque mode) and
renders the forces master_node asks for through :class:`~rrps_canopen.force_output.PassiveForceOutput`.
A fault zeroes every force until :meth:`CanopenMaster.reset_faults` and a new activation."""

from __future__ import annotations

import can
import numpy as np

from rrps_canopen.cia402 import Mode
from rrps_canopen.drive import ConfigureError
from rrps_canopen.drive_set import DriveSet
from rrps_canopen.force_output import PassiveForceOutput
from rrps_canopen.homing import set_mode
from rrps_hardware.interface import (
    OK,
    SUCCESS,
    CallbackReturn,
    FaultKind,
    HardwareConfig,
    Result,
    ReturnType,
    Transition,
)
from rrps_hardware.master import MasterInterface, MasterSample

__all__ = ['CanopenMaster', 'STROKE_MARGIN']

#: [m] how far beyond its stroke an encoder may read before it is a fault.
STROKE_MARGIN = 0.002


class CanopenMaster(MasterInterface):
    """A master robot's legs on a CANopen bus (see the module docstring)."""

    def __init__(self):
        self.drives: DriveSet | None = None
        self.output: PassiveForceOutput | None = None
        self.active = False
        self.wanted = np.zeros(6)
        self._last_cycle: float | None = None

    def on_configure(self, config: HardwareConfig) -> Transition:
        g = config.geometry
        if g.bus is None or g.bus.force_output is None:
            return Transition(CallbackReturn.FAILURE, f'robot {g.name!r} has no bus section with force_output: '
                                                      'the canopen master needs one (docs/connecting-a-robot.md)')
        self.stroke = (g.min_length - STROKE_MARGIN, g.max_length + STROKE_MARGIN)
        fo = g.bus.force_output
        self.output = PassiveForceOutput(6, limit=fo.limit, damping=fo.damping)
        try:
            self.drives = DriveSet(g.bus, Mode.CYCLIC_SYNCHRONOUS_TORQUE, extra=self._cycle)
            self.drives.configure()
        except (ConfigureError, FileNotFoundError, can.CanError, OSError, ValueError) as exc:
            self.drives = None
            return Transition(CallbackReturn.FAILURE, f'canopen master: {exc}')
        return Transition(CallbackReturn.SUCCESS, self.drives.notes)

    def _cycle(self, now: float) -> None:
        """Each bus cycle, under the bus' lock: the encoders' bounds, then this period's forces."""
        d = self.drives
        lengths = np.array([drive.scale.position(d.data[drive.name].position) for drive in d.drives])
        for drive, x in zip(d.drives, lengths):
            if not self.stroke[0] <= x <= self.stroke[1]:
                d.latch(drive.name, FaultKind.DRIVE_FAULT, f'encoder reads {x:.4f} m, outside the stroke', now)
        dt = d.period if self._last_cycle is None else now - self._last_cycle
        self._last_cycle = now
        if not self.active or d.faults:
            self.active = False
            self.output.reset()
            for drive in d.drives:
                drive.target_torque = 0
            return
        velocities = np.array([drive.scale.velocity(d.data[drive.name].velocity) for drive in d.drives])
        forces = self.output(self.wanted, lengths, velocities, dt)
        for drive, f in zip(d.drives, forces):
            drive.target_torque = drive.scale.per_mille(float(f))

    def on_activate(self) -> Transition:
        if self.drives is None:
            return Transition(CallbackReturn.FAILURE, 'not configured')
        reason = set_mode(self.drives, self.drives.drives, Mode.CYCLIC_SYNCHRONOUS_TORQUE) or self.drives.enable()
        if reason:
            self.drives.disable()
            return Transition(CallbackReturn.FAILURE, f'activation failed: {reason}: drives disabled')
        with self.drives.lock:
            self.wanted = np.zeros(6)
            self.output.reset()
            self.active = True
        return SUCCESS

    def on_shutdown(self) -> Transition:
        self.active = False
        if self.drives is not None:
            self.drives.hold()
            self.drives.close()
            self.drives = None
        return SUCCESS

    def read(self, time: float) -> MasterSample:
        d = self.drives
        if d is None:
            return MasterSample(np.zeros(0), np.zeros(0), np.zeros(0), lost=True)
        with d.lock:
            data = [d.data[drive.name] for drive in d.drives]
            sample = MasterSample(
                lengths=np.array([drive.scale.position(p.position) for drive, p in zip(d.drives, data)]),
                velocities=np.array([drive.scale.velocity(p.velocity) for drive, p in zip(d.drives, data)]),
                forces=self.output.forces.copy(), faults=tuple(d.faults.values()), lost=d.bus_lost)
        return sample

    def write(self, time: float, forces: np.ndarray | None) -> Result:
        d = self.drives
        if d is None:
            return Result(ReturnType.ERROR, 'not configured')
        with d.lock:
            if d.faults:
                return Result(ReturnType.ERROR, '; '.join(map(str, d.faults.values())) + ': force output off')
            if not self.active:
                return Result(ReturnType.ERROR, 'inactive: no force output')
            wanted = np.zeros(6) if forces is None else np.asarray(forces, dtype=float)
            if wanted.shape != (6,) or not np.all(np.isfinite(wanted)):
                self.wanted = np.zeros(6)
                return Result(ReturnType.ERROR, f'leg forces must be 6 finite numbers [N], got {forces!r}')
            self.wanted = wanted
        return OK

    def reset_faults(self) -> Result:
        if self.drives is None:
            return Result(ReturnType.ERROR, 'not configured')
        reason = self.drives.reset()
        return Result(ReturnType.ERROR, reason) if reason else Result(ReturnType.OK, 'reset: activate to enable')
