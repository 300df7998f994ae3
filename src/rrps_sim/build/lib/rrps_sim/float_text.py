"""Rows of float64 values as CSV text, each value as Python's ``repr`` writes it (the shortest
decimal that reads back to the same double), compiled.

The digits are Ryu's (U. Adams, "Ryū: fast float-to-string conversion", PLDI 2018): the shortest
decimal inside the interval that rounds to the double, from 128-bit products with tables of
powers of 5. The layout is repr's: positional for 1e-4 <= |x| < 1e16 (``0.001``, ``12.0``),
else ``d.ddde±XX`` (``1e-05``, ``1.5e+16``); ``nan``, ``inf``, ``-0.0``. Without numba
(``RRPS_NUMBA=0``) the same text comes from Python's repr itself (the kernels rely on numba's
wrapping uint64 arithmetic).
"""

from __future__ import annotations

from typing import BinaryIO

import numpy as np

from rrps_kinematics.backend import jit, numba_enabled

__all__ = ['CHUNK_ROWS', 'csv_rows', 'write_rows']

_BITCOUNT = 125          # Ryu's DOUBLE_POW5_BITCOUNT = DOUBLE_POW5_INV_BITCOUNT
_U0, _U1, _U2, _U5, _U10, _U50, _U100, _U1E8 = (np.uint64(v) for v in (0, 1, 2, 5, 10, 50, 100, 10**8))
_U32, _U52, _U63, _U64 = (np.uint64(v) for v in (32, 52, 63, 64))
_MASK32 = np.uint64(0xFFFFFFFF)
_MANTISSA = np.uint64((1 << 52) - 1)
_HIDDEN = np.uint64(1 << 52)
_EXPONENT = np.uint64(0x7FF)
_POW10 = np.array([10**k for k in range(17)], np.uint64)
_PAIRS = np.frombuffer(''.join(f'{k:02d}' for k in range(100)).encode('ascii'), np.uint8).copy()
#: Rows formatted at a time by :func:`write_rows` (about 600 kB of text for the simulate CSV).
CHUNK_ROWS = 1000
_MAX_CHARS = 25          # the longest repr of a double, '-2.2250738585072014e-308', and a comma


def _tables() -> tuple[np.ndarray, np.ndarray]:
    """Ryu's DOUBLE_POW5_INV_SPLIT (floor(2^j / 5^i) + 1) and DOUBLE_POW5_SPLIT (5^i in 125
    bits) as (low, high) 64-bit words, computed exactly with Python integers."""
    inverse, power = np.empty((342, 2), np.uint64), np.empty((326, 2), np.uint64)
    low = (1 << 64) - 1
    for i in range(342):
        p = 5 ** i
        v = (1 << (p.bit_length() - 1 + _BITCOUNT)) // p + 1
        inverse[i] = v & low, v >> 64
    for i in range(326):
        p = 5 ** i
        n = p.bit_length()
        v = p >> (n - _BITCOUNT) if n >= _BITCOUNT else p << (_BITCOUNT - n)
        power[i] = v & low, v >> 64
    return inverse, power


_POW5_INV, _POW5 = _tables()


@jit
def _umul128(a, b):
    """The 128-bit product of two uint64: (low, high)."""
    a_lo, a_hi = a & _MASK32, a >> _U32
    b_lo, b_hi = b & _MASK32, b >> _U32
    p00, p01, p10, p11 = a_lo * b_lo, a_lo * b_hi, a_hi * b_lo, a_hi * b_hi
    mid = (p00 >> _U32) + (p01 & _MASK32) + (p10 & _MASK32)
    return (p00 & _MASK32) | (mid << _U32), p11 + (p01 >> _U32) + (p10 >> _U32) + (mid >> _U32)


@jit
def _shift(mid, high, d):
    """(high 2^64 + mid) >> d, 0 < d < 64."""
    d = np.uint64(d)
    return (mid >> d) | (high << (_U64 - d))


