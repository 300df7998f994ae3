"""Several robots and one operator station in network namespaces: a fleet on one field network.

:class:`FleetRig`: an operator namespace holding a bridge ``br0`` (the field network's access point, and the
discovery server's host) and a namespace per robot joined to it by a veth pair (``veth0`` on the robot; its peer
``vr<j>``, a bridge port, is shaped for operator -> robot). Hosts are ``'operator'`` and ``'robot_<j>'``
(``'robot'`` is robot 1); the rest is :class:`rrps_testing.netns_rig.Rig`'s. :class:`Fleet` runs the stack on
it: per robot, in ``/robot_<j>``, the driver and the robot nodes (their statuses in the robot's namespace); on
the operator station, in ``/rrps``, master, teleop (driving robot 1) and viewer (listing every robot).
"""

from __future__ import annotations

import os
import time
from pathlib import Path

from rrps_testing.link_shaping import veth_bytes
from rrps_testing.netns import DISCOVERY_PORT, ip, sweep_stale, wait
from rrps_testing.netns_rig import Rig

__all__ = ['FleetRig', 'Fleet', 'robot_namespace', 'ROBOT_REMAPS']

#: the robots' statuses stay in their namespaces (the operator reads them from the relays)
ROBOT_REMAPS = ('/diagnostics:=diagnostics',)
ROBOT_RECORD = ('pose', 'actuators/command', 'actuators/state', 'grippers/state', 'climb/status', 'teleop/status')
OPERATOR_RECORD = ('teleop/status', 'teleop/enable', '/diagnostics')
DEADLINE = 120.0


def robot_namespace(j: int) -> str:
    return f'/robot_{j}'


class FleetRig(Rig):
    """``robots`` robot hosts and one operator station on a bridge (module docstring)."""

    def __init__(self, domain_id: int, robots: int, *, discovery: str = 'subnet', log_dir: str | Path | None = None):
        if discovery not in ('subnet', 'server'):
            raise ValueError(f"a fleet discovers by 'subnet' or 'server', got {discovery!r}")
        if not 1 <= robots <= 200:
            raise ValueError(f'robots must be 1..200, got {robots}')
        super().__init__(domain_id, discovery=discovery, log_dir=log_dir)
        base = self.robot
        self.hosts = {f'robot_{j}': f'{base}_{j}' for j in range(1, robots + 1)}
        self.robot = self.hosts['robot_1']
        prefix = self.subnet.rsplit('.', 1)[0]
        self.robot_ips = {host: f'{prefix}.{10 + j}' for j, host in enumerate(self.hosts, start=1)}
        self.robot_ip = self.robot_ips['robot_1']

    @property
    def robot_count(self) -> int:
        return len(self.hosts)

    def setup(self) -> None:
        sweep_stale()
        names = [self.operator, *self.hosts.values()]
        for name in names:
            ip('netns', 'add', name)
            self._created.append(name)
            self._ns_inodes[name] = os.stat(f'/run/netns/{name}').st_ino
            ip('-n', name, 'link', 'set', 'lo', 'up')
        op = self.operator
        ip('-n', op, 'link', 'add', 'br0', 'type', 'bridge')
        ip('-n', op, 'addr', 'add', f'{self.operator_ip}/24', 'dev', 'br0')
        ip('-n', op, 'link', 'set', 'br0', 'up')
        ip('-n', op, 'route', 'add', '224.0.0.0/4', 'dev', 'br0')
        for j, (host, name) in enumerate(self.hosts.items(), start=1):
            ip('-n', name, 'link', 'add', 'veth0', 'type', 'veth', 'peer', 'name', f'vr{j}', 'netns', op)
            ip('-n', op, 'link', 'set', f'vr{j}', 'master', 'br0')
            ip('-n', op, 'link', 'set', f'vr{j}', 'up')
            ip('-n', name, 'addr', 'add', f'{self.robot_ips[host]}/24', 'dev', 'veth0')
            ip('-n', name, 'link', 'set', 'veth0', 'up')
            ip('-n', name, 'route', 'add', '224.0.0.0/4', 'dev', 'veth0')

    def namespace(self, host: str) -> str | None:
        if host == 'operator':
            return self.operator
        if host == 'robot':
            return self.robot
        if host not in self.hosts:
            raise ValueError(f"host must be 'operator' or one of {list(self.hosts)}, got {host!r}")
        return self.hosts[host]

    def env(self, **extra: str) -> dict:
        env = super().env(**extra)
        if self.discovery == 'server':
            env['ROS_DISCOVERY_SERVER'] = f'{self.operator_ip}:{DISCOVERY_PORT}'
        return env

    def start_discovery_server(self):
        """The Fast DDS discovery server on the operator station (the fleet's hub)."""
        from rrps_testing.netns import discovery_server_command
        command, extra = discovery_server_command(self.operator_ip)
        env = self.env(**extra)
        env.pop('ROS_DISCOVERY_SERVER')
        return self.start('operator', 'discovery_server', command, env=env)

    def leftovers(self) -> list[str]:
        left = super().leftovers()
        from rrps_testing.netns import rig_namespaces
        return left + [name for name in self.hosts.values() if name in rig_namespaces()]

    def robot_bytes(self, host: str) -> tuple[int, int]:
        """(robot -> operator, operator -> robot) bytes of robot ``host``'s link."""
        return veth_bytes(self.hosts[host], 'veth0')


