"""Shared pytest fixtures: DDS on loopback, a private rclpy Context per ROS test, and ``--load``.

``./rrps test --load [ARGS]`` runs the tests while rrps_testing.load keeps one core busy and a
second ROS process floods the machine with DDS messages: the suite must pass on a busy
machine, not only on an idle one.
"""

from __future__ import annotations

import os

import pytest

from rrps_testing.ci import next_domain_id

# Every process that starts rclpy here keeps DDS on this machine (docs/deployment.md).
os.environ['ROS_AUTOMATIC_DISCOVERY_RANGE'] = 'LOCALHOST'
# Inherited by every process this session starts: how an orphan it left is told from another
# job's process that happens to be reparented to init (never kill those).
SESSION_MARK = f'RRPS_TEST_SESSION={os.getpid()}'
os.environ['RRPS_TEST_SESSION'] = str(os.getpid())

@pytest.fixture
def ros_domain_id() -> int:
    return next_domain_id()


@pytest.fixture
def ros_context(ros_domain_id):
    """An initialised rclpy Context on its own domain id; shut down after the test."""
    import rclpy

    context = rclpy.Context()
    rclpy.init(context=context, domain_id=ros_domain_id)
    try:
        yield context
    finally:
        if context.ok():
            rclpy.shutdown(context=context)



def pytest_addoption(parser):
    group = parser.getgroup('rrps')
    group.addoption('--load', action='store_true',
                    help='run the tests on a loaded machine: a busy core and a DDS flood '
                         '(rrps_testing.load)')
    group.addoption('--load-busy', type=int, default=1, help='with --load: busy processes')
    group.addoption('--load-flood-rate', type=float, default=2000.0,
                    help='with --load: DDS messages per second per topic of the flood')


@pytest.fixture(scope='session', autouse=True)
def machine_load(request):
    """With ``--load``, the load of rrps_testing.load around the whole session (started once:
    by the first pytest-xdist worker, or by the one process of ``-n 0``)."""
    if not request.config.getoption('--load') or os.environ.get('PYTEST_XDIST_WORKER', 'gw0') != 'gw0':
        yield None
        return
    from rrps_testing.load import Load
    with Load(busy=request.config.getoption('--load-busy'),
              flood_rate=request.config.getoption('--load-flood-rate')) as load:
        yield load


def _marked(pid: int) -> bool:
    """Whether the process inherited this session's :data:`SESSION_MARK`."""
    try:
        with open(f'/proc/{pid}/environ', 'rb') as f:
            return SESSION_MARK.encode() in f.read().split(b'\0')
    except OSError:
        return False


def _processes_started_since(t0_ticks: int) -> list[tuple[int, int, str]]:
    """(pid, parent pid, command line) of the processes started after ``t0_ticks`` (clock ticks
    since boot) that are this session's descendants, or orphans (parent 1) that carry its mark."""
    me = os.getpid()
    table = {}
    for entry in os.listdir('/proc'):
        if not entry.isdigit():
            continue
        try:
            with open(f'/proc/{entry}/stat') as f:
                fields = f.read().rsplit(')', 1)[1].split()
            with open(f'/proc/{entry}/cmdline', 'rb') as f:
                cmdline = f.read().replace(b'\0', b' ').decode(errors='replace').strip()
        except OSError:
            continue
        if fields[0] != 'Z':
            table[int(entry)] = (int(fields[1]), int(fields[19]), cmdline)
    def descends(pid: int) -> bool:
        seen = set()
        while pid in table and pid not in seen:
            seen.add(pid)
            pid = table[pid][0]
            if pid == me:
                return True
        return False
    return [(pid, ppid, cmd) for pid, (ppid, start, cmd) in table.items()
            if start > t0_ticks and pid != me and cmd
            and (descends(pid) or (ppid == 1 and _marked(pid)))]


def _ticks_now() -> int:
    with open('/proc/self/stat') as f:
        return int(f.read().rsplit(')', 1)[1].split()[19])


#: The directory of the session's machine turns (rrps_testing.machine_turns), made by the controller.
TURNS_ENV = 'RRPS_TEST_TURNS'


