"""Simulated CANopen drives and the CANopen driver as real processes, for tests and benchmarks.

:class:`DriveSim` runs ``rrps-drive-sim`` and talks to it through its JSON lines; :func:`driver_process` starts
driver_node with ``hardware:=canopen``; :func:`canopen_hardware` puts a robot's CANopen hardware on a simulator's
bus in this process. Each rig has a loopback bus of its own (``RRPS_CAN_PORT``); its processes die with their parent.
"""

from __future__ import annotations

import json
import os
import queue
import subprocess
import sys
import threading
import time
from contextlib import contextmanager
from pathlib import Path
from typing import Callable, Iterator

import numpy as np
import yaml

from rrps_canopen.loopback_bus import free_port
from rrps_canopen.robot import CanopenRobot
from rrps_description.geometry import robot_path
from rrps_hardware.interface import Command
from rrps_runtime.supervision import CONTROL_NICE, CONTROL_RT_PRIORITY, start_child, stop_child

__all__ = ['free_port', 'DriveSim', 'driver_process', 'can_env', 'cycle_to', 'canopen_hardware', 'robot_yaml',
           'SIM_RT_PRIORITY', 'UNHURRIED_BUS']

#: Bus keys for tests that are not about heartbeats: a loaded machine must not lose one in them.
UNHURRIED_BUS = {'heartbeat_period': 0.05, 'heartbeat_timeout': 0.5}
#: [s] how long a request to the simulator may take on a busy machine.
ANSWER_TIMEOUT = 30.0
#: SCHED_RR priority of the drive simulator: above the robot's command path, as real drives are
#: hardware of their own that the driver's computer cannot starve. The kernel's RT bandwidth limit
#: still stops it for about 50 ms at times; its heartbeats stay ahead of its PDOs then
#: (rrps_canopen_sim.heartbeat; docs/measurements.md: CANopen).
SIM_RT_PRIORITY = CONTROL_RT_PRIORITY + 10


def can_env(port: int, **extra: str) -> dict:
    """The environment of a process on the rig's bus (and DDS on this machine)."""
    return dict(os.environ, RRPS_CAN_PORT=str(port), ROS_AUTOMATIC_DISCOVERY_RANGE='LOCALHOST', PYTHONUNBUFFERED='1',
                **extra)