class Fleet:
    """The stack on a :class:`FleetRig` (module docstring): ``driver_rate`` of each driver,
    ``master_rate``, teleop's ``command_rate``; an agent on the operator station and, with
    ``robot_agents``, one on each robot host."""

    def __init__(self, rig: FleetRig, *, driver_rate: float = 50.0, master_rate: float = 50.0,
                 command_rate: float = 50.0, render_rate: float = 10.0, recorder: bool = True,
                 robot_agents: bool = True):
        self.rig = rig
        self.namespaces = [robot_namespace(j) for j in range(1, rig.robot_count + 1)]
        self.t_start = time.time()
        nodes = ['ik_node', 'fk_node', 'climb_node', 'link_relay_node'] + (['recorder_node'] if recorder else [])
        remaps = [a for rule in ROBOT_REMAPS for a in ('-r', rule)]
        for host, ns in zip(rig.hosts, self.namespaces):
            rig.python(host, f'{host}_driver', ['-m', 'rrps_hardware.nodes.driver_node', *rig.ros_args(
                {'robot': 'pole_climber', 'rate': float(driver_rate), 'auto_activate': True}, namespace=ns), *remaps])
            params = {'robot': 'pole_climber', 'climb_node:step_length': 0.03, 'climb_node:speed': 0.03}
            if recorder:
                params.update({'recorder_node:output_dir': str(rig.log_dir or '/tmp'),
                               'recorder_node:record': False})
            rig.python(host, f'{host}_nodes', ['-m', 'rrps_bringup.compose', *nodes,
                                               *rig.ros_args(params, namespace=ns), *remaps])
        self.t_operator = time.time()
        operator = {'master_node:trajectory': 'circle', 'master_node:rate': master_rate,
                    'teleop_node:robot_topics': 'link', 'teleop_node:control': 'timer',
                    'teleop_node:control_rate': command_rate, 'teleop_node:robot_namespace': self.namespaces[0],
                    'viewer_node:robot_topics': 'link', 'viewer_node:robots': self.namespaces,
                    'viewer_node:token': 'fleet-token', 'viewer_node:render_rate': render_rate,
                    'viewer_node:workspace_resolution': 0.0}
        rig.python('operator', 'operator', ['-m', 'rrps_bringup.compose', 'master_node', 'teleop_node',
                                            'viewer_node', *rig.ros_args(operator)])
        self.operator = rig.agent('operator', record=OPERATOR_RECORD)
        self.robots = {ns: rig.agent(host, f'{host}_agent', record=ROBOT_RECORD, namespace=ns, remaps=ROBOT_REMAPS)
                       for host, ns in zip(rig.hosts, self.namespaces)} if robot_agents else {}

    def viewer_status(self, since: float = -float('inf')):
        """The viewer's newest ViewerStatus received since ``since`` (None: none)."""
        from rrps_interfaces.teleop import ViewerStatus
        rows = [r for r in self.operator.records('/diagnostics', since) if r['node'] == 'viewer_node']
        return ViewerStatus.from_values(rows[-1]['values']) if rows else None

    def viewer_heard_all(self) -> bool:
        """Whether the viewer has heard every robot lately (its status on /diagnostics)."""
        status = self.viewer_status(time.time() - 2.0)
        return status is not None and status.heard == self.rig.robot_count

    def wait_up(self) -> float:
        """Wait until every robot moves its pose and the viewer heard them all; seconds since the
        operator station started."""
        ok = wait(lambda: all(agent.records('pose') for agent in self.robots.values()) and self.viewer_heard_all(),
                  DEADLINE, period=0.1)
        if not ok:
            raise RuntimeError('the fleet did not come up:\n' + self.logs())
        return time.time() - self.t_operator

    def logs(self) -> str:
        return '\n'.join(f'--- {n}\n{self.rig.log_tail(n, 8)}' for n in self.rig.processes)

    def bytes(self) -> dict[str, tuple[int, int]]:
        return {ns: self.rig.robot_bytes(host) for host, ns in zip(self.rig.hosts, self.namespaces)}

    def operator_cpu(self) -> float:
        """CPU seconds the operator station's stack process used so far."""
        process = self.rig.processes['operator']
        return _cpu_seconds(process.pid)


def _cpu_seconds(pid: int) -> float:
    """utime + stime [s] of ``pid`` and its children that ``ip netns exec`` left in its place."""
    ticks = os.sysconf('SC_CLK_TCK')
    total = 0.0
    pids = [pid] + _children(pid)
    for p in pids:
        try:
            with open(f'/proc/{p}/stat') as f:
                fields = f.read().rsplit(')', 1)[1].split()
            total += (int(fields[11]) + int(fields[12])) / ticks
        except OSError:
            continue
    return total


def _children(pid: int) -> list[int]:
    try:
        with open(f'/proc/{pid}/task/{pid}/children') as f:
            kids = [int(k) for k in f.read().split()]
    except OSError:
        return []
    return kids + [g for k in kids for g in _children(k)]

