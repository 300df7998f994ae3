"""The viewer over a real network: a browser on the operator station of a multi-host rig
(rrps_testing.netns_rig, the stack of rrps_testing.multihost_stack) drives the robot through a
proxy that adds latency and stalls (rrps_testing.latency_proxy). What the robot does is recorded
inside its own namespace by rrps_testing.netns_agent and judged from message stamps
(rrps_testing.fault_metrics): every namespace shares the host's wall clock.

Root is needed (``ip netns``): locally without it these tests skip, in CI they fail.
"""

from __future__ import annotations

import json
import os
import re
import subprocess
import threading
import time

import numpy as np
import pytest

import rrps_testing.multihost_stack as multihost_stack
from rrps_interfaces.teleop import TeleopCode
from rrps_testing.agent_handle import AgentHandle
from rrps_testing.fault_metrics import (
    in_window,
    last_stamp,
    length_change,
    pose_change,
    teleop,
)
from rrps_testing.multihost_stack import DEADLINE, SETTLE, STILL, TOKEN, VIEWER_PORT
from rrps_testing.multihost_stack import fail_with_logs as _fail_with_logs
from rrps_testing.netns import wait
from rrps_testing.processes import raise_tree_priority

pytestmark = [pytest.mark.ros, pytest.mark.slow, pytest.mark.netns]
stack = multihost_stack.stack  # the fixture

BROWSER_DIR = os.path.join(os.path.dirname(os.path.dirname(__file__)), 'browser')
CHROMIUM = os.environ.get('CHROMIUM', '/usr/bin/chromium')


# --- the viewer over a real network: a browser on the operator station, through a proxy -------

DEADMAN_TIMEOUT = 0.25         # s, the viewer's (default)
ENABLE_PERIOD = 0.05           # s, the viewer's teleop/enable period (20 Hz)
HOLDS = 3
HOLD_STRETCH = 2.0             # s engaged at a stretch: a hold that kept the robot engaged
DEADMAN = 'Hold to move (deadman)'
#: ms added to each direction by the proxy: the round trip gains 100 +- 50 ms (a chunk never
#: overtakes the one before it, as on TCP, so a ping behind a burst of scene updates waits for
#: their draws: 50-150 ms each way would put the round trip near 300 ms, where teleop holds)
LATENCY_DELAY = (25, 75)
MEDIUM_DELAY = 115             # ms each way: a round trip above 200 ms, below 300 ms
SLOW_DELAY = 200               # ms each way: a 400 ms round trip
#: The browser and the proxy stand for the operator's own computer and the network: on a rig they
#: share no CPU with the robot or with a loaded machine's other work. Here their sessions'
#: autogroups get this nice value, so that they get the CPU they ask for beside ``./rrps test
#: --load``, where at nice 0 the software-rendered page's deadman stopped for 1.6-6.4 s in all
#: three holds (it expired: the operator's computer, not the link, broke them).
OPERATOR_COMPUTER_NICE = -10
ENGAGED_CODES = {TeleopCode.NO_WARNING, TeleopCode.LATENCY_SLOWED, TeleopCode.SPEED_LIMITED,
                 TeleopCode.DECELERATE_FOR_APPROACHING_SINGULARITY, TeleopCode.DECELERATE_FOR_COLLISION}


class _Lines:
    """JSON lines of a child's stdout, read by a thread; commands on its stdin."""

    def __init__(self, process: subprocess.Popen):
        self.process = process
        self.lines: list[dict] = []
        self._thread = threading.Thread(target=self._read, daemon=True)
        self._thread.start()

    def _read(self) -> None:
        for line in self.process.stdout:
            try:
                self.lines.append(json.loads(line))
            except json.JSONDecodeError:
                pass

    def write(self, text: str) -> None:
        self.process.stdin.write(text + '\n')
        self.process.stdin.flush()

    def next(self, key: str | tuple, start: int, timeout: float) -> tuple[int, dict]:
        """The first line from index ``start`` on that has ``key`` (or one of the keys)."""
        found = {}
        keys = (key,) if isinstance(key, str) else key

        def look() -> bool:
            for i in range(start, len(self.lines)):
                if any(k in self.lines[i] for k in keys):
                    found.update(index=i, line=self.lines[i])
                    return True
            return False
        # the reader ends with the child's output: no such line will come
        wait(lambda: look() or not self._thread.is_alive(), timeout, period=0.02)
        if not found and not look():
            raise TimeoutError(f'no {key!r} line in {timeout} s' if self._thread.is_alive()
                               else f'no {key!r} line: the process closed its output ({self.process.poll()})')
        return found['index'], found['line']


