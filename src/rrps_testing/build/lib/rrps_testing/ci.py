"""What a test needs from its machine: dependencies that CI must have, and private DDS domains."""

from __future__ import annotations

import itertools
import os

__all__ = ['require', 'next_domain_id']

_domain_ids = itertools.count()


def require(condition: bool, reason: str) -> None:
    """Skip a test whose dependency is missing on a developer's machine; fail it in CI.

    CI installs every dependency (./rrps test), so there a missing one is a defect, never a skip.
    """
    if condition:
        return
    import pytest
    if os.environ.get('CI'):
        pytest.fail(f'{reason} (CI must have it)')
    pytest.skip(reason)


def _domain_range() -> tuple[int, int]:
    """The ids tests may use: ``RRPS_TEST_DOMAINS=FIRST-LAST`` (so that test runs of several
    checkouts on one machine never share a domain), 1-100 when unset."""
    text = os.environ.get('RRPS_TEST_DOMAINS', '')
    if not text:
        return 1, 100
    try:
        first, last = (int(part) for part in text.split('-'))
    except ValueError:
        raise ValueError(f'RRPS_TEST_DOMAINS={text!r}: expected FIRST-LAST, e.g. 101-140') from None
    if not 0 <= first <= last <= 232:
        raise ValueError(f'RRPS_TEST_DOMAINS={text!r}: ids must be 0-232, FIRST <= LAST')
    return first, last


def next_domain_id() -> int:
    """A ROS domain id private to one test (1..100, or ``RRPS_TEST_DOMAINS``): each pytest-xdist
    worker has its own share of the range, and within it ids are spread by pid so that concurrent
    test runs rarely meet."""
    first, last = _domain_range()
    worker = os.environ.get('PYTEST_XDIST_WORKER', '')
    workers = int(os.environ.get('PYTEST_XDIST_WORKER_COUNT', '1') or 1)
    index = int(worker[2:]) if worker.startswith('gw') and worker[2:].isdigit() else 0
    share = max(1, (last - first + 1) // max(1, workers))
    return first + index * share + (os.getpid() * 7 + next(_domain_ids)) % share