class DriveSim:
    """``rrps-drive-sim`` in a process of its own (its drives behaving as ``behaviour`` says:
    rrps_canopen_sim.behaviour); ``ask`` sends one request, returns the answer. ``cpus``: the CPUs its
    threads may run on once it is ready (a benchmark pins the simulated drives, devices with processors
    of their own, apart from the robot computer's measured processes)."""

    def __init__(self, robot: str = 'pole_climber', *, port: int | None = None, master: bool = False,
                 lengths=None, time_constant: float | None = None, behaviour: dict | None = None,
                 cpus: tuple[int, ...] = ()):
        self.port = free_port() if port is None else port
        args = [sys.executable, '-m', 'rrps_canopen_sim.process', '--robot', robot, '--stdin',
                '--rt-priority', str(SIM_RT_PRIORITY)]
        args += ['--master'] if master else []
        args += ['--lengths', *map(str, lengths)] if lengths is not None else []
        args += ['--time-constant', str(time_constant)] if time_constant is not None else []
        args += ['--behaviour', json.dumps(behaviour)] if behaviour else []
        self.process = start_child(args, env=can_env(self.port), nice=CONTROL_NICE,
                                   stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        self._lines: queue.Queue[str | None] = queue.Queue()
        threading.Thread(target=self._read, daemon=True).start()
        self.ready = self._next()
        if not self.ready.get('ready'):
            self.stop()
            raise RuntimeError(f'rrps-drive-sim did not start: {self.ready}')
        if cpus:  # its threads all exist now; those it starts later inherit the set
            for tid in os.listdir(f'/proc/{self.process.pid}/task'):
                os.sched_setaffinity(int(tid), set(cpus))

    def _read(self) -> None:
        for line in self.process.stdout:
            self._lines.put(line)
        self._lines.put(None)

    def _next(self) -> dict:
        try:
            line = self._lines.get(timeout=ANSWER_TIMEOUT)
        except queue.Empty:
            return {'ok': False, 'error': 'no answer'}
        if line is None:
            return {'ok': False, 'error': f'exited: {self.process.poll()}: {self.process.stderr.read()[-2000:]}'}
        return json.loads(line)

    def ask(self, **request) -> dict:
        self.process.stdin.write(json.dumps(request) + '\n')
        self.process.stdin.flush()
        answer = self._next()
        if not answer.get('ok'):
            raise RuntimeError(f'rrps-drive-sim refused {request}: {answer}')
        return answer

    def status(self) -> dict:
        return self.ask(cmd='status')

    def positions(self) -> np.ndarray:
        """The simulated legs' lengths [m] now."""
        return np.array([d['position'] for d in self.status()['drives'].values()])

    def fault(self, drive: str, kind: str) -> float:
        """Inject a fault; the simulator's monotonic time of it."""
        return self.ask(cmd='fault', drive=drive, kind=kind)['time']

    def stop(self) -> int:
        if self.process.stdin and not self.process.stdin.closed:
            try:
                self.process.stdin.close()
            except OSError:
                pass
        return stop_child(self.process)

    def __enter__(self) -> 'DriveSim':
        return self

    def __exit__(self, *exc_info) -> None:
        self.stop()


def driver_process(port: int, *params: str, robot: str = 'pole_climber', namespace: str = '/rrps_test',
                   domain_id: int | None = None, hardware: str = 'canopen') -> subprocess.Popen:
    """driver_node with ``hardware`` (canopen: on the rig's bus); ``params``: more ``name:=value``."""
    args = [sys.executable, '-m', 'rrps_hardware.nodes.driver_node', '--ros-args', '-r', f'__ns:={namespace}',
            '-p', f'robot:={robot}', '-p', f'hardware:={hardware}']
    for p in params:
        args += ['-p', p]
    env = can_env(port, **({'ROS_DOMAIN_ID': str(domain_id)} if domain_id is not None else {}))
    return start_child(args, env=env, nice=CONTROL_NICE, stdout=subprocess.PIPE,  # it claims its cycle's priority
                       stderr=subprocess.PIPE, text=True)


@contextmanager
def canopen_hardware(sim: DriveSim) -> Iterator[CanopenRobot]:
    """The CANopen hardware of the simulator's robot, on its bus, in this process (the caller
    configures and activates it); shut down on exit."""
    before = os.environ.get('RRPS_CAN_PORT')
    os.environ['RRPS_CAN_PORT'] = str(sim.port)
    hardware = CanopenRobot()
    try:
        yield hardware
    finally:
        hardware.on_shutdown()
        if before is None:
            del os.environ['RRPS_CAN_PORT']
        else:
            os.environ['RRPS_CAN_PORT'] = before


def cycle_to(hardware: CanopenRobot, goal, *, period: float = 0.002, timeout: float = 30.0,
             arrived: Callable[[], bool]) -> bool:
    """Run the driver's cycle on ``hardware`` (write one command, the same each period, as the
    driver does until another arrives) until ``arrived()`` or ``timeout`` s; whether it arrived.
    The bus' SYNC cycle steps the jerk-limited setpoints towards it."""
    command, start = Command(np.asarray(goal, dtype=float)), time.monotonic()
    while time.monotonic() - start < timeout:
        result = hardware.write(time.monotonic(), period, command)
        assert result.ok, result.message
        if arrived():
            return True
        time.sleep(period)
    return False


def robot_yaml(path: Path, robot: str = 'pole_climber', *, bus: dict | None = None, drive_defaults: dict | None = None,
               drives: dict | None = None) -> str:
    """``robot`` with its bus section's keys, drive defaults and drives (by leg) updated, written to
    ``path``; the path as a string."""
    data = yaml.safe_load(robot_path(robot).read_text())
    data['bus'].update(bus or {})
    data['bus']['drive_defaults'].update(drive_defaults or {})
    for leg, keys in (drives or {}).items():
        data['bus']['drives'][leg].update(keys)
    Path(path).write_text(yaml.safe_dump(data))
    return str(path)