class _Proxy(_Lines):
    def command(self, text: str) -> dict:
        start = len(self.lines)
        self.write(text)
        return self.next('ok', start, 30.0)[1]


def _round_trip_ms(text: str) -> float:
    match = re.search(r'Round trip:\**\s*(\d+) ms', text)
    assert match, f'no round trip on the panel: {text[:500]}'
    return float(match.group(1))


@pytest.mark.browser
def test_a_browser_on_the_operator_station_drives_the_robot_through_latency_and_stalls(stack, playwright_dir,
                                                                                      browser_tmpdir):
    """A browser on the operator station drives the robot through rrps_testing.latency_proxy.

    The proxy adds 25-75 ms to each direction (the round trip gains 100 +- 50 ms): the held
    deadman keeps the robot engaged, the panel shows the round trip. With 115 ms each way (a
    round trip above 200 ms) teleop slows down; a 1.5 s stall (longer than the viewer's deadman
    timeout) holds the robot; with 200 ms each way (400 ms) the robot holds although the deadman
    is held. The browser presses and releases the deadman; the test decides how long it is held
    (a ``sync`` between press and release) and judges from the recorded messages."""
    stack.reset()
    rig, robot, operator = stack.rig, stack.robot, stack.operator
    lo, hi = LATENCY_DELAY
    proxy = _Proxy(rig.python('operator', 'proxy', [
        '-m', 'rrps_testing.latency_proxy', '--listen', '127.0.0.1:0',
        '--target', f'127.0.0.1:{VIEWER_PORT}', '--delay', f'{lo},{hi}', '--seed', '11'], pipes=True,
        nice=OPERATOR_COMPUTER_NICE))
    port = proxy.next('listening', 0, DEADLINE)[1]['listening']
    wait_long = 90000

    def held(name: str) -> list[dict]:  # press, hand over to the test, release
        return [{'sync': name}, {'press': DEADMAN}, {'sync': f'{name} held'}, {'release': True},
                {'sync': f'{name} released'}]
    steps = [
        {'wait_text': 'Read-only viewer', 'timeout': wait_long},
        # No 3-D scene: software-rendered (no GPU here), each frame blocks the page's main
        # thread so long that the hold button's 20 Hz timer fires at 1-2 Hz, and the deadman
        # (0.25 s) flickers whatever the link does. This test is about the link.
        {'css': 'canvas { display: none !important; }'},
        {'fill': 'Token', 'value': TOKEN, 'timeout': wait_long},
        {'click': 'Enter token', 'timeout': wait_long},
        {'wait_text': 'Token accepted', 'timeout': wait_long},
        {'click': 'Take control', 'timeout': wait_long},
        {'wait_text': 'You have control', 'timeout': wait_long},
        {'check': 'Engage (clutch)', 'timeout': wait_long},
        # up to HOLDS holds (the test makes the later ones short once one was judged): a
        # software-rendered browser on a busy machine can itself pause longer than the deadman
        # timeout; the link must never be the cause
        *[step for k in range(HOLDS) for step in held(f'latency {k}')],
        {'wait_text': 'Round trip:', 'timeout': wait_long},
        {'text': True},
        *held('medium'),
        *held('stall'),
        {'sync': 'slow link'},
        {'wait_text': 'robot holds above 300 ms', 'timeout': wait_long},
        *held('slow'),
        {'text': True},
    ]
    browser = _Lines(rig.start('operator', 'browser', ['node', 'drive.js', f'http://127.0.0.1:{port}',
                                                       json.dumps(steps)],
                               env=rig.env(CHROMIUM=CHROMIUM, TMPDIR=browser_tmpdir), pipes=True,
                               cwd=BROWSER_DIR, nice=OPERATOR_COMPUTER_NICE))

    session = _BrowserSession(operator, robot, proxy)
    index = 0
    browser_sessions: list[int] = []
    while True:
        try:
            index, line = browser.next(('sync', 'ok'), index, 240.0)
        except TimeoutError as exc:
            _fail_with_logs(rig, f'browser: {exc}; its last lines {browser.lines[-3:]}')
        index += 1
        if 'ok' in line:
            result = line
            break
        if not browser_sessions:  # by now Chromium runs, in a session of its own (Playwright's)
            browser_sessions = raise_tree_priority(browser.process.pid, OPERATOR_COMPUTER_NICE)
        session.on_sync(line['sync'])
        browser.write('go')
    marks, stall = session.marks, session.stall
    if not result['ok']:
        _fail_with_logs(rig, f"browser: {result['error']} after {result['results'][-3:]}")
    texts = [r['text'] for r in result['results'] if 'text' in r]
    print(f'browser sessions at autogroup nice {OPERATOR_COMPUTER_NICE}: {browser_sessions}; '
          'steps [ms since its start]:',
          [(next(iter(r)), r.get('ms')) for r in result['results'] if 'text' not in r])

    enables = operator.records('teleop/enable')
    statuses = operator.records('teleop/status')
    targets = robot.records('target_pose')

    # 1. 100 +- 50 ms more round trip: the held deadman keeps the robot engaged, for a stretch of
    # HOLD_STRETCH s in which every teleop/status says engaged and the slave moves. One Ping that a
    # busy machine delays past 300 ms holds the robot (LINK_LATENCY, as it must) outside such a
    # stretch; the link's own share is the median round trip, asserted below 300 ms.
    holds = [_judge_hold(operator, robot, marks[f'latency {k}'], marks[f'latency {k} released'])
             for k in range(HOLDS)]
    round_trips = [_percentiles(operator.records('operator/round_trip_time', marks[f'latency {k}'],
                                                 marks[f'latency {k} released'])) for k in range(HOLDS)]
    assert any(ok for ok, _ in holds), \
        f'no hold stayed engaged: {holds}; proxy {proxy.command("stats")}; round trips in the holds: {round_trips}'
    # The panel shows the link's round trip: at least what the proxy adds. One reading is one Ping,
    # which a busy machine can delay past 300 ms (a CI run read 367 ms); what the viewer measured
    # over the holds (operator/round_trip_time, its median) stays below teleop's 300 ms hold.
    rtt = _round_trip_ms(texts[0])
    assert rtt >= 2 * lo, f'round trip {rtt} ms on the panel through a {lo}-{hi} ms proxy'
    measured = [r['data'] for r in operator.records('operator/round_trip_time', marks['latency 0'], marks['medium'])]
    assert measured and 2 * lo / 1e3 <= np.median(measured) <= 0.3, (measured, rtt)

    # 2. A round trip above 200 ms (below 300 ms) slows teleop down, engaged: every engaged
    # status with such a round trip has a speed factor below 1, and there was one.
    window = [teleop(r) for r in operator.records('teleop/status', marks['medium'], marks['medium released'])]
    slowed = [s for s in window if s.engaged and s.round_trip_time is not None
              and 0.2 < s.round_trip_time <= 0.3]
    assert slowed and all(s.speed_factor < 1.0 and s.code is TeleopCode.LATENCY_SLOWED for s in slowed), \
        (f'round trips {sorted({s.round_trip_time for s in window if s.round_trip_time})[-5:]}, '
         f'codes {sorted({s.code.name for s in window})}')
    assert all(s.speed_factor == 1.0 for s in window if s.round_trip_time is not None
               and s.round_trip_time <= 0.2)

    # 3. A stall longer than the deadman timeout holds the robot: no command stamped later
    # than the deadman's expiry (+ one enable period, + slack for a busy machine).
    assert 't' in stall, 'the deadman never engaged before the stall'
    t_stall = stall['t']
    assert any(r['data'] for r in enables if t_stall - 0.3 <= r['t'] <= t_stall), 'deadman not held'
    newest = last_stamp(targets, t_stall - 1.0, t_stall + 1.5)
    bound = t_stall + DEADMAN_TIMEOUT + ENABLE_PERIOD + 0.25
    assert newest is not None and newest <= bound, f'target {newest - t_stall:.3f} s after the stall began'
    assert not in_window(robot.records('actuators/command'), bound, t_stall + 1.5, by='stamp')
    assert length_change(robot.records('actuators/state'), bound + SETTLE, t_stall + 1.5) < STILL
    assert any(not teleop(r).engaged for r in statuses if t_stall <= r['t'] <= t_stall + 1.5)

    # 4. A 400 ms round trip: teleop holds (LINK_LATENCY) although the deadman is held.
    window = (marks['slow held'] + 1.0, marks['slow released'])
    slow = [teleop(r) for r in statuses if window[0] <= r['t'] <= window[1]]
    assert slow and not any(s.engaged for s in slow)
    assert TeleopCode.LINK_LATENCY in {s.code for s in slow}
    assert any(r['data'] for r in enables if window[0] <= r['t'] <= window[1]), 'no deadman held'
    assert not in_window(targets, window[0], window[1], by='stamp')
    assert _round_trip_ms(texts[-1]) >= 350.0
    assert '(robot holds above 300 ms)' in texts[-1]
    print(f'browser through the proxy: holds (engaged throughout, codes when not engaged): {holds}; '
          f'panel round trip {rtt:.0f} ms at {lo}-{hi} ms each way; slowed: speed factors '
          f'{sorted({round(s.speed_factor, 2) for s in slowed})} at round trips up to '
          f'{max(s.round_trip_time for s in slowed) * 1e3:.0f} ms; '
          f'stall: last target {newest - t_stall:.3f} s after it began; '
          f'400 ms link: {_round_trip_ms(texts[-1]):.0f} ms on the panel, teleop {slow[-1].code.name}')


