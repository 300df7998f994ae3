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
    """A ROS domain id private to one test (1..100): spread by pid so that concurrent test
    runs do not meet."""
    return 1 + (os.getpid() * 7 + next(_domain_ids)) % 100