@jit
def _add(lo, mid, hi, lo_b, mid_b, hi_b):
    """(hi, mid, lo) + (hi_b, mid_b, lo_b): 192-bit unsigned words with their carries."""
    lo2 = lo + lo_b
    mid2 = mid + mid_b
    if lo2 < lo:
        mid2 += _U1
    hi2 = hi + hi_b + _U1 if mid2 < mid else hi + hi_b
    return lo2, mid2, hi2


@jit
def _subtract(lo, mid, hi, lo_b, mid_b):
    """(hi, mid, lo) - (0, mid_b, lo_b): 192-bit unsigned words with their borrows."""
    lo2 = lo - lo_b
    mid2 = mid - mid_b
    if lo2 > lo:
        mid2 -= _U1
    hi2 = hi - _U1 if mid2 > mid else hi
    return lo2, mid2, hi2


@jit
def _mul_shift_all(m2, low, high, j, mm_shift):
    """floor(x (high 2^64 + low) / 2^j) for x = 4 m2 (vr), 4 m2 + 2 (vp) and 4 m2 - 1 -
    mm_shift (vm), from the one product 2 m2 (high 2^64 + low) (Ryu's mulShiftAll64)."""
    m = m2 << _U1
    lo, tmp = _umul128(m, low)
    mid_lo, hi = _umul128(m, high)
    mid = tmp + mid_lo
    if mid < tmp:
        hi += _U1
    _, mid2, hi2 = _add(lo, mid, hi, low, high, _U0)
    vp = _shift(mid2, hi2, j - 65)
    if mm_shift == _U1:
        _, mid3, hi3 = _subtract(lo, mid, hi, low, high)
        vm = _shift(mid3, hi3, j - 65)
    else:
        lo3, mid3, hi3 = _add(lo, mid, hi, lo, mid, hi)
        _, mid4, hi4 = _subtract(lo3, mid3, hi3, low, high)
        vm = _shift(mid4, hi4, j - 64)
    return _shift(mid, hi, j - 65), vp, vm


@jit
def _pow5_factor(v):
    count = 0
    while v % _U5 == _U0:
        v //= _U5
        count += 1
    return count


@jit
def _interval(bits):
    """Ryu's steps 1-3 for a finite nonzero double: the decimal interval (vr, vp, vm) * 10^e10
    of the values that round to it, whether vm and vr drop only zeros when shortened, and
    whether the interval's bounds are inside (an even mantissa)."""
    mantissa = bits & _MANTISSA
    exponent = np.int64((bits >> _U52) & _EXPONENT)
    if exponent == 0:
        e2 = 1 - 1023 - 52 - 2
        m2 = mantissa
    else:
        e2 = exponent - 1023 - 52 - 2
        m2 = _HIDDEN | mantissa
    accept = (m2 & _U1) == _U0
    mv = m2 << _U2
    mm_shift = _U1 if (mantissa != _U0 or exponent <= 1) else _U0
    vm_zeros = False
    vr_zeros = False
    if e2 >= 0:
        q = ((e2 * 78913) >> 18) - (1 if e2 > 3 else 0)
        e10 = q
        i = -e2 + q + _BITCOUNT + ((q * 1217359) >> 19)
        low, high = _POW5_INV[q, 0], _POW5_INV[q, 1]
        vr, vp, vm = _mul_shift_all(m2, low, high, i, mm_shift)
        if q <= 21:
            if mv % _U5 == _U0:
                vr_zeros = _pow5_factor(mv) >= q
            elif accept:
                vm_zeros = _pow5_factor(mv - _U1 - mm_shift) >= q
            elif _pow5_factor(mv + _U2) >= q:
                vp -= _U1
    else:
        q = ((-e2 * 732923) >> 20) - (1 if -e2 > 1 else 0)
        e10 = q + e2
        i = -e2 - q
        j = q - (((i * 1217359) >> 19) + 1 - _BITCOUNT)
        low, high = _POW5[i, 0], _POW5[i, 1]
        vr, vp, vm = _mul_shift_all(m2, low, high, j, mm_shift)
        if q <= 1:
            vr_zeros = True
            if accept:
                vm_zeros = mm_shift == _U1
            else:
                vp -= _U1
        elif q < 63:
            vr_zeros = (mv & ((_U1 << np.uint64(q)) - _U1)) == _U0
    return vr, vp, vm, e10, vm_zeros, vr_zeros, accept


