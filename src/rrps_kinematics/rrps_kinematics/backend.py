"""The kernels, compiled by numba or interpreted: one source for both.

A :func:`jit` kernel is compiled by numba when numba imports, ``RRPS_NUMBA`` is not ``0`` and
numba's own ``NUMBA_DISABLE_JIT`` is not set (read once), else run as plain Python on lists
(:func:`floats`, :func:`matrix`). ``backend`` per call: 'auto', 'numba' (insists) or 'numpy'
(interpreted). Each kernel's disk cache is stamped with all kernel sources
(:func:`kernel_sources_stamp`): numba checks only a kernel's own file.
"""

from __future__ import annotations

import hashlib
import importlib.util
import os
import threading
import types
from pathlib import Path

__all__ = ['BACKENDS', 'PARALLEL_BATCH', 'compiled_backend_available', 'floats', 'interpreted', 'jit',
           'kernel_sources_stamp', 'kernels_of', 'matrix', 'numba_enabled', 'parallel_range', 'run_parallel',
           'use_numba']

BACKENDS = ('auto', 'numba', 'numpy')
#: Packages whose modules may hold :func:`jit` kernels.
KERNEL_PACKAGES = ('rrps_kinematics', 'rrps_sim', 'rrps_teleop')
_numba = None
_stamp = None
_parallel = threading.Lock()
#: Batches at least this long go to the parallel kernels (for shorter ones the launch costs more).
PARALLEL_BATCH = 512


def numba_enabled() -> bool:
    """True when numba imports, ``RRPS_NUMBA`` is not ``0`` and numba's ``NUMBA_DISABLE_JIT`` is not
    set (decided once per process)."""
    global _numba
    if _numba is None:
        _numba = False
        if os.environ.get('RRPS_NUMBA', '1') != '0':
            try:
                import numba
            except ImportError:
                return False
            if numba.config.DISABLE_JIT:   # numba's own switch: its njit would return plain functions
                return False
            _numba = numba
            _register_scratch(numba)
    return _numba is not False


def floats(n):
    """Scratch space of n floats: a list interpreted, an uninitialised array compiled."""
    return [0.0] * n


def matrix(rows, columns):
    """Scratch space of rows x columns floats, indexed ``m[i][k]``: lists interpreted, an array
    compiled."""
    return [[0.0] * columns for _ in range(rows)]


def _register_scratch(numba) -> None:
    """The compiled :func:`floats` and :func:`matrix`: ``np.empty``."""
    import numpy as np
    from numba.extending import overload

    @overload(floats)
    def _floats(n):
        return lambda n: np.empty(n)

    @overload(matrix)
    def _matrix(rows, columns):
        return lambda rows, columns: np.empty((rows, columns))


def parallel_range():
    """``numba.prange`` when numba is enabled (the loop of a ``parallel=True`` kernel), else ``range``."""
    return _numba.prange if numba_enabled() else range


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


def jit(function=None, *, signature=None, fastmath: bool = False, **options):
    """``numba.njit(signature, cache=True, fastmath=..., **options)`` when numba is enabled, else the
    function itself. The code must be valid numba nopython code and plain Python: 2-D arrays indexed
    ``a[i][k]``, scratch space from :func:`floats` and :func:`matrix`."""
    def decorate(f):
        if not numba_enabled():
            return f
        dispatcher = _numba.njit(signature, cache=True, fastmath=fastmath, **options)(f)
        # numba's cache index (third-party internals of the pinned numba): stamp it with all
        # kernel sources too, so that a change to a callee invalidates this kernel's cache.
        index = getattr(dispatcher._cache, '_cache_file', None)
        if index is not None and hasattr(index, '_source_stamp'):
            index._source_stamp = (index._source_stamp, kernel_sources_stamp())
        return dispatcher
    return decorate if function is None else decorate(function)


_interpreted: dict = {}


def interpreted(kernel):
    """The plain Python function of a :func:`jit` kernel, every kernel it calls interpreted too
    (the kernel itself when numba is disabled): ``backend='numpy'`` in a process that compiles."""
    function = getattr(kernel, 'py_func', None)
    if function is None:
        return kernel
    plain = _interpreted.get(function)
    if plain is None:
        namespace = dict(function.__globals__)
        plain = _interpreted[function] = types.FunctionType(
            function.__code__, namespace, function.__name__, function.__defaults__, function.__closure__)
        for name in function.__code__.co_names:
            if hasattr(namespace.get(name), 'py_func'):
                namespace[name] = interpreted(namespace[name])
    return plain


_namespaces: dict = {}


def kernels_of(module, backend: str = 'auto'):
    """The kernels of ``module`` for ``backend``: the module itself when compiled, else a
    namespace of its functions :func:`interpreted`."""
    if use_numba(backend):
        return module
    namespace = _namespaces.get(module.__name__)
    if namespace is None:
        namespace = _namespaces[module.__name__] = types.SimpleNamespace(**{
            name: interpreted(value) for name, value in vars(module).items() if not name.startswith('__')})
    return namespace


def compiled_backend_available() -> bool:
    """True when the numba backend can be used (numba importable, ``RRPS_NUMBA`` not ``0``)."""
    return numba_enabled()


def use_numba(backend: str) -> bool:
    """Resolve a ``backend`` argument; ValueError for unknown names or unavailable numba."""
    if backend not in BACKENDS:
        raise ValueError(f'backend must be one of {BACKENDS}, got {backend!r}')
    if backend == 'numpy':
        return False
    available = numba_enabled()
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
