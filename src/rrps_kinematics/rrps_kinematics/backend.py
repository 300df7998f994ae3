"""Choice between the numba-compiled kernels (:mod:`.compiled`) and the pure-NumPy paths.

``backend='auto'`` (the default everywhere) uses numba when it imports and the environment
variable ``RRPS_NUMBA`` is not ``0``; ``'numba'`` insists on it; ``'numpy'`` never uses it.
numba is imported on first use only, so ``import rrps_kinematics`` stays light.
"""

from __future__ import annotations

import os

__all__ = ['BACKENDS', 'compiled_backend_available', 'use_numba', 'kernels']

BACKENDS = ('auto', 'numba', 'numpy')
_compiled = None


def kernels():
    """The :mod:`.compiled` module, imported on first use; None when unavailable or disabled."""
    global _compiled
    if _compiled is None:
        if os.environ.get('RRPS_NUMBA', '1') == '0':
            _compiled = False
        else:
            try:
                from . import compiled
                _compiled = compiled
            except ImportError:
                _compiled = False
    return _compiled or None


def compiled_backend_available() -> bool:
    """True when the numba backend can be used (numba importable, ``RRPS_NUMBA`` not ``0``)."""
    return kernels() is not None


def use_numba(backend: str) -> bool:
    """Resolve a ``backend`` argument; ValueError for unknown names or unavailable numba."""
    if backend not in BACKENDS:
        raise ValueError(f'backend must be one of {BACKENDS}, got {backend!r}')
    if backend == 'numpy':
        return False
    available = kernels() is not None
    if backend == 'numba' and not available:
        raise ValueError('backend "numba" requested but numba is not available (or RRPS_NUMBA=0)')
    return available