def pytest_configure(config):
    """The controller (or the one process of ``-n 0``) makes the session's machine turns; its
    pytest-xdist workers, started after this, inherit their directory."""
    if not hasattr(config, 'workerinput'):
        import tempfile
        config._rrps_turns = os.environ[TURNS_ENV] = tempfile.mkdtemp(prefix='rrps-turns-')


def pytest_unconfigure(config):
    """The machine turns' directory is removed. The objects the nodes built here froze out of the
    collector's reach (a driver freezes its hardware's) back in it, so that the interpreter's end
    frees them: a Ruckig object still alive then is reported by nanobind as a leak."""
    import gc
    import shutil

    from rrps_runtime.collector import thaw
    if getattr(config, '_rrps_turns', None):
        shutil.rmtree(config._rrps_turns, ignore_errors=True)
    thaw()
    gc.collect()


def _turns():
    from rrps_testing.machine_turns import MachineTurns
    return MachineTurns(os.environ[TURNS_ENV]) if os.environ.get(TURNS_ENV) else None


@pytest.fixture(scope='module', autouse=True)
def module_machine_turn(request):
    """A module marked ``exclusive`` holds the machine alone from its first fixture to its last test
    (its module-scoped stack runs between its tests)."""
    turns = _turns()
    if turns is None or request.node.get_closest_marker('exclusive') is None:
        yield False
        return
    with turns.take(exclusive=True):
        yield True


@pytest.fixture(autouse=True)
def machine_turn(request, module_machine_turn):
    """Every test but the turn-free ones shares the machine with the other worker's, and one marked
    ``exclusive`` holds it alone (rrps_testing.machine_turns): the CANopen drive simulator and driver at SCHED_RR take
    about 1.3 of its 2 cores, and beside them another test's DDS threads starved for seconds."""
    turns = _turns()
    if turns is None or module_machine_turn or request.node.nodeid.startswith(TURN_FREE):
        yield
        return
    with turns.take(exclusive=request.node.get_closest_marker('exclusive') is not None):
        yield


def pytest_sessionstart(session):
    session.config._rrps_t0 = _ticks_now() if os.path.exists('/proc/self/stat') else None


def pytest_sessionfinish(session, exitstatus):
    """No test leaves a process behind: anything this session started that still runs (a child,
    or an orphan it left) fails the session, after it is killed."""
    t0 = getattr(session.config, '_rrps_t0', None)
    if t0 is None:
        return
    import signal
    import time
    deadline = time.monotonic() + 10.0
    left = _processes_started_since(t0)
    while left and time.monotonic() < deadline:  # give stopping processes a moment
        time.sleep(0.2)
        left = _processes_started_since(t0)
    # ...but this process's own multiprocessing resource tracker (a WorkerProcess's pool started
    # it; it ends with this process, as it does with a node's)
    left = [p for p in left if 'load_flood' not in p[2] and 'while True' not in p[2]
            and not (p[1] == os.getpid() and 'multiprocessing.resource_tracker' in p[2])]
    if left:
        print('\nprocesses left behind by the tests (killed now):')
        for pid, ppid, cmd in left:
            print(f'  {pid} (parent {ppid}): {cmd[:160]}')
            try:
                os.kill(pid, signal.SIGKILL)
            except ProcessLookupError:
                pass
        session.exitstatus = 1


#: The headless browser the viewer tests drive (Debian's chromium; ./rrps test installs it as root).
CHROMIUM = os.environ.get('CHROMIUM', '/usr/bin/chromium')
BROWSER_DIR = os.path.join(os.path.dirname(__file__), 'browser')


@pytest.fixture(scope='session')
def playwright_dir() -> str:
    """tests/browser with playwright-core installed (npm ci from the lock file if missing)."""
    import shutil
    import subprocess

    from rrps_testing.ci import require
    require(os.path.exists(CHROMIUM), f'no Chromium at {CHROMIUM} (./rrps test installs Debian\'s chromium as root)')
    require(shutil.which('npm') is not None and shutil.which('node') is not None,
            'node and npm are needed for playwright-core')
    if not os.path.isdir(os.path.join(BROWSER_DIR, 'node_modules', 'playwright-core')):
        subprocess.run(['npm', 'ci', '--no-audit', '--no-fund'], cwd=BROWSER_DIR, check=True,
                       stdout=subprocess.DEVNULL, timeout=300)
    return BROWSER_DIR