class _BrowserSession:
    """The test's side of the browser's ``sync`` steps: it changes the proxy and decides how
    long each press of the deadman lasts (until what it judges has happened)."""

    def __init__(self, operator: AgentHandle, robot: AgentHandle, proxy: '_Proxy'):
        self.operator, self.robot, self.proxy = operator, robot, proxy
        self.marks: dict[str, float] = {}
        self.smooth: list[int] = []
        self.stall: dict = {}

    def engaged_for(self, since: float, seconds: float) -> bool:
        """Engaged (deadman held through the proxy) for the last ``seconds`` at a stretch."""
        stretch = _engaged_stretches(self.operator.records('teleop/status', since))
        return bool(stretch) and stretch[-1][1] - stretch[-1][0] >= seconds

    def round_trips(self, since: float) -> list[float]:
        return [r['data'] for r in self.operator.records('operator/round_trip_time', since)]

    def on_sync(self, name: str) -> None:
        now = self.marks[name] = time.time()
        lo, hi = LATENCY_DELAY
        if name.startswith('latency') and name.endswith(' held') and not self.smooth:
            # held until it was engaged for long enough at a stretch (or long enough to judge)
            start = self.marks[name.replace(' held', '')]
            wait(lambda: self.engaged_for(start, HOLD_STRETCH + 0.5), 15.0)
        elif name.startswith('latency') and name.endswith(' released'):
            k = int(name.split()[1])
            if _judge_hold(self.operator, self.robot, self.marks[f'latency {k}'], now)[0]:
                self.smooth.append(k)
        elif name == 'medium':
            self.proxy.command(f'delay {MEDIUM_DELAY} {MEDIUM_DELAY}')
            assert wait(lambda: any(0.2 < v for v in self.round_trips(now + 1.0)), DEADLINE), \
                'the viewer never measured a round trip above 200 ms'
        elif name == 'medium held':
            wait(lambda: any(_slowed(r) for r in self.operator.records('teleop/status', now)), 20.0)
            time.sleep(1.0)
        elif name == 'stall':
            self.proxy.command(f'delay {lo} {hi}')
            wait(lambda: (v := self.round_trips(now + 1.0)) and v[-1] < 0.2, 20.0)
        elif name == 'stall held':
            # 1 s into the engaged deadman (its press came through the proxy), stall the link
            if wait(lambda: self.engaged_for(self.marks['stall'], 1.0), 30.0):
                self.stall['t'] = time.time()
                self.stall['reply'] = self.proxy.command('stall 1.5')
                time.sleep(2.5)
        elif name == 'slow link':
            self.proxy.command(f'delay {SLOW_DELAY} {SLOW_DELAY}')  # a 400 ms round trip
            assert wait(lambda: any(v > 0.35 for v in self.round_trips(now + 1.0)), DEADLINE), \
                'the viewer never measured 400 ms'
        elif name == 'slow held':
            time.sleep(2.5)


