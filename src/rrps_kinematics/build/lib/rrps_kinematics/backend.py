"""Choice between the numba-compiled kernels and the pure-NumPy/Python paths.

``backend='auto'`` (the default everywhere) uses numba when it imports and the environment
variable ``RRPS_NUMBA`` is not ``0``; ``'numba'`` insists on it; ``'numpy'`` never uses it.
numba is imported on first use only, so ``import rrps_kinematics`` stays light.

Kernels written once for both (the multibody model, the dynamics) are decorated with
:func:`jit`: compiled by numba when it is enabled, otherwise left as the plain Python functions
they are, which run the same arithmetic interpreted. ``RRPS_NUMBA`` is read once, on first use.

Compiled kernels are cached on disk. numba checks only a kernel's own source file, while a
compiled kernel contains the kernels it calls (and the layouts they assume); so the cache of
every :func:`jit` kernel is also stamped with the sources of all of them
(:func:`kernel_sources_stamp`), and any change to one recompiles them all.
"""

from __future__ import annotations

import hashlib
import importlib.util
import os
import threading
from pathlib import Path

__all__ = ['BACKENDS', 'PARALLEL_BATCH', 'compiled_backend_available', 'jit', 'kernel_sources_stamp', 'kernels',
           'numba_enabled', 'run_parallel', 'use_numba']

BACKENDS = ('auto', 'numba', 'numpy')
#: Packages whose modules may hold :func:`jit` kernels.
KERNEL_PACKAGES = ('rrps_kinematics', 'rrps_sim', 'rrps_teleop')
_compiled = None
_numba = None
_stamp = None
_parallel = threading.Lock()
#: Batches at least this long go to the parallel kernels (for shorter ones the launch costs more).
PARALLEL_BATCH = 512


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


def kernel_sources_stamp() -> str:
    """sha256 of every module of KERNEL_PACKAGES that holds numba kernels (:func:`jit`, or a
    module's own ``_jit`` decorator), computed once."""
    global _stamp
    if _stamp is None:
        digest = hashlib.sha256()
        for package in KERNEL_PACKAGES:
            spec = importlib.util.find_spec(package)
            if spec is None or not spec.submodule_search_locations:
                continue
            for root in spec.submodule_search_locations:
                for path in sorted(Path(root).rglob('*.py')):
                    text = path.read_bytes()
                    if b'@jit' in text or b'@_jit' in text:
                        digest.update(str(path.relative_to(root)).encode() + b'\0' + text)
        _stamp = digest.hexdigest()
    return _stamp


def jit(function=None, *, fastmath: bool = False):
    """``numba.njit(cache=True, fastmath=...)`` when numba is enabled, else the function itself.

    Use as ``@jit`` or ``@jit(fastmath=True)``. The decorated code must be valid both as numba
    nopython code and as plain Python (scalars, tuples, NumPy arrays and NamedTuples of them).
    """
    def decorate(f):
        if not numba_enabled():
            return f
        dispatcher = _numba.njit(cache=True, fastmath=fastmath)(f)
        # numba's cache index (third-party internals of the pinned numba): stamp it with all
        # kernel sources too, so that a change to a callee invalidates this kernel's cache.
        index = getattr(dispatcher._cache, '_cache_file', None)
        if index is not None and hasattr(index, '_source_stamp'):
            index._source_stamp = (index._source_stamp, kernel_sources_stamp())
        return dispatcher
    return decorate if function is None else decorate(function)


def kernels():
    """The :mod:`.compiled` module, imported on first use; None when unavailable or disabled."""
    global _compiled
    if _compiled is None:
        _compiled = False
        if numba_enabled():
            from rrps_kinematics import compiled
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


def run_parallel(kernel, *args) -> bool:
    """Run a ``parallel=True`` kernel on numba's threads (``NUMBA_NUM_THREADS``, by default the
    cores), unless there is one thread only or another thread of this process is running one
    (numba's workqueue threading layer aborts the process on concurrent parallel launches).
    The threads take the kernel's tasks one at a time (chunk size 1: on a shared machine a
    thread that loses its core does not hold up the others' share). True when it ran; False
    means: call the serial kernel instead (the parallel kernels give the same numbers)."""
    if _numba.get_num_threads() < 2 or not _parallel.acquire(blocking=False):
        return False
    chunksize = _numba.set_parallel_chunksize(1)
    try:
        kernel(*args)
    finally:
        _numba.set_parallel_chunksize(chunksize)
        _parallel.release()
    return True
