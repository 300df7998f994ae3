"""rrps-demo: the whole stack with the web viewer (``./rrps demo``; docs/usage.md, "Installing and running the demo").

Six processes, as on a robot and an operator station (docs/deployment.md): the driver, IK and FK, the climbing node,
master and teleop, the viewer (and the headless script) in this one, and the observers
(:func:`~rrps_bringup.demo_processes.start_recorder`). ``--headless`` runs a scripted session instead of a browser
and exits 0 on success; ``--scenario`` is :mod:`rrps_bringup.scenarios`; ``--hardware canopen`` puts the robot
on simulated CANopen drives (docs/connecting-a-robot.md).
"""

from __future__ import annotations

import os
import shutil
import signal
import subprocess
import sys
import tempfile
import threading
import time
from collections.abc import Mapping

from rrps_bringup.demo_arguments import demo_parser
from rrps_bringup.demo_processes import (
    NAMESPACE,
    OBSERVER_NODES,
    OPERATOR_NODES,
    ROBOT_NODES,
    ROBOT_PROCESSES,
    start_driver,
    start_drives,
    start_operator_nodes,
    start_recorder,
    start_robot_nodes,
)
from rrps_bringup.scenarios import SCENARIOS, scenario

__all__ = ['main', 'build_stack']


def build_stack(context, *, robot: str, host: str, port: int, token: str,
                viewer: bool = True, climb: bool = True, driver: bool = True,
                kinematics: bool = True, teleop: bool = True, driver_rate: float = 500.0,
                namespace: str = NAMESPACE, parameters: Mapping[str, Mapping] | None = None) -> dict:
    """Create nodes of the demo (from :mod:`rrps_bringup.registry`) on ``context`` under ``namespace``; name -> node.

    Every node by default (one process, as the tests use it); the flags leave groups out (the demo runs them in
    processes of their own: :mod:`rrps_bringup.demo_processes`). ``driver_rate`` [Hz]; ``parameters``: node name ->
    {name: value} on top of its parameter file. Raises ValueError / RobotDescriptionError for bad arguments.
    """
    from rclpy.parameter import Parameter

    from rrps_bringup.registry import node_class

    robot_param = [Parameter('robot', value=robot)]
    plan = [('driver_node', robot_param + [Parameter('rate', value=float(driver_rate)),
                                           Parameter('auto_activate', value=True)])
            ] if driver else []
    if kinematics:
        plan += [('ik_node', robot_param), ('fk_node', robot_param)]
    if teleop:
        plan += [('master_node', []), ('teleop_node', robot_param)]
    if climb:
        plan.append(('climb_node', robot_param))
    if viewer:
        plan.append(('viewer_node', robot_param + [
            Parameter('host', value=host), Parameter('port', value=port),
            Parameter('token', value=token)]))
    nodes: dict = {}
    try:
        for name, overrides in plan:
            try:
                cls = node_class(name)
            except (ValueError, ImportError) as exc:
                if name != 'climb_node':
                    raise
                # the climbing node is optional for the teleop part
                print(f'rrps demo: warning: no climb node ({exc}); climbing is unavailable',
                      file=sys.stderr)
                continue
            extra = [Parameter(k, value=list(v) if isinstance(v, tuple) else v)
                     for k, v in (parameters or {}).get(name, {}).items()]
            nodes[name] = cls(context=context, namespace=namespace,
                              parameter_overrides=_with_file(name, overrides + extra))
    except BaseException:
        for node in nodes.values():
            node.destroy_node()
        raise
    return nodes


def scenario_parameters(name: str | None, *nodes: str) -> dict[str, dict]:
    """{node: the parameters of scenario ``name`` that the node declares} (robot apart: the demo
    passes it to every node); empty without a scenario."""
    if name is None:
        return {}
    from rrps_bringup.registry import registered_nodes
    registry, chosen = registered_nodes(), scenario(name)
    out = {}
    for node in nodes:
        params = chosen.parameters(node, registry[node].declared_parameters() if node in registry else None)
        params.pop('robot', None)
        out[node] = params
    return out


def _with_file(node: str, overrides: list) -> list:
    """The node's parameter file, then ``overrides`` (which win)."""
    from rrps_bringup.params import parameter_overrides
    explicit = {p.name for p in overrides}
    return [p for p in parameter_overrides(node) if p.name not in explicit] + list(overrides)


