"""rrps-demo: the whole stack in one process, with the web viewer (``./rrps demo``).

Composes the IK, FK, master, teleop, climb and viewer nodes under the namespace ``/rrps`` in one
process and one executor (like a component container) and runs the simulated hardware
(driver_node, 500 Hz) in a process of its own, as a real robot's driver would be. Prints the
viewer's URL and operator token, and runs until Ctrl-C (or SIGTERM), which stops everything
cleanly.

``--headless`` runs no browser: a scripted teleop session (the operator's handle moves the
master, a deadman stream engages the mapping, the slave follows; releasing the deadman holds the
robot) and a scripted climb (one step up through ``climb/step_up``), prints what happened and
exits 0 on success, 1 on failure: a smoke test for CI and users.

DDS stays on this machine: ``ROS_AUTOMATIC_DISCOVERY_RANGE`` defaults to LOCALHOST.
"""

from __future__ import annotations

import argparse
import os
import signal
import subprocess
import sys
import threading
import time

__all__ = ['main', 'build_stack', 'start_driver', 'stop_driver']

NAMESPACE = '/rrps'


def _parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(
        prog='rrps-demo', description='Run the rrps stack (driver, IK, FK, master, teleop, climb, '
                                      'viewer) in one process, with the web viewer.')
    p.add_argument('--host', default='127.0.0.1',
                   help='address the viewer binds (default 127.0.0.1; 0.0.0.0 for remote operators)')
    p.add_argument('--port', type=int, default=8080, help='viewer port (default 8080)')
    p.add_argument('--token', default='',
                   help='operator token (default: a random one, printed at start-up)')
    p.add_argument('--robot', default='pole_climber',
                   help='shipped robot name or robot YAML path (default pole_climber)')
    p.add_argument('--headless', action='store_true',
                   help='no browser: run a scripted teleop session and a climb step, then exit '
                        '(0 = success)')
    return p


def build_stack(context, *, robot: str, host: str, port: int, token: str,
                viewer: bool = True, climb: bool = True, driver: bool = True,
                driver_rate: float = 500.0, namespace: str = NAMESPACE) -> dict:
    """Create every node of the demo on ``context`` under ``namespace``; returns name -> node.

    ``viewer=False`` / ``climb=False`` / ``driver=False`` leave the viewer / climbing node /
    simulated driver out (the demo runs its driver in a process of its own: :func:`start_driver`);
    ``driver_rate`` is the simulated driver's actuators/state rate [Hz].

    Raises ValueError / RobotDescriptionError with a clear message for bad arguments.
    """
    from rclpy.parameter import Parameter

    from rrps_kinematics.nodes.fk_node import FkNode
    from rrps_kinematics.nodes.ik_node import IkNode
    from rrps_sim.nodes.driver_node import DriverNode

    from .nodes.master_node import MasterNode
    from .nodes.teleop_node import TeleopNode

    robot_param = [Parameter('robot', value=robot)]
    plan = [('driver_node', DriverNode, robot_param + [Parameter('rate', value=float(driver_rate))])
            ] if driver else []
    plan += [
        ('ik_node', IkNode, robot_param),
        ('fk_node', FkNode, robot_param),
        ('master_node', MasterNode, []),
        ('teleop_node', TeleopNode, robot_param),
    ]
    if climb:
        try:
            from .nodes.climb_node import ClimbNode
        except ImportError as exc:  # the climbing node is optional for the teleop part
            print(f'rrps demo: warning: no climb node ({exc}); climbing is unavailable',
                  file=sys.stderr)
        else:
            plan.append(('climb_node', ClimbNode, robot_param))
    if viewer:
        from .nodes.viewer_node import ViewerNode
        plan.append(('viewer_node', ViewerNode, robot_param + [
            Parameter('host', value=host), Parameter('port', value=port),
            Parameter('token', value=token)]))
    nodes: dict = {}
    try:
        for name, cls, overrides in plan:
            nodes[name] = cls(context=context, namespace=namespace, parameter_overrides=overrides)
    except BaseException:
        for node in nodes.values():
            node.destroy_node()
        raise
    return nodes


def start_driver(*, robot: str, rate: float = 500.0, namespace: str = NAMESPACE) -> subprocess.Popen:
    """The simulated hardware (driver_node) in a process of its own, as a real robot's driver.

    Its 500 Hz loop then has an interpreter and a core to itself instead of sharing one GIL with
    the viewer's web server and the rest of the stack. It inherits the environment (domain id,
    discovery range); stop it with :func:`stop_driver`.
    """
    return subprocess.Popen([sys.executable, '-m', 'rrps_sim.nodes.driver_node', '--ros-args',
                             '-r', f'__ns:={namespace}', '-p', f'robot:={robot}',
                             '-p', f'rate:={float(rate)}'])