def _percentiles(records: list[dict]) -> dict:
    """p50, p90 and max [ms] of recorded round trips [s], and their number."""
    values = np.array([r['data'] for r in records]) * 1e3
    if not len(values):
        return {}
    p50, p90 = np.percentile(values, [50, 90])
    return {'p50': round(p50), 'p90': round(p90), 'max': round(values.max()), 'n': len(values)}


def _slowed(record: dict) -> bool:
    s = teleop(record)
    return s.engaged and s.code is TeleopCode.LATENCY_SLOWED


def _engaged_stretches(statuses: list[dict]) -> list[tuple[float, float]]:
    """(first, last) receipt times of each run of consecutive engaged teleop statuses."""
    out: list[list[float]] = []
    previous = False
    for r in statuses:
        engaged = teleop(r).engaged
        if engaged and previous:
            out[-1][1] = r['t']
        elif engaged:
            out.append([r['t'], r['t']])
        previous = engaged
    return [(a, b) for a, b in out]


def _judge_hold(operator: AgentHandle, robot: AgentHandle, start: float, end: float) -> tuple[bool, dict]:
    """Whether the deadman held from ``start`` to ``end`` kept teleop engaged: a stretch of
    HOLD_STRETCH s at least in which every status says engaged (with an engaged code), every
    deadman sample is true and the slave moves; and what broke the others (codes while not
    engaged, LINK_LATENCY statuses: a Ping delayed past 300 ms, false deadman samples: the
    viewer's deadman expired, the longest gap between deadman samples: the operator station's
    own stalls)."""
    enables = operator.records('teleop/enable', start, end)
    on = [r for r in enables if r['data']]
    if not on:
        return False, {'deadman': 'no sample'}
    t_on, t_off = on[0]['t'], on[-1]['t']
    held = [r for r in enables if t_on <= r['t'] <= t_off]
    statuses = operator.records('teleop/status', t_on, t_off)
    codes = [teleop(r) for r in statuses]
    ok = any(
        b - a >= HOLD_STRETCH
        and all(teleop(r).code in ENGAGED_CODES for r in statuses if a <= r['t'] <= b)
        and all(r['data'] for r in held if a <= r['t'] <= b)
        and pose_change(robot.records('pose'), a, b) > 1e-3
        for a, b in _engaged_stretches(statuses))
    gaps = np.diff([r['t'] for r in held])
    return ok, {'codes': sorted({s.code.name for s in codes if not s.engaged}),
                'LINK_LATENCY statuses': sum(s.code is TeleopCode.LINK_LATENCY for s in codes),
                'false samples': sum(not r['data'] for r in held),
                'longest deadman gap [s]': round(float(gaps.max()), 3) if len(gaps) else None}
