"""The operator link as it is in the field: the two-host split of docs/deployment.md with the link relay
(rrps_testing.field_link) on a rig whose veth pair is shaped with ``tc tbf`` and nftables drops
(rrps_testing.link_shaping), teleop engaged and then a climbing step.

* 2 Mbit/s robot -> operator and 500 kbit/s back: teleop follows (slave-state age p99 under
  100 ms, never disengaged), the viewer gets the robot's pose at 10 Hz or more, the climbing
  step completes, and the link carries a fraction of its capacity;
* 500 kbit/s each way with 5 % random loss: the same;
* a 1 s outage every 10 s: teleop disengages and holds within the command timeout, re-engages as
  a clutch (no jump) once the link is back, the climb pauses and resumes on the operator's
  request, no gripper opens on the lost link.

The long profiles and the old subscription pattern as a baseline are benchmarks/field_link.py.
Root is needed (``ip netns``, ``tc``, ``nft``): locally without them these tests skip, in CI they
fail.
"""

from __future__ import annotations

import subprocess

import pytest

from rrps_testing.ci import next_domain_id, require
from rrps_testing.field_link import PROFILES, FieldSession
from rrps_testing.link_shaping import LinkShaping, nft_available
from rrps_testing.netns import netns_supported
from rrps_testing.netns_rig import Rig

pytestmark = [pytest.mark.ros, pytest.mark.slow, pytest.mark.netns]

#: the operator station's link profile: teleop commands at 50 Hz (docs/deployment.md)
COMMAND_RATE = 50.0
#: the driver and the master slower than the demo's 500 and 200 Hz: both hosts and both agents
#: share two cores (the benchmark runs the demo's rates)
DRIVER_RATE = 100.0
MASTER_RATE = 50.0
#: a profile is run again (up to ATTEMPTS times) when the robot's own processes stalled during
#: it for longer than this [s]: a busy machine (the judgement leaves such stalls out)
ROBOT_STALL = 0.3
ATTEMPTS = 2
TELEOP_TIME = 11.0


def _require_rig() -> None:
    for ok, reason in (netns_supported(), nft_available()):
        require(ok, reason)


@pytest.fixture(scope='module')
def session(tmp_path_factory):
    """The two-host split of docs/deployment.md with the link relay, one for the module's tests."""
    _require_rig()
    log_dir = tmp_path_factory.mktemp('field_link')
    rig = Rig(next_domain_id(), discovery='subnet', log_dir=log_dir)
    try:
        rig.__enter__()
        yield FieldSession(rig, 'link', driver_rate=DRIVER_RATE, master_rate=MASTER_RATE, command_rate=COMMAND_RATE)
    finally:
        rig.close()
    assert rig.leftovers() == []


def _run(session, name: str, **kwargs):
    """The profile's result, run again while the machine was too busy to judge the link."""
    for _ in range(ATTEMPTS):
        result = session.run(PROFILES[name], teleop_time=TELEOP_TIME, **kwargs)
        print(result)
        if result.robot_gap <= ROBOT_STALL and result.stalls == 0:
            break
    return result


def _targets(result, session) -> None:
    """The issue's targets for a link that stays up."""
    assert result.follows, (result, session.logs())
    assert result.spurious == 0, result.codes
    assert result.age_p99 is not None and result.age_p99 < 100.0, result
    assert result.viewer_rate is not None and result.viewer_rate >= 10.0, result
    assert result.no_jump, result.clutch_mm
    assert result.climb.startswith('IDLE'), result.climb


def test_teleop_and_a_climb_over_2_mbit_per_s_and_500_kbit_per_s_back(session):
    result = _run(session, '2M')
    _targets(result, session)
    # the budget: the 500 Hz streams stay on the robot host
    assert result.robot_to_operator < 0.5e6 and result.operator_to_robot < 0.4e6, result


def test_teleop_follows_over_500_kbit_per_s_with_5_percent_loss(session):
    result = _run(session, '500k_loss', climb_step=False)
    assert result.follows and result.spurious == 0, (result, session.logs())
    assert result.age_p99 is not None and result.age_p99 < 100.0, result
    assert result.viewer_rate is not None and result.viewer_rate >= 10.0 and result.no_jump, result


def test_a_1_s_outage_every_10_s_pauses_and_resumes_as_the_link_loss_rules_say(session):
    result = _run(session, 'outages')
    assert result.outage_holds  # during teleop (and one during the climb)
    # teleop: no command sent after the link went down reached the robot beyond the command
    # timeout, engaged again after each outage as a clutch (no jump), otherwise never dropped
    assert all(hold <= 0.1 for hold in result.outage_holds), result.outage_holds
    assert result.follows and result.spurious == 0, result
    assert len(result.clutch_mm) >= 2 and result.no_jump, result.clutch_mm
    assert 'SLAVE_STATE_LOST' in result.codes, result.codes
    # the climb paused on the lost operator link, waited for the operator and completed
    assert result.climb.startswith('IDLE') and 'OPERATOR_LINK_LOST' in result.climb, result.climb
    assert result.outage_gripper_switches == 0


def test_link_shaping_is_undone_also_when_a_test_fails(ros_domain_id, tmp_path):
    _require_rig()
    with Rig(ros_domain_id, log_dir=tmp_path) as rig:
        def state() -> tuple[str, str]:
            qdisc = subprocess.run(['ip', 'netns', 'exec', rig.robot, 'tc', 'qdisc', 'show', 'dev', 'veth0'],
                                   capture_output=True, text=True).stdout
            tables = subprocess.run(['ip', 'netns', 'exec', rig.operator, 'nft', 'list', 'tables'],
                                    capture_output=True, text=True).stdout
            return qdisc, tables
        with pytest.raises(RuntimeError, match='a failing test'):
            with LinkShaping(rig.robot, 'veth0', rig.operator, 'veth1') as link:
                link.limit(robot_to_operator=2e6, operator_to_robot=500e3)
                link.loss(0.05)
                link.outage(True)
                qdisc, tables = state()
                assert 'tbf' in qdisc and 'rrps_link' in tables
                raise RuntimeError('a failing test')
        qdisc, tables = state()
        assert 'tbf' not in qdisc and 'rrps_link' not in tables
    assert rig.leftovers() == []
