"""A multi-host rig: a robot host and an operator station in two network namespaces.

The namespaces ``rrps_robot_<pid>_<n>`` and ``rrps_op_<pid>_<n>`` are joined by one veth pair (``veth0``
10.213.<k>.1/24 on the robot, ``veth1`` 10.213.<k>.2/24 on the operator station) and reach no other network,
so DDS discovers across them for real. ``discovery``: ``'subnet'`` (multicast on the veth), ``'server'`` (the
Fast DDS discovery server of the pinned wheel on the robot host, 10.213.<k>.1:11811, as docs/deployment.md
recommends for Wi-Fi) or ``'loopback'`` (no namespaces, no root, no link faults: :attr:`Rig.can_cut_link`).
Every process runs under ``ip netns exec``, in a process group of its own, with the parent-death signal.
:meth:`Rig.close` stops them, kills what else runs in the namespaces, deletes the namespaces and checks that
nothing is left; :func:`sweep_stale` removes the namespaces of rigs whose process died.
"""

from __future__ import annotations

import itertools
import json
import os
import shutil
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Iterable, Sequence

import pytest

from rrps_runtime.supervision import start_child
from rrps_testing.agent_handle import AgentHandle
from rrps_testing.netns import (
    DISCOVERY_PORT,
    discovery_server_command,
    ip,
    kill_namespace_processes,
    netns_supported,
    rig_namespaces,
    sweep_stale,
)

__all__ = ['Rig', 'rig_factory', 'NAMESPACE']

NAMESPACE = '/rrps'
_counter = itertools.count()


