"""rrps_sim.float_text: the compiled CSV text is Python's repr of every double, checked value by
value against repr itself on random bit patterns and the edge cases of the layout."""

import io

import numpy as np
import pytest

from rrps_sim.float_text import csv_rows, write_rows

EDGES = [0.0, -0.0, np.nan, -np.nan, np.inf, -np.inf, 5e-324, -5e-324, 2.2250738585072014e-308,
         2.225073858507201e-308, 1.7976931348623157e308, 1e16, 9999999999999998.0, 1e15, 1e-4,
         9.999999999999999e-05, 1e-5, 0.001, 0.1, 0.3, 1 / 3, 12.0, 100.0, 1e22, 1e23, 2.0**53,
         2.0**63, 16900.0, 0.5, 1.5, 2.5e-7, 123456.789, 1.0e-300, 4.35e+100]


def expected(rows):
    return ''.join(','.join(map(repr, row)) + '\r\n' for row in np.asarray(rows).tolist())


def test_edges_are_written_as_repr_writes_them():
    rows = np.array(EDGES).reshape(-1, 2)
    assert csv_rows(rows).decode('ascii') == expected(rows)


@pytest.mark.parametrize('kind', ['bits', 'scaled', 'decimals', 'steps'])
def test_random_doubles_are_written_as_repr_writes_them(kind):
    rng = np.random.default_rng(29)
    n = 60_000
    if kind == 'bits':           # every exponent and mantissa, subnormals, nan and inf included
        values = rng.integers(0, 2**64, size=n, dtype=np.uint64).view(np.float64)
    elif kind == 'scaled':
        values = rng.normal(size=n) * 10.0 ** rng.integers(-320, 308, size=n)
    elif kind == 'decimals':     # short decimals, where the shortest digits matter most
        values = np.round(rng.normal(size=n) * 10.0 ** rng.integers(-6, 18, size=n), 3)
    else:
        values = np.arange(n) * 0.001
    rows = values.reshape(-1, 12)
    assert csv_rows(rows).decode('ascii') == expected(rows)
    back = np.array([line.split(',') for line in csv_rows(rows).decode().split('\r\n')[:-1]], float)
    np.testing.assert_array_equal(back, rows)


def test_repeated_values_are_copied_from_the_row_above_exactly():
    rows = np.tile(np.array(EDGES[:12]), (5, 1))
    rows[2, 3] = 0.25
    rows[3:, 5] = -1.5e-300
    assert csv_rows(rows).decode('ascii') == expected(rows)


def test_written_in_chunks_is_the_same_text():
    rows = np.tile(np.array(EDGES[:12]), (7, 1))
    rows[::3, 4] = 0.125
    fh = io.BytesIO()
    write_rows(fh, rows, chunk=3)
    assert fh.getvalue() == csv_rows(rows) == expected(rows).encode('ascii')


def test_a_non_table_is_rejected():
    with pytest.raises(ValueError, match='2-D'):
        csv_rows(np.zeros(3))
