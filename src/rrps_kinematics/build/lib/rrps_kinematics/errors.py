"""Why a computation on valid input has no answer: the exceptions of the math core.

A :class:`ComputationError` is the problem's, not the caller's: the input was well formed but
the pose is singular or a solve did not converge (the command-line tools report it on one line
with exit status 1; malformed input stays a ValueError, a usage error).
"""

from __future__ import annotations

__all__ = ['ComputationError', 'ConvergenceError', 'SingularPoseError']


class ComputationError(RuntimeError):
    """A computation failed on valid input (base class; a RuntimeError)."""


class SingularPoseError(ComputationError, ValueError):
    """A singular pose or configuration: no finite forces or accelerations exist there (a
    degenerate leg, a locked universal joint, a rank-deficient constraint Jacobian).

    Also a ValueError, as singular poses have always been reported by the statics."""


class ConvergenceError(ComputationError):
    """An iterative solve (Newton-Raphson, adaptive integration) did not converge."""
