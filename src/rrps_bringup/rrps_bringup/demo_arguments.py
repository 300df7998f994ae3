"""rrps-demo's command line, on the standard library alone: ``./rrps demo --help`` answers from
the sources before anything is installed (the demo itself: :mod:`rrps_bringup.demo`)."""

from __future__ import annotations

import argparse
import sys

__all__ = ['demo_parser', 'SCENARIO_NAMES']

#: The scenarios of :data:`rrps_bringup.scenarios.SCENARIOS`, by name (its unit test keeps them equal).
SCENARIO_NAMES = ('facade_wall', 'pole_leaning', 'frame_node')


def demo_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(
        prog='rrps-demo', description='Run the whole rrps stack with the web viewer, in six supervised '
                                      'processes: the driver; IK and FK, and climb (the robot computer); '
                                      'master and teleop, and the viewer (the operator station); recorder '
                                      'and markers (observers).')
    p.add_argument('--host', default='127.0.0.1',
                   help='address the viewer binds (default 127.0.0.1; 0.0.0.0 for remote operators)')
    p.add_argument('--port', type=int, default=8080, help='viewer port (default 8080)')
    p.add_argument('--token', default='',
                   help='operator token (default: a random one, printed at start-up)')
    p.add_argument('--robot', default=None,
                   help="shipped robot name or robot YAML path (default pole_climber, or the scenario's)")
    p.add_argument('--scenario', default=None,
                   help='a robot on its structure in the world with a payload: '
                        f'{" | ".join(SCENARIO_NAMES)} (with --headless: a scripted load scenario)')
    p.add_argument('--headless', action='store_true',
                   help='no browser: run a scripted teleop session and a climb step, then exit '
                        '(0 = success)')
    p.add_argument('--recordings', default='rrps_recordings',
                   help='folder of the flight recorder\'s files (and of --record)')
    p.add_argument('--record', action='store_true',
                   help='also record the whole session to MCAP in --recordings')
    p.add_argument('--hardware', choices=('simulated', 'canopen'), default='simulated',
                   help="the driver's hardware: simulated, or canopen (simulated CiA 402 drives on a loopback "
                        'CAN bus; default simulated)')
    return p


if __name__ == '__main__':
    demo_parser().parse_args(sys.argv[1:])
