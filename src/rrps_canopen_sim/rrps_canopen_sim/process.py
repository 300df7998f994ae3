"""``rrps-drive-sim``: the simulated drives of one robot's CAN bus, in a process of their own, until
SIGTERM or SIGINT; the first line out is ``{"ready": true, ...}``. With ``--rt-priority`` its threads
take SCHED_RR once the devices are built (as permitted; the line says what they got), so that its
start-up (imports, object dictionaries) never runs above a robot's real-time threads. ``--stdin`` takes JSON requests
(:meth:`rrps_canopen_sim.bus.SimulatedBus.control`), one answer line each. Exit status 2 and one
line on a bad robot or bus."""

from __future__ import annotations

import argparse
import json
import signal
import sys
import threading

import can

__all__ = ['main']


def _parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog='rrps-drive-sim', description='Simulated CiA 402 drives (and CiA 401 I/O) '
                                'of one robot\'s CAN bus.')
    p.add_argument('--robot', default='pole_climber', help='shipped robot name or robot YAML path')
    p.add_argument('--master', action='store_true', help="a master robot's drives: torque mode, held by a hand")
    p.add_argument('--lengths', type=float, nargs=6, default=None, metavar='M',
                   help='the legs\' lengths at power-on [m] (default: the home pose)')
    p.add_argument('--time-constant', type=float, default=0.02, help='the legs\' first-order lag [s]')
    p.add_argument('--behaviour', type=json.loads, default=None, metavar='JSON',
                   help='how the drives behave (rrps_canopen_sim.behaviour): options for every drive, or per '
                   'drive under its name')
    p.add_argument('--rt-priority', type=int, default=0, metavar='N',
                   help='SCHED_RR priority of its threads once ready (0: the normal policy); devices with '
                   'processors of their own answer a SYNC within its period')
    p.add_argument('--stdin', action='store_true', help='take requests (JSON lines) on standard input, answer '
                   'on standard output, and stop at the end of the input')
    return p


def _serve(bus, stop: threading.Event) -> None:
    from rrps_runtime.scheduling import name_thread
    name_thread('requests')  # a test's requests, at the normal policy
    for line in sys.stdin:
        line = line.strip()
        if not line:
            continue
        try:
            reply = bus.control(json.loads(line))
        except (ValueError, KeyError, TypeError) as exc:
            reply = {'ok': False, 'error': str(exc)}
        print(json.dumps(reply), flush=True)
    stop.set()


def main(argv=None) -> int:
    args = _parser().parse_args(argv)
    from rrps_canopen_sim.bus import SimulatedBus
    from rrps_description.geometry import load_robot
    from rrps_runtime.collector import freeze_startup_objects
    from rrps_runtime.scheduling import Request, claim, thread_ids
    sys.setswitchinterval(5e-4)  # the bus' receive thread gets the interpreter within a fraction of a period
    stop = threading.Event()
    for sig in (signal.SIGINT, signal.SIGTERM):
        signal.signal(sig, lambda *_: stop.set())
    try:
        request = Request(args.rt_priority)
        geometry = load_robot(args.robot)
        bus = SimulatedBus(geometry, lengths=args.lengths, master=args.master, time_constant=args.time_constant,
                           behaviour=args.behaviour)
    except (ValueError, TypeError, OSError, can.CanError) as exc:
        print(f'rrps-drive-sim: error: {exc}', file=sys.stderr)
        return 2
    freeze_startup_objects()  # the devices' objects, before the first SYNC
    granted = claim(request, thread_ids())
    try:
        print(json.dumps({'ready': True, 'robot': geometry.name, 'nodes': geometry.bus.node_ids(),
                          'scheduling': granted.text()}), flush=True)
        if args.stdin:
            threading.Thread(target=_serve, args=(bus, stop), daemon=True).start()
        while not stop.wait(0.2):
            pass
    finally:
        bus.close()
    return 0


if __name__ == '__main__':
    sys.exit(main())