def wait_for_robot(executor, context, node, children: list[subprocess.Popen],
                   stop: threading.Event, *, timeout: float = 60.0) -> bool:
    """Spin until the robot is up, seen from ``node``: the driver's ``actuators/state``, the FK's
    ``pose``, the climbing services and teleop's status. False if a child exits, ``stop`` is set
    or ``timeout`` s pass first."""
    from rclpy.task import Future

    ns = node.get_namespace().rstrip('/')
    never = Future()
    deadline = time.monotonic() + timeout

    def up() -> bool:
        names = {name for name, _ in node.get_service_names_and_types()}
        return (node.count_publishers(f'{ns}/actuators/state') > 0
                and node.count_publishers(f'{ns}/pose') > 0 and f'{ns}/climb/step_up' in names
                and node.count_publishers(f'{ns}/teleop/status') > 0)

    while context.ok() and not stop.is_set() and time.monotonic() < deadline:
        if any(child.poll() is not None for child in children):
            return False
        if up():
            return True
        executor.spin_until_future_complete(never, timeout_sec=0.05)
    return False


def _banner(viewer, driver_scheduling: str, what: str) -> str:
    from rrps_runtime.supervision import CONTROL_RT_PRIORITY
    wanted = f'SCHED_RR {CONTROL_RT_PRIORITY}'
    scheduling = (f'driver and robot nodes at {driver_scheduling}' if driver_scheduling == wanted else
                  f'driver and robot nodes at {driver_scheduling}, not {wanted} (run as root or '
                  'grant CAP_SYS_NICE to give the robot\'s command path real-time priority)')
    return (f'\nrrps demo: {what} is live.\n'
            f'  viewer:         {viewer.url}\n'
            f'  operator token: {viewer.token}\n'
            f'  robot for RViz2/Foxglove: {NAMESPACE}/robot_description (RobotModel), '
            f'{NAMESPACE}/robot/markers (MarkerArray), /tf; fixed frame ring_a\n'
            f'  scheduling:     {scheduling}\n'
            f'  (every browser is read-only until it enters the token; Ctrl-C stops everything)\n')


def _argument_error(args) -> str | None:
    if not 1 <= args.port <= 65535:
        return f'--port must be 1..65535, got {args.port}'
    if args.token and len(args.token) < 8:
        return '--token must have at least 8 characters'
    if args.scenario is not None:
        if args.scenario not in SCENARIOS:
            return f'unknown scenario {args.scenario!r}: one of {", ".join(SCENARIOS)}'
        robot = SCENARIOS[args.scenario].robot
        if args.robot not in (None, robot):
            return f'--scenario {args.scenario} runs the {robot}, not --robot {args.robot}'
        args.robot = robot
    args.robot = args.robot or 'pole_climber'
    return None


def _start_robot(args, run_dir: str):
    """The simulated robot: its driver (active at the first start only; a restarted driver
    resumes the robot's physical state from the state file and waits for activation), its
    computer's nodes, the operator station's master and teleop, and the observers (flight
    recorder, markers). A child that dies is restarted (at most 3 times a minute)."""
    from rrps_runtime.supervision import Respawner

    state_file = os.path.join(run_dir, f'{args.robot}-hardware.json')
    params = scenario_parameters(args.scenario, 'driver_node', *ROBOT_NODES, *OPERATOR_NODES, *OBSERVER_NODES)
    drives = {}
    if args.hardware == 'canopen':  # the drives first: the driver configures them at its start
        from rrps_canopen.loopback_bus import free_port
        os.environ.setdefault('RRPS_CAN_PORT', str(free_port()))
        drives = {'drives': lambda first: start_drives(robot=args.robot)}
    return Respawner({
        **drives,
        'driver': lambda first: start_driver(robot=args.robot, state_file=state_file, activate=first,
                                             hardware=args.hardware, parameters=params),
        **{name: lambda first, nodes=nodes: start_robot_nodes(robot=args.robot, nodes=nodes, parameters=params)
           for name, nodes in ROBOT_PROCESSES.items()},
        'operator nodes': lambda first: start_operator_nodes(robot=args.robot, parameters=params),
        'observer': lambda first: start_recorder(robot=args.robot, output_dir=args.recordings,
                                                 record=args.record, parameters=params),
    })


def _serve(executor, context, robot, stop: threading.Event) -> None:
    """Spin the operator station's nodes until Ctrl-C, reporting (and restarting) dead children."""
    from rclpy.task import Future

    never = Future()
    while context.ok() and not stop.is_set():
        executor.spin_until_future_complete(never, timeout_sec=0.05)
        for name, code, restarted in robot.poll():
            print(f'rrps demo: the {name} process exited (status {code}); '
                  + ('restarted it' + (': activate the driver in the viewer' if name == 'driver' else '')
                     if restarted else 'not restarting it again'), flush=True)
    print('rrps demo: stopping', flush=True)


