"""Step control of the pose-level Newton-Raphson FK (section 2.2), shared by both backends.

The NumPy reference (:mod:`.forward`) and the compiled kernels (:mod:`.compiled`) read these
constants from here, so neither backend imports the other.
"""

from __future__ import annotations

import math

__all__ = ['MAX_HALVINGS', 'MAX_ROTATION_STEP', 'PIVOT_TOLERANCE']

#: Line-search halvings per Newton iteration before the solve gives up (unconverged).
MAX_HALVINGS = 12
#: A pivot below this (unit-consistent J, entries of order 1) marks the Jacobian singular.
PIVOT_TOLERANCE = 1e-12
#: Largest rotation [rad] taken in one Newton step.
MAX_ROTATION_STEP = 0.5 * math.pi
