"""Choice between the numba-compiled kernels and the pure-NumPy/Python paths.

``backend='auto'`` (the default everywhere) uses numba when it imports and the environment
variable ``RRPS_NUMBA`` is not ``0``; ``'numba'`` insists on it; ``'numpy'`` never uses it.
numba is imported on first use only, so ``import rrps_kinematics`` stays light.

Kernels written once for both (the multibody model, the dynamics) are decorated with
:func:`jit`: compiled by numba when it is enabled, otherwise left as the plain Python functions
they are, which run the same arithmetic interpreted. ``RRPS_NUMBA`` is read once, on first use.
"""

from __future__ import annotations

import os

__all__ = ['BACKENDS', 'compiled_backend_available', 'jit', 'kernels', 'numba_enabled',
           'use_numba']

BACKENDS = ('auto', 'numba', 'numpy')
_compiled = None
_numba = None


def numba_enabled() -> bool:
    """True when numba imports and ``RRPS_NUMBA`` is not ``0`` (decided once per process)."""
    global _numba
    if _numba is None:
        _numba = False
        if os.environ.get('RRPS_NUMBA', '1') != '0':
            try:
                import numba
                _numba = numba
            except ImportError:
                pass
    return _numba is not False


def jit(function=None, *, fastmath: bool = False):
    """``numba.njit(cache=True, fastmath=...)`` when numba is enabled, else the function itself.

    Use as ``@jit`` or ``@jit(fastmath=True)``. The decorated code must be valid both as numba
    nopython code and as plain Python (scalars, tuples, NumPy arrays and NamedTuples of them).
    """
    def decorate(f):
        if not numba_enabled():
            return f
        return _numba.njit(cache=True, fastmath=fastmath)(f)
    return decorate if function is None else decorate(function)


def kernels():
    """The :mod:`.compiled` module, imported on first use; None when unavailable or disabled."""
    global _compiled
    if _compiled is None:
        _compiled = False
        if numba_enabled():
            from . import compiled
            _compiled = compiled
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