class Rig:
    """The robot host and the operator station; see the module docstring."""

    def __init__(self, domain_id: int, *, discovery: str = 'subnet', log_dir: str | Path | None = None):
        if discovery not in ('subnet', 'server', 'loopback'):
            raise ValueError(f"discovery must be 'subnet', 'server' or 'loopback', got {discovery!r}")
        self.domain_id = int(domain_id)
        self.discovery = discovery
        n = next(_counter)
        pid = os.getpid()
        self.isolated = discovery != 'loopback'
        self.robot = f'rrps_robot_{pid}_{n}' if self.isolated else None
        self.operator = f'rrps_op_{pid}_{n}' if self.isolated else None
        k = 1 + (pid * 3 + n) % 250
        self.subnet = f'10.213.{k}.0/24'
        self.robot_ip = f'10.213.{k}.1' if self.isolated else '127.0.0.1'
        self.operator_ip = f'10.213.{k}.2' if self.isolated else '127.0.0.1'
        self.log_dir = Path(log_dir) if log_dir is not None else None
        self.processes: dict[str, subprocess.Popen] = {}
        self.agents: dict[str, AgentHandle] = {}
        self._created: list[str] = []
        self._ns_inodes: dict[str, int] = {}
        self._logs: list = []
        self.link_up = True
        self._params_dir: Path | None = None

    @property
    def can_cut_link(self) -> bool:
        return self.isolated

    # --- set-up and tear-down ------------------------------------------------------------------

    def __enter__(self) -> 'Rig':
        try:
            self.setup()
        except BaseException:
            self.close()
            raise
        return self

    def __exit__(self, *exc_info) -> None:
        self.close()

    def setup(self) -> None:
        if not self.isolated:
            return
        sweep_stale()
        for name in (self.robot, self.operator):
            ip('netns', 'add', name)
            self._created.append(name)
            self._ns_inodes[name] = os.stat(f'/run/netns/{name}').st_ino
            ip('-n', name, 'link', 'set', 'lo', 'up')
        # the veth pair is created inside the robot namespace, its peer inside the operator's:
        # it never exists in the root namespace
        ip('-n', self.robot, 'link', 'add', 'veth0', 'type', 'veth', 'peer', 'name', 'veth1',
            'netns', self.operator)
        prefix = self.subnet.split('/')[1]
        for name, dev, address in ((self.robot, 'veth0', self.robot_ip),
                                   (self.operator, 'veth1', self.operator_ip)):
            ip('-n', name, 'addr', 'add', f'{address}/{prefix}', 'dev', dev)
            ip('-n', name, 'link', 'set', dev, 'up')
            ip('-n', name, 'route', 'add', '224.0.0.0/4', 'dev', dev)

    def close(self, timeout: float = 5.0) -> None:
        """Stop every process, kill what remains in the namespaces, delete them."""
        self.stop_all(timeout)
        for name in self._created:
            kill_namespace_processes(name)
            ip('netns', 'del', name, check=False)
        self._created = []
        for log in self._logs:
            log.close()
        self._logs = []
        if self._params_dir is not None:
            shutil.rmtree(self._params_dir, ignore_errors=True)
            self._params_dir = None

    def leftovers(self) -> list[str]:
        """What this rig left behind: its namespaces, processes still inside them (found by
        their network namespace inode), processes it started that still run."""
        left = [name for name in (self.robot, self.operator) if name and name in rig_namespaces()]
        inodes = set(self._ns_inodes.values())
        for entry in Path('/proc').iterdir():
            if not entry.name.isdigit():
                continue
            try:
                if os.stat(entry / 'ns' / 'net').st_ino in inodes:
                    left.append(f'pid {entry.name} in a rig namespace')
            except OSError:
                continue
        left += [f'{name} (pid {p.pid})' for name, p in self.processes.items() if p.poll() is None]
        return left

    # --- processes -----------------------------------------------------------------------------

    def namespace(self, host: str) -> str | None:
        if host not in ('robot', 'operator'):
            raise ValueError(f"host must be 'robot' or 'operator', got {host!r}")
        return self.robot if host == 'robot' else self.operator

    def env(self, **extra: str) -> dict:
        """The environment of every rig process: the test's domain id, DDS discovery of the rig."""
        env = dict(os.environ)
        env.pop('ROS_LOCALHOST_ONLY', None)
        env.pop('ROS_DISCOVERY_SERVER', None)
        env.pop('ROS_STATIC_PEERS', None)
        env.update(ROS_DOMAIN_ID=str(self.domain_id), PYTHONUNBUFFERED='1',
                   ROS_AUTOMATIC_DISCOVERY_RANGE='SUBNET' if self.isolated else 'LOCALHOST')
        if self.discovery == 'server':
            env['ROS_DISCOVERY_SERVER'] = f'{self.robot_ip}:{DISCOVERY_PORT}'
        env.update(extra)
        return env

    def start(self, host: str, name: str, args: Sequence[str], *, env: dict | None = None,
              pipes: bool = False, cwd: str | Path | None = None, nice: int | None = None) -> subprocess.Popen:
        """Start ``args`` on ``host`` ('robot' or 'operator') as ``name``, in a process group
        of its own (at ``nice``, its session's autogroup too: rrps_runtime.supervision.start_child);
        stdout and stderr go to ``<log_dir>/<name>.log`` (or stdin/stdout pipes with ``pipes``:
        stderr still to the log)."""
        if name in self.processes and self.processes[name].poll() is None:
            raise RuntimeError(f'{name} is already running')
        ns = self.namespace(host)
        command = (['ip', 'netns', 'exec', ns] if ns else []) + [str(a) for a in args]
        log = self._log(name)
        kwargs = dict(stdin=subprocess.PIPE if pipes else subprocess.DEVNULL,
                      stdout=subprocess.PIPE if pipes else log, stderr=log,
                      start_new_session=True, cwd=cwd)
        if pipes:
            kwargs.update(text=True, bufsize=1)
        process = start_child(command, env=env or self.env(), nice=nice, **kwargs)
        self.processes[name] = process
        return process

    def _log(self, name: str):
        if self.log_dir is None:
            return subprocess.DEVNULL
        log = open(self.log_dir / f'{name}.log', 'ab')
        self._logs.append(log)
        return log

    def log_tail(self, name: str, lines: int = 20) -> str:
        if self.log_dir is None or not (self.log_dir / f'{name}.log').exists():
            return ''
        text = (self.log_dir / f'{name}.log').read_text(errors='replace').splitlines()
        return '\n'.join(text[-lines:])

    def signal(self, name: str, sig: int = signal.SIGKILL) -> None:
        """Send ``sig`` to the process group of ``name`` (SIGKILL: the process dies at once)."""
        process = self.processes[name]
        try:
            os.killpg(process.pid, sig)
        except ProcessLookupError:
            pass
        if sig == signal.SIGKILL:
            process.wait(timeout=10)

    def stop(self, name: str, timeout: float = 5.0) -> int | None:
        """SIGTERM to ``name``'s process group, SIGKILL after ``timeout`` s; its exit status."""
        process = self.processes.get(name)
        if process is None:
            return None
        for sig, limit in ((signal.SIGTERM, timeout), (signal.SIGKILL, 5.0)):
            if process.poll() is not None:
                break
            try:
                os.killpg(process.pid, sig)
            except ProcessLookupError:
                break
            try:
                process.wait(limit)
            except subprocess.TimeoutExpired:
                continue
        try:  # the group's other members (a browser's children) go too
            os.killpg(process.pid, signal.SIGKILL)
        except (ProcessLookupError, PermissionError):
            pass
        return process.returncode

    def stop_all(self, timeout: float = 5.0) -> None:
        for name, process in list(self.processes.items()):
            if process.poll() is None:
                try:
                    os.killpg(process.pid, signal.SIGTERM)
                except ProcessLookupError:
                    pass
        deadline = time.monotonic() + timeout
        for name in list(self.processes):
            process = self.processes[name]
            try:
                process.wait(max(deadline - time.monotonic(), 0.1))
            except subprocess.TimeoutExpired:
                pass
            self.stop(name, 0.1)
        for agent in self.agents.values():
            for stream in (agent.process.stdin, agent.process.stdout):
                try:
                    stream.close()
                except (OSError, ValueError):
                    pass

    # --- the stack -----------------------------------------------------------------------------

    def python(self, host: str, name: str, args: Sequence[str], **kwargs) -> subprocess.Popen:
        return self.start(host, name, [sys.executable, *args], **kwargs)

    def ros_args(self, params: dict | None = None, namespace: str = NAMESPACE) -> list[str]:
        """``--ros-args`` under ``namespace``: ``{'rate': 100.0}`` for every node of the
        process, ``{'climb_node:speed': 0.03}`` for one node (a params file: rcl's
        ``-p node:name:=value`` does not match nodes in a namespace)."""
        out = ['--ros-args', '-r', f'__ns:={namespace}']
        per_node: dict[str, dict] = {}
        for key, value in (params or {}).items():
            if ':' in key:
                node, name = key.split(':', 1)
                per_node.setdefault(node, {})[name] = value
                continue
            if isinstance(value, bool):
                value = str(value).lower()
            out += ['-p', f'{key}:={value}']
        if per_node:
            import yaml
            if self._params_dir is None:
                self._params_dir = Path(tempfile.mkdtemp(prefix='rrps-rig-'))
            path = self._params_dir / f'params_{next(_counter)}.yaml'
            path.write_text(yaml.safe_dump({f'{namespace}/{node}': {'ros__parameters': values}
                                            for node, values in per_node.items()}))
            out += ['--params-file', str(path)]
        return out

    def start_discovery_server(self) -> subprocess.Popen:
        """The Fast DDS discovery server on the robot host (``discovery='server'`` only)."""
        if self.discovery != 'server':
            raise RuntimeError('the rig does not use a discovery server')
        command, extra = discovery_server_command(self.robot_ip)
        env = self.env(**extra)
        env.pop('ROS_DISCOVERY_SERVER')
        return self.start('robot', 'discovery_server', command, env=env)

    def start_driver(self, *, state_file: str | Path = '', activate: bool = True,
                     rate: float = 100.0, name: str = 'driver', **params) -> subprocess.Popen:
        """driver_node on the robot host (the simulated hardware, a process of its own)."""
        if state_file:
            params['state_file'] = str(state_file)
        return self.python('robot', name, ['-m', 'rrps_hardware.nodes.driver_node', *self.ros_args({
            'robot': 'pole_climber', 'rate': float(rate), 'auto_activate': activate, **params})])

    def start_robot_nodes(self, *, name: str = 'robot_nodes', **params) -> subprocess.Popen:
        """IK, FK and climbing composed in one process on the robot host (as the demo runs
        them); ``params`` as ``{'climb_node:speed': 0.03}``."""
        return self.python('robot', name, ['-m', 'rrps_bringup.compose', 'ik_node', 'fk_node',
                                           'climb_node',
                                           *self.ros_args({'robot': 'pole_climber', **params})])

    def start_operator(self, *, viewer: bool = False, name: str = 'operator', **params) -> subprocess.Popen:
        """The operator station's master, teleop (and viewer) composed in one process."""
        nodes = ['master_node', 'teleop_node'] + (['viewer_node'] if viewer else [])
        return self.python('operator', name, ['-m', 'rrps_bringup.compose', *nodes,
                                              *self.ros_args(params)])

    def agent(self, host: str, name: str | None = None, *, record: Iterable[str] = (),
              timeout: float = 60.0, namespace: str = NAMESPACE, remaps: Iterable[str] = ()) -> AgentHandle:
        """A rrps_testing.netns_agent on ``host`` (in ``namespace``, with ``remaps``) recording
        ``record``; waits until it is ready."""
        name = name or f'{host}_agent'
        remap_args = [arg for rule in remaps for arg in ('-r', rule)]
        process = self.python(host, name, ['-m', 'rrps_testing.netns_agent', '--name', name,
                                           '--record', ','.join(record), *self.ros_args(namespace=namespace),
                                           *remap_args], pipes=True)
        handle = AgentHandle(name, process)
        self.agents[name] = handle
        if not handle.ready.wait(timeout):
            raise RuntimeError(f'agent {name} did not start: {self.log_tail(name)}')
        return handle

    # --- faults --------------------------------------------------------------------------------

    def link(self, up: bool) -> float:
        """Take the veth link down or up (``ip link set``, the robot's end first: its peer loses
        its carrier at once); returns the time.time() of the change: for a cut, when it had
        surely taken effect, for a return, when it may have begun."""
        if not self.can_cut_link:
            raise RuntimeError('loopback rig: no link to cut (needs network namespaces)')
        state = 'up' if up else 'down'
        before = time.time()
        ip('-n', self.robot, 'link', 'set', 'veth0', state)  # the link is cut (or back) here
        after = time.time()
        ip('-n', self.operator, 'link', 'set', 'veth1', state)
        self.link_up = up
        # conservative: a cut from when it surely took effect, a return from when it may have
        return after if not up else before

    def interface_counters(self, host: str) -> dict:
        """rx/tx bytes and packets of the host's veth end and loopback (``ip -s -j link``)."""
        out = ip('-n', self.namespace(host), '-s', '-j', 'link', 'show').stdout
        return {d['ifname']: d['stats64'] for d in json.loads(out)}

    def routes(self, host: str) -> list[dict]:
        return json.loads(ip('-n', self.namespace(host), '-j', 'route', 'show', 'table', 'all').stdout)

    def links(self, host: str) -> list[str]:
        return [d['ifname'] for d in json.loads(ip('-n', self.namespace(host), '-j', 'link', 'show').stdout)]


@pytest.fixture
def rig_factory(ros_domain_id, tmp_path):
    """``make(discovery='subnet')`` -> a set-up :class:`Rig` (skipped without root locally,
    failed in CI), torn down after the test whatever happens; asserts nothing was left."""
    from rrps_testing.ci import require
    ok, reason = netns_supported()
    require(ok, reason)
    made: list[Rig] = []

    def make(discovery: str = 'subnet') -> Rig:
        rig = Rig(ros_domain_id, discovery=discovery, log_dir=tmp_path)
        made.append(rig)
        rig.__enter__()
        return rig

    try:
        yield make
    finally:
        for rig in made:
            rig.close()
        left = [x for rig in made for x in rig.leftovers()]
        assert not left, f'the rig left behind: {left}'
