"""The simulated grippers' I/O: a CiA 401 digital I/O module and the clamps it switches.

A gripper is wired fail-safe: its valve's output bit, when set, opens the clamp; de-energised
(at power-on, after a reboot) the clamp closes. A clamp takes ``CLAMP_TIME`` to close or open; its
sensor input bit is set while it is closed, unless a test makes the sensor stick. Pure Python
(canopen), no ROS import.
"""

from __future__ import annotations

from typing import Any

import canopen
from rrps_canopen_sim.node import SimulatedNode

__all__ = ['SimulatedIoModule', 'Clamp', 'CLAMP_TIME']

#: [s] a clamp's travel between open and closed.
CLAMP_TIME = 0.3


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
    """One ring's clamp: ``closed`` moves towards its command at 1/CLAMP_TIME per second."""

    def __init__(self, closed: bool = True):
        self.travel = 1.0 if closed else 0.0   # 1 closed, 0 open
        self.stuck_sensor: bool | None = None  # a sensor stuck at this value

    @property
    def closed(self) -> bool:
        return self.travel >= 1.0

    def step(self, open_command: bool, dt: float) -> None:
        rate = dt / CLAMP_TIME
        self.travel = max(0.0, self.travel - rate) if open_command else min(1.0, self.travel + rate)

    def sensor(self) -> bool:
        """The clamp sensor: set while closed (or stuck)."""
        return self.closed if self.stuck_sensor is None else self.stuck_sensor