@jit
def _shortest(bits):
    """The shortest decimal of a finite nonzero double's magnitude: (digits, exponent), value =
    digits * 10^exponent (Ryu's d2d, step 4)."""
    vr, vp, vm, e10, vm_zeros, vr_zeros, accept = _interval(bits)
    removed = 0
    if not (vm_zeros or vr_zeros):                      # the common case (~99 %)
        round_up = False
        if vp // _U100 > vm // _U100:
            round_up = vr % _U100 >= _U50
            vr, vp, vm = vr // _U100, vp // _U100, vm // _U100
            removed = 2
        while vp // _U10 > vm // _U10:
            round_up = vr % _U10 >= _U5
            vr, vp, vm = vr // _U10, vp // _U10, vm // _U10
            removed += 1
        if vr == vm or round_up:
            vr += _U1
        return vr, e10 + removed
    last = _U0
    while vp // _U10 > vm // _U10:
        vm_zeros = vm_zeros and vm % _U10 == _U0
        vr_zeros = vr_zeros and last == _U0
        last = vr % _U10
        vr, vp, vm = vr // _U10, vp // _U10, vm // _U10
        removed += 1
    if vm_zeros:
        while vm % _U10 == _U0:
            vr_zeros = vr_zeros and last == _U0
            last = vr % _U10
            vr, vp, vm = vr // _U10, vp // _U10, vm // _U10
            removed += 1
    if vr_zeros and last == _U5 and vr % _U2 == _U0:
        last = np.uint64(4)      # round half to even
    if (vr == vm and (not accept or not vm_zeros)) or last >= _U5:
        vr += _U1
    return vr, e10 + removed


@jit
def _put(out, n, text):
    for k in range(len(text)):
        out[n + k] = text[k]
    return n + len(text)


@jit
def _put_digits(out, end, value):
    """The decimal digits of value ending at out[end - 1]: 8 at a time, then two at a time."""
    while value >= _U1E8:
        chunk = np.int64(value % _U1E8)
        value //= _U1E8
        for _ in range(4):
            pair = 2 * (chunk % 100)
            chunk //= 100
            out[end - 1] = _PAIRS[pair + 1]
            out[end - 2] = _PAIRS[pair]
            end -= 2
    small = np.int64(value)
    while small >= 100:
        pair = 2 * (small % 100)
        small //= 100
        out[end - 1] = _PAIRS[pair + 1]
        out[end - 2] = _PAIRS[pair]
        end -= 2
    if small >= 10:
        out[end - 1] = _PAIRS[2 * small + 1]
        out[end - 2] = _PAIRS[2 * small]
    else:
        out[end - 1] = 48 + small


