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


def next_domain_id() -> int:
    """A ROS domain id private to one test (1..100): each pytest-xdist worker has its own share
    of the range, and within it ids are spread by pid so that concurrent test runs rarely meet."""
    worker = os.environ.get('PYTEST_XDIST_WORKER', '')
    workers = int(os.environ.get('PYTEST_XDIST_WORKER_COUNT', '1') or 1)
    index = int(worker[2:]) if worker.startswith('gw') and worker[2:].isdigit() else 0
    share = max(1, 100 // max(1, workers))
    return 1 + index * share + (os.getpid() * 7 + next(_domain_ids)) % share