@pytest.fixture
def browser_tmpdir():
    """A temporary directory for a browser's profile and files (TMPDIR), removed after the test.
    Short, in /tmp: Chromium puts its singleton socket there, and a Unix socket's path holds at
    most 107 characters (under pytest-xdist a tmp_path is too deep: the browser never starts).
    Removed again while a browser that is still closing writes there (up to 30 s): a single
    removal racing it left the directory behind."""
    import shutil
    import tempfile
    import time
    path = tempfile.mkdtemp(prefix='rrps-browser-')
    try:
        yield path
    finally:
        deadline = time.monotonic() + 30.0
        shutil.rmtree(path, ignore_errors=True)
        while os.path.exists(path) and time.monotonic() < deadline:
            time.sleep(0.2)
            shutil.rmtree(path, ignore_errors=True)


# Two pytest-xdist workers (./rrps test). The system tests (processes, network namespaces, the
# CANopen bus, timing under load) run one after another on one worker, the longest chain of the
# suite, the CANopen tests first: they hold the machine alone (``exclusive``), and meanwhile the
# other worker runs the unit and repository tests, which time nothing and take no turn; then the
# browser test and the node tests, all at a lower priority.
SERIAL_LEVELS = ('tests/system/',)
#: First on their worker: the CANopen tests, beside the turn-free tests only.
FIRST = ('tests/system/test_canopen',)
#: System tests that time nothing and share nothing (builds and installs into their own
#: directories): each module on whichever worker is free, as a whole (its build made once).
SPREAD = ('tests/system/test_clean_install.py', 'tests/system/test_install_tree.py')
#: Tests that time nothing and start no real-time thread (pure functions, the repository, builds and
#: installs): they take no machine turn, and run beside the CANopen tests.
TURN_FREE = ('tests/unit/', 'tests/repo/', *SPREAD)


def _level(nodeid: str) -> str | None:
    if nodeid.startswith(SPREAD):
        return None
    return next((level for level in SERIAL_LEVELS if nodeid.startswith(level)), None)


def pytest_collection_modifyitems(config, items):
    """The system tests with the CANopen ones first, then the unit and repository tests, then the
    browser test, then the node tests."""
    def rank(item):
        nodeid = item.nodeid
        if nodeid.startswith('tests/system/'):
            return 0 if nodeid.startswith(FIRST) else 1
        if nodeid.startswith(TURN_FREE):
            return 2
        return 3 if nodeid.startswith('tests/browser/') else 4
    items.sort(key=rank)  # stable: each file keeps its order


@pytest.hookimpl(optionalhook=True)
def pytest_xdist_make_scheduler(config, log):
    """xdist's load-scope scheduling with our scopes: the serial level is one scope (one worker, in
    order), each SPREAD module one, every other test its own scope (spread over the workers; the
    browser's, first in the order, goes to the other worker first)."""
    from xdist.scheduler import LoadScopeScheduling

    class LevelScheduling(LoadScopeScheduling):
        def _split_scope(self, nodeid: str) -> str:
            if nodeid.startswith(SPREAD):
                return nodeid.split('::')[0]
            return 'serial' if _level(nodeid) else nodeid

    return LevelScheduling(config, log)


#: Beside the serial levels, yet a whole stack that keeps its deadman and climb timing: at nice 0. At nice 10 it
#: shares the tests' autogroup with the serial level's work at nice 0 (a tenth of the weight), and under ``--load``
#: its in-process robot did not move in the 60 s after a climb step began.
WHOLE_STACK = ('tests/browser/',)


def pytest_runtest_setup(item):
    """Under xdist, the tests beside the serial levels run at nice 10 (their children too), but
    the browser's whole stack."""
    if 'PYTEST_XDIST_WORKER' not in os.environ:
        return
    niceness = 0 if _level(item.nodeid) or item.nodeid.startswith(WHOLE_STACK) else 10
    try:
        os.setpriority(os.PRIO_PROCESS, 0, niceness)
    except OSError:  # lowering it back needs root; then the worker simply stays at 10
        pass
