"""The viewer in headless Chromium, used like a person would (playwright-core, tests/browser/).

The whole demo stack runs in-process on a private ROS domain. One browser page stays a read-only
viewer; a second enters the token, takes control, engages and holds the deadman button while
the master robot moves: the slave follows over ROS. The read-only page cannot move anything, and
the gripper interlock's refusal is shown to the operator.
"""

from __future__ import annotations

import json
import os
import shutil
import socket
import subprocess
import time
from pathlib import Path

import numpy as np
import pytest

from ros_harness import Probe, Spinner, wait_for
from conftest import require

pytestmark = [pytest.mark.browser, pytest.mark.ros, pytest.mark.slow]

BROWSER_DIR = Path(__file__).parent / 'browser'
CHROMIUM = os.environ.get('CHROMIUM', '/usr/bin/chromium')
TOKEN = 'browser-test-token'


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(('127.0.0.1', 0))
        return s.getsockname()[1]


@pytest.fixture(scope='module')
def playwright_dir() -> Path:
    """tests/browser with playwright-core installed (npm ci from the lock file if missing)."""
    require(Path(CHROMIUM).exists(), f'no Chromium at {CHROMIUM} (./rrps test installs Debian\'s chromium as root)')
    require(shutil.which('npm') is not None and shutil.which('node') is not None, 'node and npm are needed for playwright-core')
    if not (BROWSER_DIR / 'node_modules' / 'playwright-core').exists():
        subprocess.run(['npm', 'ci', '--no-audit', '--no-fund'], cwd=BROWSER_DIR, check=True,
                       stdout=subprocess.DEVNULL, timeout=300)
    return BROWSER_DIR


class Browser:
    """drive.js as a subprocess: yields its sync points, returns its final result."""

    def __init__(self, url: str, steps: list[dict]):
        self.proc = subprocess.Popen(['node', 'drive.js', url, json.dumps(steps)], cwd=BROWSER_DIR,
                                     stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True,
                                     env={**os.environ, 'CHROMIUM': CHROMIUM})

    def events(self):
        for line in self.proc.stdout:
            msg = json.loads(line)
            if 'sync' in msg:
                yield msg['sync']
            else:
                self.result = msg
                return

    def resume(self) -> None:
        self.proc.stdin.write('go\n')
        self.proc.stdin.flush()

    def close(self) -> None:
        if self.proc.poll() is None:
            self.proc.kill()
        self.proc.wait(timeout=10)


def _changed_pixels(a: Path, b: Path) -> tuple[int, tuple[int, int, int, int] | None]:
    from PIL import Image
    x = np.asarray(Image.open(a).convert('RGB'), dtype=int)
    y = np.asarray(Image.open(b).convert('RGB'), dtype=int)
    changed = np.abs(x - y).max(axis=2) > 40
    if not changed.any():
        return 0, None
    rows, cols = np.nonzero(changed)
    return int(changed.sum()), (int(cols.min()), int(rows.min()), int(cols.max()), int(rows.max()))