def stop_driver(process: subprocess.Popen, timeout: float = 5.0) -> None:
    """SIGTERM, then kill if it has not stopped after ``timeout`` s.

    SIGTERM (not SIGINT): once the driver runs it is its clean shutdown, like Ctrl-C, and before
    its handlers exist (still importing) it ends the process without a traceback.
    """
    if process.poll() is None:
        process.send_signal(signal.SIGTERM)
        try:
            process.wait(timeout)
        except subprocess.TimeoutExpired:
            process.kill()
            process.wait()


def wait_for_driver(executor, context, node, driver: subprocess.Popen, stop: threading.Event, *,
                    timeout: float = 60.0) -> bool:
    """Spin until the driver's ``actuators/state`` publisher is seen from ``node`` (it is up);
    False if the driver exits, ``stop`` is set or ``timeout`` s pass first."""
    from rclpy.task import Future

    topic = f'{node.get_namespace().rstrip("/")}/actuators/state'
    never = Future()
    deadline = time.monotonic() + timeout
    while context.ok() and not stop.is_set() and driver.poll() is None and time.monotonic() < deadline:
        if node.count_publishers(topic) > 0:
            return True
        executor.spin_until_future_complete(never, timeout_sec=0.05)
    return False


def _banner(viewer) -> str:
    return (f'\nrrps demo: the pole climber is live.\n'
            f'  viewer:         {viewer.url}\n'
            f'  operator token: {viewer.token}\n'
            f'  (every browser is read-only until it enters the token; Ctrl-C stops everything)\n')


def main(argv=None) -> int:
    args = _parser().parse_args(argv)
    os.environ.setdefault('ROS_AUTOMATIC_DISCOVERY_RANGE', 'LOCALHOST')
    if not 1 <= args.port <= 65535:
        print(f'error: --port must be 1..65535, got {args.port}', file=sys.stderr)
        return 2
    if args.token and len(args.token) < 8:
        print('error: --token must have at least 8 characters', file=sys.stderr)
        return 2

    import rclpy
    from rclpy.executors import ExternalShutdownException
    from rclpy.signals import SignalHandlerOptions

    from rrps_kinematics.geometry import RobotDescriptionError
    from rrps_kinematics.nodes.common import make_executor, spin_until_shutdown

    stop = threading.Event()
    context = rclpy.Context()
    rclpy.init(context=context, signal_handler_options=SignalHandlerOptions.NO)
    previous = {sig: signal.signal(sig, lambda *_: stop.set())
                for sig in (signal.SIGINT, signal.SIGTERM)}
    nodes: dict = {}
    driver = None
    status = 0
    try:
        try:
            nodes = build_stack(context, robot=args.robot, host=args.host, port=args.port,
                                token=args.token, viewer=True, driver=False)
        except (RobotDescriptionError, ValueError) as exc:
            print(f'error: {exc}', file=sys.stderr)
            return 2
        driver = start_driver(robot=args.robot)
        # A driver that dies ends the demo (the robot is gone), with an error status.
        threading.Thread(target=lambda: (driver.wait(), stop.set()), daemon=True).start()
        script = None
        if args.headless:
            from ._demo_script import DemoScript
            script = DemoScript(context=context, namespace=NAMESPACE)
            nodes['demo_script'] = script
        executor = make_executor(context, 'events')
        for node in nodes.values():
            executor.add_node(node)
        if not wait_for_driver(executor, context, nodes['fk_node'], driver, stop):
            if not stop.is_set():
                print('error: the simulated driver did not start', file=sys.stderr)
                status = 1
            return status
        if script is None:
            print(_banner(nodes['viewer_node']), flush=True)
            spin_until_shutdown(executor, context, stop)
            print('rrps demo: stopping', flush=True)
        else:
            spinner = threading.Thread(target=spin_until_shutdown,
                                       args=(executor, context, stop), kwargs={'period': 0.02},
                                       daemon=True)
            spinner.start()
            try:
                ok = script.run(stop, viewer=nodes['viewer_node'])
            finally:
                stop.set()
                spinner.join(timeout=5.0)
            status = 0 if ok else 1
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    finally:
        for sig, handler in previous.items():
            signal.signal(sig, handler)
        for node in nodes.values():
            node.destroy_node()
        rclpy.try_shutdown(context=context)
        if driver is not None:
            if driver.poll() not in (None, 0):
                print(f'rrps demo: the driver process exited with status {driver.returncode}',
                      file=sys.stderr)
                status = status or 1
            stop_driver(driver)
    return status


if __name__ == '__main__':
    sys.exit(main())
