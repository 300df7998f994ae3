"""The hardware interface of a master robot's drives, for master_node's ``hardware`` parameter.

A :class:`MasterInterface`: six leg encoders and, while active, a bounded, passive force per leg
rendering the slave's limits (master/feedback); registered in ``rrps.master_hardware``. SI units.
"""

from __future__ import annotations

import abc
from dataclasses import dataclass

import numpy as np

from rrps_hardware.interface import ActuatorFault, HardwareConfig, Result, Transition
from rrps_runtime.parameter_schema import Parameter

__all__ = ['MasterSample', 'MasterInterface']


@dataclass(frozen=True)
class MasterSample:
    """One sample of the master: leg ``lengths`` [m] and ``velocities`` [m/s] from its encoders,
    the ``forces`` [N] its drives apply, its latched ``faults``; ``lost``: no fresh sample."""

    lengths: np.ndarray
    velocities: np.ndarray
    forces: np.ndarray
    faults: tuple[ActuatorFault, ...] = ()
    lost: bool = False


class MasterInterface(abc.ABC):
    """A master robot's drives: configure (encoders read), activate (force output on), read,
    write the wanted leg forces, reset the faults, shut down. No exception crosses it."""

    #: The parameters this implementation owns (master_node declares them once its ``hardware``
    #: parameter names it) and reads from :attr:`HardwareConfig.parameters`.
    PARAMETERS: tuple[Parameter, ...] = ()

    @abc.abstractmethod
    def on_configure(self, config: HardwareConfig) -> Transition:
        """Connect and read the encoders; no force is applied."""

    @abc.abstractmethod
    def on_activate(self) -> Transition:
        """Switch the force output on (zero force until written); refused while faulted."""

    @abc.abstractmethod
    def on_shutdown(self) -> Transition:
        """Force output off, disconnect; safe in any state and more than once."""

    @abc.abstractmethod
    def read(self, time: float) -> MasterSample:
        """The encoders now (``time``: the host's monotonic clock [s])."""

    @abc.abstractmethod
    def write(self, time: float, forces: np.ndarray | None) -> Result:
        """The leg forces [N] (6,) the operator should feel (None: none); the hardware renders
        them bounded and passive. ERROR when inactive or faulted."""

    @abc.abstractmethod
    def reset_faults(self) -> Result:
        """Clear the latched faults; the force output stays off until :meth:`on_activate`."""