def test_operator_drives_the_robot_from_the_browser_and_a_viewer_cannot(
        ros_context, playwright_dir, tmp_path):
    from diagnostic_msgs.msg import DiagnosticStatus
    from geometry_msgs.msg import PoseStamped
    from rclpy.parameter import Parameter
    from sensor_msgs.msg import JointState
    from std_msgs.msg import Bool

    from rrps_kinematics.nodes.common import COMMAND_QOS, pose_from_msg
    from rrps_teleop.demo import build_stack

    port = _free_port()
    nodes = build_stack(ros_context, robot='pole_climber', host='127.0.0.1', port=port,
                        token=TOKEN, driver_rate=100.0)
    viewer = nodes['viewer_node']
    probe = Probe(context=ros_context, namespace='/rrps')
    poses = probe.collect(PoseStamped, 'pose', stamped=True)
    enables = probe.collect(Bool, 'teleop/enable', qos=COMMAND_QOS, stamped=True)
    grippers = probe.collect(JointState, 'grippers/state')
    climb_status = probe.collect(DiagnosticStatus, 'climb/status')
    shots = {name: tmp_path / f'{name}.png' for name in ('robot', 'hidden', 'operator')}
    steps = [
        {'page': 1, 'wait_text': 'Read-only viewer'},
        {'page': 1, 'wait_text': 'Latency: state'},
        {'page': 1, 'sleep': 1500},
        {'page': 1, 'screenshot': str(shots['robot'])},
        {'page': 1, 'sync': 'hide robot'},
        {'page': 1, 'sleep': 1500},
        {'page': 1, 'screenshot': str(shots['hidden'])},
        {'page': 1, 'sync': 'show robot'},
        {'page': 2, 'wait_text': 'Read-only viewer'},
        {'page': 2, 'fill': 'Token', 'value': TOKEN},
        {'page': 2, 'click': 'Enter token'},
        {'page': 2, 'wait_text': 'Token accepted'},
        {'page': 2, 'click': 'Take control'},
        {'page': 2, 'wait_text': 'You have control'},
        {'page': 2, 'check': 'Engage (clutch)'},
        {'page': 2, 'sync': 'before hold'},
        {'page': 2, 'hold': 'Hold to move (deadman)', 'ms': 2500},
        {'page': 2, 'sync': 'after hold'},
        {'page': 1, 'fill': 'Token', 'value': 'not-the-token'},
        {'page': 1, 'click': 'Enter token'},
        {'page': 1, 'wait_text': 'wrong token'},
        {'page': 1, 'disabled': 'Hold to move (deadman)'},
        {'page': 1, 'disabled': 'Climb one step up'},
        {'page': 1, 'disabled': 'Open ring_b'},
        {'page': 1, 'hold': 'Hold to move (deadman)', 'ms': 1000},
        {'page': 1, 'click': 'Open ring_b', 'force': True},
        {'page': 1, 'sync': 'intruder done'},
        {'page': 2, 'click': 'Open ring_b'},
        {'page': 2, 'wait_text': 'open ring_b:'},
        {'page': 2, 'click': 'Open ring_a'},
        {'page': 2, 'wait_text': 'open ring_a:'},
        {'page': 2, 'screenshot': str(shots['operator'])},
        {'page': 2, 'text': True},
        {'page': 2, 'click': 'Close ring_b'},
        {'page': 2, 'wait_text': 'close ring_b:'},
        {'page': 2, 'sync': 'before climb'},
        {'page': 2, 'click': 'Climb one step up'},
        {'page': 2, 'wait_text': 'climb step up: started'},
        {'page': 2, 'sync': 'climbing'},
    ]
    robot_nodes = [h for name, h in viewer.viewer.nodes.items() if name.startswith('/robot/')]
    marks: dict[str, float] = {}
    with Spinner(ros_context, [*nodes.values(), probe]):
        assert wait_for(lambda: poses, timeout=10.0), 'no FK pose from the stack'
        browser = Browser(f'http://127.0.0.1:{viewer.viewer.port}', steps)
        try:
            for sync in browser.events():
                marks[sync] = time.monotonic()
                if sync == 'hide robot':
                    for handle in robot_nodes:
                        handle.visible = False
                elif sync == 'show robot':
                    for handle in robot_nodes:
                        handle.visible = True
                elif sync == 'before hold':
                    assert viewer.control.controller is not None
                    nodes['master_node'].set_parameters([Parameter('trajectory', value='circle')])
                    time.sleep(0.3)
                    start = pose_from_msg(poses[-1][1])[0]
                elif sync == 'after hold':
                    time.sleep(0.3)  # the deadman expires, the mapping disengages
                    moved = np.linalg.norm(pose_from_msg(poses[-1][1])[0] - start)
                    held_at = pose_from_msg(poses[-1][1])[0]
                elif sync == 'before climb':
                    assert wait_for(lambda: list(grippers[-1].position) == [1.0, 1.0], 3.0)
                elif sync == 'climbing':
                    # The click started a climb step: over ROS it executes and the robot moves.
                    climbing = wait_for(lambda: climb_status and
                                        climb_status[-1].message == 'executing', timeout=5.0)
                    before = pose_from_msg(poses[-1][1])[0]
                    climb_moved = wait_for(
                        lambda: np.linalg.norm(pose_from_msg(poses[-1][1])[0] - before) > 0.005,
                        timeout=15.0)
                browser.resume()
        finally:
            browser.close()
        result = browser.result
        print('browser steps [ms since start]:',
              [(next(iter(r.items()))[1], r.get('ms')) for r in result['results']
               if 'text' not in r])
        if not result['ok']:
            pytest.fail(f"browser: {result['error']} after {result['results'][-3:]}")

    # The robot is drawn: hiding its scene nodes changes the picture in the 3-D view.
    count, box = _changed_pixels(shots['robot'], shots['hidden'])
    assert count > 2000, f'only {count} pixels changed when the robot was hidden'
    assert box[2] < 860 - 330, f'changes outside the 3-D view: {box}'  # the panel is on the right
    names = set(viewer.viewer.nodes)
    assert {'/robot/ring_a', '/robot/ring_b', '/robot/legs', '/ghost/ring_b',
            '/master/legs', '/trail/ring_a'} <= names
    legs = np.asarray(viewer.viewer.nodes['/robot/legs'].points)
    lengths = np.linalg.norm(legs[:, 1] - legs[:, 0], axis=1)
    assert np.all((lengths > 0.3) & (lengths < 0.55)), lengths

    # The operator's real press-and-hold streamed the deadman and moved the robot. (On this
    # 2-core machine two software-rendered pages can delay the browser's hold events; a gap
    # longer than deadman_timeout drops the deadman, which is the safe side, so only a lower
    # bound on the samples is asserted.)
    held = [t for t, m in enables if m.data and marks['before hold'] <= t <= marks['after hold']]
    assert len(held) >= 5, f'{len(held)} enable samples during a 2.5 s hold'
    assert moved > 0.002, f'the slave moved only {moved * 1e3:.2f} mm while the deadman was held'
    # The read-only viewer could not move anything: no enable, no motion, grippers unchanged.
    intruder = [m for t, m in enables
                if marks['after hold'] + 0.5 <= t <= marks['intruder done'] and m.data]
    assert not intruder
    drift = max(np.linalg.norm(pose_from_msg(m)[0] - held_at)
                for t, m in poses if marks['after hold'] + 0.5 <= t <= marks['intruder done'])
    assert drift < 1e-3, f'robot moved {drift * 1e3:.2f} mm while only the viewer acted'
    disabled = {r['disabled']: r['value'] for r in result['results'] if 'disabled' in r}
    assert all(disabled.values()), disabled
    text = next(r['text'] for r in result['results'] if 'text' in r)
    assert '⛔ open ring_a:' in text  # the interlock's refusal is shown to the operator
    assert not any(list(m.position) == [0.0, 0.0] for m in grippers), 'both grippers opened'
    assert any(list(m.position) == [1.0, 0.0] for m in grippers), 'ring_b never opened'
    assert climbing, 'Climb one step up did not start a climb step'
    assert climb_moved, 'the robot did not move during the climb step'
    keep = os.environ.get('RRPS_SCREENSHOT_DIR')  # e.g. to look at the pictures
    for name, path in shots.items():
        if keep:
            shutil.copy(path, Path(keep) / f'rrps_viewer_{name}.png')
