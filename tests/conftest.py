"""Shared pytest fixtures: DDS on loopback, a private rclpy Context per ROS test, and ``--load``.

``./rrps test --load [ARGS]`` runs the tests while tests/load.py keeps one core busy and a
second ROS process floods the machine with DDS messages: the suite must pass on a busy
machine, not only on an idle one.
"""

from __future__ import annotations

import itertools
import os

import pytest

# Every process that starts rclpy here keeps DDS on this machine (README: deployment).
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


def pytest_addoption(parser):
    group = parser.getgroup('rrps')
    group.addoption('--load', action='store_true',
                    help='run the tests on a loaded machine: a busy core and a DDS flood '
                         '(tests/load.py)')
    group.addoption('--load-busy', type=int, default=1, help='with --load: busy processes')
    group.addoption('--load-flood-rate', type=float, default=2000.0,
                    help='with --load: DDS messages per second per topic of the flood')


@pytest.fixture(scope='session', autouse=True)
def machine_load(request):
    """With ``--load``, the load of tests/load.py around the whole session."""
    if not request.config.getoption('--load'):
        yield None
        return
    from load import Load
    with Load(busy=request.config.getoption('--load-busy'),
              flood_rate=request.config.getoption('--load-flood-rate')) as load:
        yield load
