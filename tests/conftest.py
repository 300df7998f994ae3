"""Shared pytest fixtures: DDS on loopback, and a private rclpy Context per ROS test."""

from __future__ import annotations

import itertools
import os

import pytest

# Every process that starts rclpy here keeps DDS on this machine (NOTES-ros-on-pip.md).
os.environ['ROS_AUTOMATIC_DISCOVERY_RANGE'] = 'LOCALHOST'

_domain_ids = itertools.count()


def _next_domain_id() -> int:
    """A domain id private to this test: spread by pid so concurrent test runs do not meet."""
    return 1 + (os.getpid() * 7 + next(_domain_ids)) % 100


@pytest.fixture
def ros_domain_id() -> int:
    return _next_domain_id()


@pytest.fixture
def ros_context(ros_domain_id):
    """An initialised rclpy Context on its own domain id; shut down after the test."""
    import rclpy

    context = rclpy.Context()
    rclpy.init(context=context, domain_id=ros_domain_id)
    try:
        yield context
    finally:
        if context.ok():
            rclpy.shutdown(context=context)


def require(condition: bool, reason: str) -> None:
    """Skip a test whose dependency is missing on a developer's machine; fail it in CI.

    CI installs every dependency (./rrps test), so there a missing one is a defect, never a skip.
    """
    if condition:
        return
    if os.environ.get('CI'):
        pytest.fail(f'{reason} (CI must have it)')
    pytest.skip(reason)
