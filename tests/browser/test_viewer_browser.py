"""The viewer in headless Chromium, used like a person would (playwright-core, tests/browser/).

The whole demo stack runs in-process on a private ROS domain. A first browser page, a read-only
viewer, shows the robot; a second enters the token, takes control, engages and holds the deadman
button while the master robot moves: the slave follows over ROS. A read-only page opened while
the operator has control cannot move anything, and the gripper interlock's refusal is shown to
the operator. (Pages are open only while they are used: each software-rendered 3-D page costs
a loaded 2-core machine much of a core.)

Nothing waits for a fixed time: drive.js waits for what the page shows (generous deadlines) and
hands over to the test at sync points, where the test waits for what happened over ROS (the
slave moved, the mapping disengaged, the robot stands still) before the browser goes on.
"""

from __future__ import annotations

import contextlib
import json
import os
import shutil
import signal
import subprocess
import time
from pathlib import Path

import numpy as np
import pytest

from rrps_testing.climb_resume import Resumer
from rrps_testing.processes import free_port
from rrps_testing.ros_harness import DEADLINE, Probe, Spinner, wait_for

pytestmark = [pytest.mark.browser, pytest.mark.ros, pytest.mark.slow]

BROWSER_DIR = Path(__file__).parent
CHROMIUM = os.environ.get('CHROMIUM', '/usr/bin/chromium')
TOKEN = 'browser-test-token'


class Browser:
    """drive.js as a subprocess: yields its sync points, returns its final result. Its browser
    keeps its profile and artifacts in ``tmp`` (the ``browser_tmpdir`` fixture's, removed after the
    test); :meth:`close` stops every process it started."""

    def __init__(self, url: str, steps: list[dict], tmp: str):
        self.proc = subprocess.Popen(['node', 'drive.js', url, json.dumps(steps)], cwd=BROWSER_DIR,
                                     stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True,
                                     start_new_session=True,
                                     env={**os.environ, 'CHROMIUM': CHROMIUM, 'TMPDIR': tmp})

    def events(self):
        for line in self.proc.stdout:
            msg = json.loads(line)
            if 'sync' in msg:
                yield msg['sync']
            else:
                self.result = msg
                return

    def resume(self, reply: str = 'go') -> None:
        """Let drive.js go on (or, after a screenshot step with a sync, take another: 'again')."""
        self.proc.stdin.write(f'{reply}\n')
        self.proc.stdin.flush()

    def close(self) -> None:
        if self.proc.poll() is None:
            self.proc.stdin.close()  # drive.js closes its browser at the end of its input
            try:
                self.proc.wait(timeout=10)
            except subprocess.TimeoutExpired:
                pass
        with contextlib.suppress(ProcessLookupError):
            os.killpg(self.proc.pid, signal.SIGKILL)  # the browser's processes too
        self.proc.wait(timeout=10)
        self.proc.stdout.close()


#: Changed pixels a row or a column of a picture needs to count in the changed pixels' box.
BOX_PIXELS = 4
#: Width [px] of the 3-D view left of the panel (the viewport is 860 px wide).
VIEW_WIDTH = 860 - 330
#: The reachable workspace's point clouds: around the robot (in ring_a) and scaled on the master.
WORKSPACE_NODES = {'/robot/ring_a/workspace', '/master/ring_a/workspace/shell'}


def _workspace_pixels(path: Path) -> int:
    """Pixels of the 3-D view where blue clearly dominates: the workspace's colour (90, 160, 235)
    blended with whatever shows between its small points (an exact-colour count changed by half
    between two pictures of the same scene); the robot's blue-grey (120, 130, 150) stays out."""
    from PIL import Image
    x = np.asarray(Image.open(path).convert('RGB'), dtype=int)[:, :VIEW_WIDTH]
    red, green, blue = x[..., 0], x[..., 1], x[..., 2]
    return int(((blue - red > 50) & (blue >= green)).sum())


def _workspace_drawn(shown: int, hidden: int) -> bool:
    """Whether the robot's copy of the workspace shows: its pixels added to the master's copy."""
    return shown - hidden > 300


