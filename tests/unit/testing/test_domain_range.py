"""Private DDS domains of the tests: the default range and ``RRPS_TEST_DOMAINS``."""

import pytest

from rrps_testing import ci


def _ids(monkeypatch, domains, worker='gw1', workers='2', n=200):
    if domains is None:
        monkeypatch.delenv('RRPS_TEST_DOMAINS', raising=False)
    else:
        monkeypatch.setenv('RRPS_TEST_DOMAINS', domains)
    monkeypatch.setenv('PYTEST_XDIST_WORKER', worker)
    monkeypatch.setenv('PYTEST_XDIST_WORKER_COUNT', workers)
    return {ci.next_domain_id() for _ in range(n)}


def test_the_default_range_is_split_between_the_workers(monkeypatch):
    assert _ids(monkeypatch, None, 'gw0') <= set(range(1, 51))
    assert _ids(monkeypatch, None, 'gw1') <= set(range(51, 101))


def test_a_range_of_its_own_keeps_a_checkout_s_tests_inside_it(monkeypatch):
    first = _ids(monkeypatch, '101-125', 'gw0')
    second = _ids(monkeypatch, '101-125', 'gw1')
    assert first <= set(range(101, 113)) and second <= set(range(113, 125))
    assert len(first) == 12 and len(second) == 12


@pytest.mark.parametrize('text', ['abc', '10', '50-20', '200-300'])
def test_a_malformed_range_is_refused_with_its_text(monkeypatch, text):
    monkeypatch.setenv('RRPS_TEST_DOMAINS', text)
    with pytest.raises(ValueError, match='RRPS_TEST_DOMAINS'):
        ci.next_domain_id()
