"""What a climbing step knows of the robot and the operator station, pure Python.

:class:`ClimbInputs`: the step machine's newest inputs with their watch
(:class:`.climb_watch.InputWatch`), and whether they changed while a step was previewed
(:class:`.step_preview.StepSnapshot`).
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np

from rrps_climbing.climb_watch import InputWatch
from rrps_climbing.step_io import StepConfig
from rrps_climbing.step_preview import StepSnapshot
from rrps_description.pose import Pose
from rrps_interfaces.climb import PauseReason, StepRefusal

__all__ = ['ClimbInputs']


class ClimbInputs:
    """The newest inputs of a climb and their watch; ``clock``: the watch's receipt clock [s]."""

    def __init__(self, config: StepConfig, clock: Callable[[], float]):
        self.watch = InputWatch(state_timeout=config.state_timeout,
                                operator_timeout=config.operator_timeout, clock=clock)
        self.pose: Pose | None = None
        self.grippers: dict[str, bool] | None = None
        self.driver_active: bool | None = None
        self.teleop_engaged = False
        self.engagements = self.driver_changes = 0  # teleop engaged / driver state changed, counted
        self.measured_angles: np.ndarray | None = None

    def pose_received(self) -> None:
        """A measured pose arrived (its receipt counts for the watch; the step machine's ``on_pose`` uses it)."""
        self.watch.received('pose')

    def on_grippers(self, closed: dict[str, bool]) -> None:
        """The gripper states {ring: closed} (both rings)."""
        self.grippers = dict(closed)
        self.watch.received('grippers/state')

    def on_teleop(self, engaged: bool | None) -> None:
        """The operator station was heard; ``engaged``: whether teleoperation is engaged (None:
        its status was unreadable, the last value stands)."""
        self.watch.received('teleop/status')
        if engaged is not None:
            self.engagements += bool(engaged) and not self.teleop_engaged
            self.teleop_engaged = bool(engaged)

    def on_driver_active(self, active: bool) -> None:
        """The driver's lifecycle state (from its status)."""
        self.driver_changes += self.driver_active is not None and bool(active) != self.driver_active
        self.driver_active = bool(active)

    def on_ring_angles(self, theta_a: float, theta_b: float) -> None:
        """The measured extra-DOF angles [rad] (robots that have them); non-finite ones are ignored."""
        if math.isfinite(theta_a) and math.isfinite(theta_b):
            self.measured_angles = np.array([theta_a, theta_b], dtype=float)

    def hold_reason(self) -> PauseReason | None:
        """Why the robot must hold now (a lost input or an inactive driver; None: none)."""
        return self.watch.hold_reason(driver_active=self.driver_active)

    def snapshot(self) -> StepSnapshot:
        """The inputs as a step's preview starts."""
        return StepSnapshot(self.pose, dict(self.grippers), self.engagements, self.driver_changes)

    def changed_since(self, snapshot: StepSnapshot, config: StepConfig) -> tuple[StepRefusal, str] | None:
        """Why a previewed step may no longer start as planned (None: nothing changed)."""
        return snapshot.changed(pose=self.pose, grippers=self.grippers, engagements=self.engagements,
                                driver_changes=self.driver_changes, driver_active=self.driver_active,
                                position_tolerance=config.position_tolerance,
                                orientation_tolerance=config.orientation_tolerance)