def _changed_pixels(a: Path, b: Path, width: int | None = None) -> tuple[int, tuple[int, int, int, int] | None]:
    """(number of changed pixels, their bounding box) between two screenshots, in the first
    ``width`` columns if given."""
    from PIL import Image
    x = np.asarray(Image.open(a).convert('RGB'), dtype=int)[:, :width]
    y = np.asarray(Image.open(b).convert('RGB'), dtype=int)[:, :width]
    changed = np.abs(x - y).max(axis=2) > 40
    # the box: rows and columns with a few changed pixels at least; the shadow maps are redrawn
    # when a scene node is hidden, which changes lone pixels of the pole's and the grid's shading
    # anywhere in the view (two CI runs read a box from the view's top to its left edge)
    rows = np.nonzero(changed.sum(axis=1) >= BOX_PIXELS)[0]
    cols = np.nonzero(changed.sum(axis=0) >= BOX_PIXELS)[0]
    if not len(rows) or not len(cols):
        return int(changed.sum()), None
    return int(changed.sum()), (int(cols.min()), int(rows.min()), int(cols.max()), int(rows.max()))


def test_operator_drives_the_robot_from_the_browser_and_a_viewer_cannot(  # noqa: C901 - one scenario, its sync points
        ros_context, playwright_dir, tmp_path, browser_tmpdir):
    from diagnostic_msgs.msg import DiagnosticStatus
    from geometry_msgs.msg import PoseStamped
    from rclpy.parameter import Parameter
    from sensor_msgs.msg import JointState
    from std_msgs.msg import Bool
    from std_srvs.srv import Trigger

    from rrps_bringup.demo import build_stack
    from rrps_interfaces.climb import CLIMB_RESUME, ClimbStatus
    from rrps_runtime.messages import pose_from_msg
    from rrps_runtime.qos import COMMAND_QOS

    port = free_port()
    # The whole stack in this one process beside a software-rendered browser on two cores: its
    # executor stalls for 0.2 s now and then, which the climb node rightly reads as lost robot
    # state and pauses (tests/node/test_liveness.py). This test is about the viewer: a climb step
    # it starts pauses only for state older than 1 s.
    nodes = build_stack(ros_context, robot='pole_climber', host='127.0.0.1', port=port,
                        token=TOKEN, driver_rate=100.0, parameters={'climb_node': {'state_timeout': 1.0}})
    viewer = nodes['viewer_node']
    probe = Probe(context=ros_context, namespace='/rrps')
    poses = probe.collect(PoseStamped, 'pose', stamped=True)
    enables = probe.collect(Bool, 'teleop/enable', qos=COMMAND_QOS, stamped=True)
    grippers = probe.collect(JointState, 'grippers/state')
    climb_status = probe.collect(DiagnosticStatus, 'climb/status')
    teleop_status = probe.collect(DiagnosticStatus, 'teleop/status', stamped=True)
    keep = os.environ.get('RRPS_SCREENSHOT_DIR')  # e.g. to look at the pictures
    shots = {name: tmp_path / f'{name}.png' for name in ('robot', 'previous', 'hidden', 'shown', 'operator')}
    steps = [
        {'page': 1, 'wait_text': 'Read-only viewer'},
        {'page': 1, 'wait_text': 'Latency: state'},
        {'page': 1, 'layout': 'Read-only viewer'},
        # Taken until two in a row show the same 3-D view: the scene is drawn and still.
        {'page': 1, 'screenshot': str(shots['robot']), 'sync': 'robot shot'},
        {'page': 1, 'sync': 'hide robot'},
        # Taken until the hidden robot shows in the picture (or the test's deadline passed).
        {'page': 1, 'screenshot': str(shots['hidden']), 'sync': 'hidden shot'},
        {'page': 1, 'sync': 'show robot'},
        # Taken until the robot's workspace shows again (it is drawn around the robot, hidden
        # with it), or the test's deadline passed.
        {'page': 1, 'screenshot': str(shots['shown']), 'sync': 'shown shot'},
        {'page': 1, 'close': True},
        {'page': 2, 'wait_text': 'Read-only viewer'},
        {'page': 2, 'fill': 'Token', 'value': TOKEN},
        {'page': 2, 'click': 'Enter token', 'expect': 'Token accepted'},
        {'page': 2, 'click': 'Take control', 'expect': 'You have control'},
        {'page': 2, 'check': 'Engage (clutch)'},
        {'page': 2, 'sync': 'before hold'},
        {'page': 2, 'press': 'Hold to move (deadman)'},
        {'page': 2, 'sync': 'holding'},  # held until the slave moved
        {'page': 2, 'release': True},
        {'page': 2, 'sync': 'after hold'},
        # A read-only viewer while the operator has control: it can move nothing.
        {'page': 3, 'wait_text': 'Read-only viewer'},
        {'page': 3, 'fill': 'Token', 'value': 'not-the-token'},
        {'page': 3, 'click': 'Enter token', 'expect': 'wrong token'},
        {'page': 3, 'disabled': 'Hold to move (deadman)'},
        {'page': 3, 'disabled': 'Climb one step up'},
        {'page': 3, 'disabled': 'Open ring_b'},
        {'page': 3, 'hold': 'Hold to move (deadman)', 'ms': 1000},
        {'page': 3, 'click': 'Open ring_b', 'force': True},
        {'page': 3, 'sync': 'intruder done'},
        {'page': 3, 'close': True},
        {'page': 2, 'click': 'Open ring_b', 'expect': 'open ring_b:'},
        {'page': 2, 'click': 'Open ring_a', 'expect': 'open ring_a:'},
        *([{'page': 2, 'screenshot': str(shots['operator'])}] if keep else []),
        {'page': 2, 'text': True},
        {'page': 2, 'click': 'Close ring_b', 'expect': 'close ring_b:'},
        {'page': 2, 'sync': 'before climb'},
        {'page': 2, 'click': 'Climb one step up', 'expect': 'climb step up: previewing'},
        {'page': 2, 'sync': 'climbing'},
    ]
    robot_nodes = [h for name, h in viewer.viewer.nodes.items() if name.startswith('/robot/')]
    marks: dict[str, float] = {}

    def position():
        return pose_from_msg(poses[-1][1])[0]

    reported_cameras: dict[int, np.ndarray] = {}  # client id: the camera position its browser reported

    @viewer.viewer.server.on_client_connect
    def _watch_camera(client):  # a client connects on its first camera report, which sets its camera
        reported_cameras[client.client_id] = np.array(client.camera.position)
        client.camera.on_update(
            lambda camera: reported_cameras.__setitem__(client.client_id, np.array(camera.position)))

    def browser_framed() -> bool:
        """Whether the browser reported the first view's framing as its camera."""
        framing = viewer.viewer.first_view.camera
        return framing is not None and any(np.allclose(p, framing[0], atol=1e-4)
                                           for p in reported_cameras.values())

    def at_rest():
        """Wait until the last 20 measured poses are one (the slave stands still); return it."""
        def still():
            last = [pose_from_msg(m)[0] for _, m in poses[-20:]]
            return len(last) == 20 and np.ptp(last, axis=0).max() < 1e-9
        assert wait_for(still)
        return position()

    client = probe.create_client(Trigger, CLIMB_RESUME)
    resumer = Resumer(lambda: client.call_async(Trigger.Request()))

    with Spinner(ros_context, [*nodes.values(), probe]):
        assert wait_for(lambda: poses), 'no FK pose from the stack'
        browser = Browser(f'http://127.0.0.1:{viewer.viewer.port}', steps, browser_tmpdir)
        deadline = {}
        framed: list[bool] = []  # at each robot shot's sync (after that shot was taken)
        try:
            for sync in browser.events():
                marks[sync] = time.monotonic()
                reply = 'go'
                if sync == 'robot shot':
                    # still, with the reachable workspace drawn around the robot and the master, and
                    # the browser showing the first view framed on the robot before the earlier of the
                    # two shots compared was taken: its camera moves the whole picture, and a loaded
                    # browser applies the server's camera late (two shots alike before it did failed
                    # a CI run), so the browser's own report of its camera is what counts
                    drawn = WORKSPACE_NODES <= set(viewer.viewer.nodes)
                    changed = (_changed_pixels(shots['previous'], shots['robot'], VIEW_WIDTH)[0]
                               if shots['previous'].exists() else None)
                    still = drawn and framed[-2:-1] == [True] and changed is not None and changed < 50
                    framed.append(browser_framed())
                    shutil.copy(shots['robot'], shots['previous'])
                    deadline.setdefault(sync, time.monotonic() + DEADLINE)
                    if not still and time.monotonic() > deadline[sync]:
                        pytest.fail(f'the 3-D view did not settle framed on the robot: workspace drawn {drawn}, '
                                    f'framed in the browser {framed[-1]}, {changed} pixels changed')
                    reply = 'go' if still else 'again'
                elif sync == 'hide robot':
                    for handle in robot_nodes:
                        handle.visible = False
                elif sync == 'hidden shot':
                    changed = _changed_pixels(shots['robot'], shots['hidden'], VIEW_WIDTH)[0] > 2000
                    deadline.setdefault(sync, time.monotonic() + DEADLINE)
                    reply = 'go' if changed or time.monotonic() > deadline[sync] else 'again'
                elif sync == 'show robot':
                    for handle in robot_nodes:
                        handle.visible = True
                elif sync == 'shown shot':
                    drawn = _workspace_drawn(_workspace_pixels(shots['shown']), _workspace_pixels(shots['hidden']))
                    drawn_snapshot = viewer.workspace.latest()
                    deadline.setdefault(sync, time.monotonic() + DEADLINE)
                    reply = 'go' if drawn or time.monotonic() > deadline[sync] else 'again'
                elif sync == 'before hold':
                    assert viewer.control.controller is not None
                    nodes['master_node'].set_parameters([Parameter('trajectory', value='circle')])
                    start = at_rest()
                elif sync == 'holding':
                    # The deadman is held: the slave follows the master until it moved 2 mm.
                    def followed():
                        held = [t for t, m in enables if m.data and t >= marks['before hold']]
                        return len(held) >= 5 and np.linalg.norm(position() - start) > 0.002
                    wait_for(followed)
                    moved = np.linalg.norm(position() - start)
                elif sync == 'after hold':
                    # Released: the deadman expires, the mapping disengages, the slave stands.
                    assert wait_for(lambda: not viewer.control.enable())
                    assert wait_for(lambda: any(t >= marks['after hold'] and {
                        kv.key: kv.value for kv in m.values}.get('engaged') == 'false' for t, m in teleop_status))
                    held_at = at_rest()
                    marks['held'] = time.monotonic()
                elif sync == 'before climb':
                    assert wait_for(lambda: list(grippers[-1].position) == [1.0, 1.0])
                elif sync == 'climbing':
                    # The click started a climb step: over ROS it executes and the robot moves. A
                    # step paused because a stall of this loaded process aged an input is what an
                    # operator resumes (the hold itself is tested in tests/node/test_liveness.py).
                    climbing = wait_for(lambda: climb_status and
                                        climb_status[-1].message == 'executing')
                    before = position()

                    def moved_or_resumed():
                        resumer(ClimbStatus.from_key_values(climb_status[-1].values))
                        return np.linalg.norm(position() - before) > 0.005
                    climb_moved = wait_for(moved_or_resumed)
                browser.resume(reply)
        finally:
            browser.close()
        result = browser.result
        print('browser steps [ms since start]:',
              [(next(iter(r.items()))[1], r.get('ms'), r.get('attempts', r.get('shots')))
               for r in result['results'] if 'text' not in r])
        if not result['ok']:
            pytest.fail(f"browser: {result['error']} after {result['results'][-3:]}")

    # The robot is drawn: hiding its scene nodes changes the picture in the 3-D view.
    # Counted in the 3-D view only: the panel on the right updates live (latency, plots) meanwhile.
    count, box = _changed_pixels(shots['robot'], shots['hidden'], VIEW_WIDTH)
    assert count > 2000, f'only {count} pixels of the 3-D view changed when the robot was hidden'
    # The first view is framed on it (odometry placed it): all of it inside the 3-D view, clear
    # of the view's edges (the top one cut the frame climber off before).
    # The panel is docked beside the 3-D view, not over it: nothing of the robot hides behind it.
    layout = next(r for r in result['results'] if 'layout' in r)
    view_right = layout['canvas']['x'] + layout['canvas']['width']
    assert VIEW_WIDTH - 10 < view_right <= layout['panel']['x'], layout
    from PIL import Image
    height = Image.open(shots['robot']).height
    assert box[0] > 2 and box[1] > 2 and box[2] < view_right - 3 and box[3] < height - 3, (box, height, view_right)
    # The reachable workspace is drawn around the robot (hidden with it) and on the master: in
    # the browser, once the robot shows again, the robot's copy adds its pixels to the master's.
    ws_shown, ws_hidden = _workspace_pixels(shots['shown']), _workspace_pixels(shots['hidden'])
    drawn = (f'workspace-coloured pixels: {ws_shown} with the robot, {ws_hidden} without; the workspace '
             f'drawn: {len(drawn_snapshot.boundary)} boundary points, {drawn_snapshot.workspace.volume * 1e3:.1f} L '
             f'at q={np.round(drawn_snapshot.quaternion_xyzw, 3)}, world_q_a={np.round(drawn_snapshot.world_q_a, 3)}, '
             f'payload {drawn_snapshot.payload} kg, version {drawn_snapshot.version}')
    print(drawn)
    assert _workspace_drawn(ws_shown, ws_hidden), drawn
    assert ws_hidden > 20, ws_hidden  # the master's copy
    names = set(viewer.viewer.nodes)
    assert WORKSPACE_NODES <= names
    assert {'/robot/ring_a', '/robot/ring_b', '/robot/legs', '/ghost/ring_b',
            '/master/legs', '/trail/ring_a'} <= names
    legs = np.asarray(viewer.viewer.nodes['/robot/legs'].points)
    lengths = np.linalg.norm(legs[:, 1] - legs[:, 0], axis=1)
    assert np.all((lengths > 0.3) & (lengths < 0.55)), lengths

    # The operator's real press-and-hold streamed the deadman and moved the robot. (On this
    # 2-core machine two software-rendered pages can delay the browser's hold events; a gap
    # longer than deadman_timeout drops the deadman, which is the safe side, so only a lower
    # bound on the samples is asserted, and the button is held until the slave moved.)
    held = [t for t, m in enables if m.data and marks['before hold'] <= t <= marks['after hold']]
    assert len(held) >= 5, f'{len(held)} enable samples during the hold'
    assert moved > 0.002, f'the slave moved only {moved * 1e3:.2f} mm while the deadman was held'
    # The read-only viewer could not move anything: no enable, no motion, grippers unchanged.
    # (From the moment the operator's hold had run out and the slave stood still.)
    intruder = [m for t, m in enables if marks['held'] <= t <= marks['intruder done'] and m.data]
    assert not intruder
    drift = max(np.linalg.norm(pose_from_msg(m)[0] - held_at)
                for t, m in poses if marks['held'] <= t <= marks['intruder done'])
    assert drift < 1e-3, f'robot moved {drift * 1e3:.2f} mm while only the viewer acted'
    disabled = {r['disabled']: r['value'] for r in result['results'] if 'disabled' in r}
    assert all(disabled.values()), disabled
    text = next(r['text'] for r in result['results'] if 'text' in r)
    assert '⛔ open ring_a:' in text  # the interlock's refusal is shown to the operator
    assert not any(list(m.position) == [0.0, 0.0] for m in grippers), 'both grippers opened'
    assert any(list(m.position) == [1.0, 0.0] for m in grippers), 'ring_b never opened'
    assert climbing, 'Climb one step up did not start a climb step'
    if resumer.calls:
        print(f'the climb step paused and was resumed {len(resumer.calls)} time(s)')
    assert climb_moved, ('the robot did not move during the climb step: '
                         f'{[ClimbStatus.from_key_values(m.values).detail for m in climb_status[-5:]]}')
    for name, path in shots.items():
        if keep and path.exists():
            shutil.copy(path, Path(keep) / f'rrps_viewer_{name}.png')