def _run_script(script, executor, context, robot, stop: threading.Event, viewer) -> int:
    """The headless demo: run the scripted session while another thread spins; 0 if it passed."""
    from rrps_runtime.command_path import claim_spinning_thread
    from rrps_runtime.process import spin_until_shutdown

    def spin() -> None:
        claim_spinning_thread()  # the operator station's command path spins here now
        spin_until_shutdown(executor, context, stop, period=0.02)
    spinner = threading.Thread(target=spin, daemon=True)
    spinner.start()
    try:
        ok = script.run(stop, viewer=viewer)
    finally:
        stop.set()
        # Wait until the executor stopped spinning (it checks ``stop`` every 20 ms, later on a
        # loaded machine): destroying nodes under a spinning EventsExecutor crashes the process.
        spinner.join()
    failed = [c for c in robot.children.values() if c.poll() is not None]
    return 0 if ok and not failed else 1


def _script(args, context):
    """The scripted operator of ``--headless`` (the scenario's with ``--scenario``), or None."""
    if not args.headless:
        return None
    if args.scenario is not None and scenario(args.scenario).junction_deg > 0.0:
        from rrps_bringup.frame_script import FrameScript
        return FrameScript(scenario(args.scenario), context=context, namespace=NAMESPACE)
    if args.scenario is not None:
        from rrps_bringup.scenario_script import ScenarioScript
        return ScenarioScript(scenario(args.scenario), hardware=args.hardware, context=context, namespace=NAMESPACE)
    from rrps_bringup.headless import DemoScript
    return DemoScript(context=context, namespace=NAMESPACE)


def main(argv=None) -> int:
    args = demo_parser().parse_args(argv)
    os.environ.setdefault('ROS_AUTOMATIC_DISCOVERY_RANGE', 'LOCALHOST')
    error = _argument_error(args)
    if error is not None:
        print(f'error: {error}', file=sys.stderr)
        return 2

    import rclpy
    from rclpy.executors import ExternalShutdownException
    from rclpy.signals import SignalHandlerOptions

    from rrps_description.geometry import RobotDescriptionError
    from rrps_runtime.collector import freeze_startup_objects, thaw
    from rrps_runtime.command_path import claim_command_path
    from rrps_runtime.process import make_executor
    from rrps_runtime.supervision import (
        OPERATOR_NICE,
        Respawner,
        exit_with_parent,
        raise_priority,
        scheduling_of,
    )

    stop = threading.Event()
    exit_with_parent(stop.set)
    # the operator station: before other jobs (the browser); its command path (master, teleop)
    # claims its real-time priority once its nodes are up, after the robot's
    raise_priority(OPERATOR_NICE)
    context = rclpy.Context()
    rclpy.init(context=context, signal_handler_options=SignalHandlerOptions.NO)
    previous = {sig: signal.signal(sig, lambda *_: stop.set())
                for sig in (signal.SIGINT, signal.SIGTERM)}
    nodes: dict = {}
    robot: Respawner | None = None
    run_dir = tempfile.mkdtemp(prefix='rrps-demo-')
    status = 0
    try:
        try:
            nodes = build_stack(context, robot=args.robot, host=args.host, port=args.port,
                                token=args.token, viewer=True, driver=False, kinematics=False,
                                climb=False, teleop=False, parameters=scenario_parameters(args.scenario, 'viewer_node'))
        except (RobotDescriptionError, ValueError) as exc:
            print(f'error: {exc}', file=sys.stderr)
            return 2
        robot = _start_robot(args, run_dir)
        script = _script(args, context)
        if script is not None:
            nodes['demo_script'] = script
        executor = make_executor(context, 'events')
        for node in nodes.values():
            executor.add_node(node)
        freeze_startup_objects()
        claim_command_path(list(nodes.values()), executor)
        if not wait_for_robot(executor, context, nodes['viewer_node'],
                              list(robot.children.values()), stop):
            if not stop.is_set() or robot.poll():
                print('error: the simulated robot did not start', file=sys.stderr)
                status = 1
            return status
        if script is None:
            what = (f'scenario {args.scenario} ({SCENARIOS[args.scenario].summary})' if args.scenario
                    else f'the {args.robot.replace("_", " ")}')
            print(_banner(nodes['viewer_node'], scheduling_of(robot.children['driver'].pid), what), flush=True)
            _serve(executor, context, robot, stop)
        else:
            status = _run_script(script, executor, context, robot, stop, nodes['viewer_node'])
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    finally:
        if robot is not None:  # they stop while this process tears its own nodes down
            robot.terminate()
        for sig, handler in previous.items():
            signal.signal(sig, handler)
        for node in nodes.values():
            node.destroy_node()
        rclpy.try_shutdown(context=context)
        thaw()
        if robot is not None:
            for name, code in zip(robot.children, robot.stop()):
                if code != 0:   # killed after the timeout, or a shutdown that failed
                    print(f'rrps demo: the {name} process ended with status {code} when stopped', file=sys.stderr)
        shutil.rmtree(run_dir, ignore_errors=True)
    return status


if __name__ == '__main__':
    sys.exit(main())