@jit
def _write(bits, out, n):
    """One value as repr writes it, at out[n:]; returns the end."""
    exponent = (bits >> _U52) & _EXPONENT
    mantissa = bits & _MANTISSA
    if exponent == _EXPONENT and mantissa != _U0:
        return _put(out, n, b'nan')
    if bits >> _U63:
        out[n] = 45                                     # '-'
        n += 1
    if exponent == _EXPONENT:
        return _put(out, n, b'inf')
    if exponent == _U0 and mantissa == _U0:
        return _put(out, n, b'0.0')
    value, e10 = _shortest(bits)
    size = 17
    while size > 1 and value < _POW10[size - 1]:
        size -= 1
    point = size + e10                                  # value = 0.d1d2...d_size * 10^point
    if point <= -4 or point > 16:                       # d.ddde-XX, d.ddde+XX
        if size > 1:
            _put_digits(out, n + 1 + size, value)
            out[n] = out[n + 1]
            out[n + 1] = 46                             # '.'
            n += 1 + size
        else:
            out[n] = 48 + np.int64(value)
            n += 1
        out[n] = 101                                    # 'e'
        out[n + 1] = 43 if point > 0 else 45            # '+', '-'
        e = abs(point - 1)
        if e >= 100:
            out[n + 2] = 48 + e // 100
            n += 1
        out[n + 2] = 48 + (e // 10) % 10
        out[n + 3] = 48 + e % 10
        return n + 4
    if point <= 0:                                      # 0.000ddd
        out[n] = 48
        out[n + 1] = 46
        for k in range(n + 2, n + 2 - point):
            out[k] = 48
        n += 2 - point
        _put_digits(out, n + size, value)
        return n + size
    if point < size:                                    # ddd.ddd
        _put_digits(out, n + 1 + size, value)
        for k in range(n, n + point):
            out[k] = out[k + 1]
        out[n + point] = 46
        return n + 1 + size
    _put_digits(out, n + size, value)                   # ddd000.0
    for k in range(n + size, n + point):
        out[k] = 48
    out[n + point] = 46
    out[n + point + 1] = 48
    return n + point + 2


@jit
def _rows_text(bits, out):
    """The rows at out[0:]; returns the end. A value equal to the one above it (a constant
    column) is copied from the row above."""
    columns = bits.shape[1]
    above = np.empty(columns, np.int64)                 # where each column's text starts
    width = np.zeros(columns, np.int64)                 # and its length (0: no row above)
    n = 0
    for r in range(bits.shape[0]):
        for c in range(columns):
            if c:
                out[n] = 44                             # ','
                n += 1
            start = n
            if width[c] and bits[r, c] == bits[r - 1, c]:
                for k in range(width[c]):
                    out[n + k] = out[above[c] + k]
                n += width[c]
            else:
                n = _write(bits[r, c], out, n)
            above[c], width[c] = start, n - start
        out[n] = 13                                     # '\r\n', as csv.writer ends a row
        out[n + 1] = 10
        n += 2
    return n


def write_rows(fh: BinaryIO, rows: np.ndarray, chunk: int = CHUNK_ROWS) -> None:
    """Write :func:`csv_rows` of ``rows`` to a binary file, ``chunk`` rows at a time through one
    buffer (it stays in the cache; no copy of the whole text)."""
    rows = _table(rows)
    if not numba_enabled():
        fh.write(csv_rows(rows))
        return
    bits = rows.view(np.uint64)
    out = np.empty(min(chunk, len(rows)) * (rows.shape[1] * _MAX_CHARS + 2), np.uint8)
    for start in range(0, len(rows), chunk):
        fh.write(out[:_rows_text(bits[start:start + chunk], out)])


def csv_rows(rows: np.ndarray) -> bytes:
    """The CSV text (ASCII, rows ended by CRLF as :class:`csv.writer` ends them) of a 2-D array
    of values, each written as ``repr(float(value))``."""
    rows = _table(rows)
    if not numba_enabled():
        line = ','.join(['%r'] * rows.shape[1]) + '\r\n'
        return ((line * rows.shape[0]) % tuple(rows.ravel().tolist())).encode('ascii')
    out = np.empty(rows.size * _MAX_CHARS + 2 * rows.shape[0], np.uint8)
    return out[:_rows_text(rows.view(np.uint64), out)].tobytes()


def _table(rows) -> np.ndarray:
    rows = np.ascontiguousarray(rows, dtype=np.float64)
    if rows.ndim != 2:
        raise ValueError(f'rows must be a 2-D array, got shape {rows.shape}')
    return rows
