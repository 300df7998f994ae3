"""Discovery under loss: after a 10 s outage of the operator link (every packet dropped, the
processes untouched) DDS finds the other side again by itself, with multicast discovery and
with the Fast DDS discovery server on the robot host. Measured: how long after the link
returns the operator station hears a robot-host process it knew before the outage, and one that
started during it (a new participant to discover). Root is needed (``ip netns``, ``nft``)."""

from __future__ import annotations

import time

import pytest

import rrps_testing.netns_rig as netns_rig
from rrps_testing.ci import require
from rrps_testing.link_shaping import LinkShaping, nft_available
from rrps_testing.netns import netns_supported, wait

pytestmark = [pytest.mark.ros, pytest.mark.slow, pytest.mark.netns]
rig_factory = netns_rig.rig_factory  # the fixture

OUTAGE = 10.0
DEADLINE = 60.0


def _heard(agent, source: str, since: float) -> float | None:
    rows = [r for r in agent.records('rig/heartbeat', since) if r['source'] == source]
    return rows[0]['t'] if rows else None


@pytest.mark.parametrize('discovery', ['subnet', 'server'])
def test_discovery_recovers_after_a_10_s_outage_without_a_restart(rig_factory, discovery):
    for ok, reason in (netns_supported(), nft_available()):
        require(ok, reason)
    rig = rig_factory(discovery)
    if discovery == 'server':
        rig.start_discovery_server()
    robot = rig.agent('robot')
    operator = rig.agent('operator')
    assert wait(lambda: _heard(operator, 'robot_agent', 0.0) and _heard(robot, 'operator_agent', 0.0), DEADLINE)
    pids = {name: p.pid for name, p in rig.processes.items()}
    with LinkShaping(rig.robot, 'veth0', rig.operator, 'veth1') as link:
        link.outage(True)
        t_down = time.time()
        time.sleep(1.0)
        assert _heard(operator, 'robot_agent', t_down + 0.5) is None  # the outage is real
        late = rig.agent('robot', 'late_agent')  # a process that starts while the link is down
        time.sleep(max(OUTAGE - (time.time() - t_down), 0.0))
        assert _heard(operator, 'late_agent', 0.0) is None
        link.outage(False)
        t_up = time.time()
        assert wait(lambda: _heard(operator, 'robot_agent', t_up) and _heard(robot, 'operator_agent', t_up)
                    and _heard(operator, 'late_agent', t_up), DEADLINE), f'{discovery}: not rediscovered'
    known = max(_heard(operator, 'robot_agent', t_up), _heard(robot, 'operator_agent', t_up)) - t_up
    new = _heard(operator, 'late_agent', t_up) - t_up
    assert late.process.poll() is None and all(rig.processes[n].pid == pid and rig.processes[n].poll() is None
                                               for n, pid in pids.items())
    print(f'{discovery}: after a {OUTAGE:.0f} s outage, heard again in {known:.2f} s; a process started '
          f'during it discovered in {new:.2f} s')
