"""The simulated grippers' I/O: a CiA 401 digital I/O module and its fail-safe clamps (set output:
open), each taking the description's ``gripper_time``; a sensor shows a switch once complete
(unless a test makes it stick). Pure Python (canopen), no ROS import."""

from __future__ import annotations

from typing import Any

import canopen

from rrps_canopen_sim.node import SimulatedNode
from rrps_description.motion_limits import GripperTime

__all__ = ['SimulatedIoModule', 'Clamp']


class SimulatedIoModule(SimulatedNode):
    """A CiA 401 module: 8 digital inputs (0x6000:1) and 8 outputs (0x6200:1)."""

    def __init__(self, network: canopen.Network, node_id: int, eds: str):
        super().__init__(network, node_id, eds)
        self.on_reset()
        self.boot()

    def on_reset(self) -> None:
        self.inputs, self.outputs = 0, 0

    def process_value(self, index: int, subindex: int) -> Any:
        if index == 0x6000 and subindex == 1:
            return self.inputs
        if index == 0x6200 and subindex == 1:
            return self.outputs
        return None

    def on_write(self, index: int, subindex: int, value: Any) -> None:
        if index == 0x6200 and subindex == 1:
            self.outputs = int(value)


class Clamp:
    """One ring's clamp: its travel moves towards its command in ``time``'s open or close time;
    ``closed``: fully closed, or still opening (module docstring)."""

    def __init__(self, closed: bool = True, time: GripperTime = GripperTime()):
        self.travel = 1.0 if closed else 0.0   # 1 closed, 0 open
        self.opening = False
        self.time = time
        self.stuck_sensor: bool | None = None  # a sensor stuck at this value

    @property
    def closed(self) -> bool:
        return self.travel >= 1.0 or (self.opening and self.travel > 0.0)

    def step(self, open_command: bool, dt: float) -> None:
        switch = self.time.switch(not open_command)
        rate = dt / switch if switch > 0.0 else 1.0
        self.opening = open_command
        travel = self.travel - rate if open_command else self.travel + rate
        self.travel = 1.0 if travel > 1.0 - 1e-9 else 0.0 if travel < 1e-9 else travel   # rounding: at the end

    def sensor(self) -> bool:
        """The clamp sensor: set while closed (or stuck)."""
        return self.closed if self.stuck_sensor is None else self.stuck_sensor
