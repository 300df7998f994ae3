"""The scheduling a node claims for the threads of its command path (``rt_priority``, ``cpu_affinity``), as
ros2_control's controller manager claims ``SCHED_FIFO`` and a CPU set for its update loop.

:func:`claim` gives threads ``SCHED_RR`` (reset on fork) and a CPU set where permitted, else :func:`fallback_nice`,
and says what they got (:class:`Granted`); :func:`background` returns a thread off the command path to the normal
policy. Only threads that sleep between periods may run real time (docs/deployment.md). Linux only; no ROS import.
"""

from __future__ import annotations

import ctypes
import ctypes.util
import os
import sys
import threading
from dataclasses import dataclass

from rrps_runtime.parameter_schema import Parameter
from rrps_runtime.supervision import CONTROL_NICE, CONTROL_RT_PRIORITY, OPERATOR_NICE

__all__ = ['Request', 'Granted', 'scheduling_parameters', 'request_of', 'fallback_nice', 'claim', 'claim_thread',
           'background', 'demote', 'thread_ids', 'thread_name', 'name_thread', 'middleware_threads',
           'input_threads', 'INPUT_THREAD',
           'scheduling_of_thread', 'set_process_scheduling', 'process_scheduling', 'process_request',
           'MAX_RT_PRIORITY', 'NORMAL']

#: Highest priority a node may ask for: below the kernel's threaded interrupts (50) and its
#: watchdogs (99) there is room for every rrps cycle; higher would delay the network's interrupts.
MAX_RT_PRIORITY = 49
NORMAL = 'SCHED_OTHER'
_PR_SET_NAME = 15
_RT_POLICY = getattr(os, 'SCHED_RR', 2)
_RESET_ON_FORK = getattr(os, 'SCHED_RESET_ON_FORK', 0x40000000)
#: Thread name prefixes of the DDS middleware's delivery threads (Fast DDS: dds.udp.*,
#: dds.shm.*, dds.ev.*, ...; Cyclone DDS: recv*, tev, dq.*): the command path's messages arrive
#: through them.
MIDDLEWARE_THREADS = ('dds.', 'recv', 'tev', 'dq.')
#: Name prefix of a thread through which an operator's input reaches a node outside its executor
#: (the viewer's websocket thread: the deadman's presses, the link's round trip): claimed with the
#: command path (:func:`input_threads`).
INPUT_THREAD = 'rrps-in-'


@dataclass(frozen=True)
class Request:
    """What a node asks for its command path: ``priority`` (SCHED_RR, 0 = the normal policy) on
    ``cpus`` (empty: every CPU)."""

    priority: int = 0
    cpus: tuple[int, ...] = ()

    def __post_init__(self) -> None:
        if not 0 <= self.priority <= MAX_RT_PRIORITY:
            raise ValueError(f'rt_priority must be in [0, {MAX_RT_PRIORITY}], got {self.priority}')
        if any(c < 0 for c in self.cpus):
            raise ValueError(f'cpu_affinity: CPUs are numbered from 0, got {list(self.cpus)}')

    def merged(self, other: 'Request') -> 'Request':
        """The request of a process whose nodes ask for ``self`` and ``other``: the higher
        priority, the CPUs of both."""
        cpus = tuple(sorted(set(self.cpus) | set(other.cpus))) if self.cpus and other.cpus else \
            (self.cpus or other.cpus)
        return Request(max(self.priority, other.priority), cpus)

    def shifted(self, levels: int) -> 'Request':
        """The same request ``levels`` priorities higher (a cycle above its process' other threads);
        the normal policy stays normal."""
        return self if self.priority == 0 else Request(min(self.priority + levels, MAX_RT_PRIORITY), self.cpus)


@dataclass(frozen=True)
class Granted:
    """What a set of threads got: ``policy`` ('SCHED_RR' or 'SCHED_OTHER'), ``priority``, ``nice``,
    the ``cpus`` they may run on, the number of ``threads``, and ``refused``: why less than the
    request was granted ('' when all of it was)."""

    policy: str
    priority: int
    nice: int
    cpus: tuple[int, ...]
    threads: int
    refused: str = ''

    @property
    def realtime(self) -> bool:
        return self.policy != NORMAL

    def text(self) -> str:
        """For people: 'SCHED_RR 10 on CPUs 0-1 (3 threads)' or 'nice -10 on CPU 0 (...)'."""
        what = f'{self.policy} {self.priority}' if self.realtime else f'nice {self.nice}'
        out = f'{what} on {_cpus_text(self.cpus)} ({self.threads} thread{"s" * (self.threads != 1)})'
        return out + (f'; not granted: {self.refused}' if self.refused else '')

    def values(self) -> dict:
        """The status values a node reports (:class:`rrps_interfaces.status.SchedulingStatus`)."""
        return {'scheduling_policy': self.policy, 'scheduling_priority': self.priority, 'scheduling_nice': self.nice,
                'scheduling_cpus': self.cpus, 'scheduling_refused': self.refused}


def _cpus_text(cpus: tuple[int, ...]) -> str:
    if not cpus:
        return 'no CPU'
    if len(cpus) > 1 and list(cpus) == list(range(cpus[0], cpus[-1] + 1)):
        return f'CPUs {cpus[0]}-{cpus[-1]}'
    return f'CPU{"s" * (len(cpus) > 1)} {",".join(map(str, cpus))}'


def scheduling_parameters(priority: int) -> list[Parameter]:
    """The two scheduling parameters of a node of the command path, ``priority`` the default of
    ``rt_priority`` (the docs' launch: rrps_runtime.supervision's priorities)."""
    return [
        Parameter('rt_priority', priority, 'SCHED_RR priority of the threads of the command path (the node\'s '
                  'cycles, its executor and the middleware\'s delivery threads), claimed at start where permitted '
                  '(root, CAP_SYS_NICE, RLIMIT_RTPRIO); 0 = the normal policy. The log and /diagnostics say what '
                  'was granted', range=(0, MAX_RT_PRIORITY)),
        Parameter('cpu_affinity', None, 'CPUs the threads of the command path may run on', type=tuple,
                  item_type=int, range=(0, 1023), unset_note='every CPU of the process'),
    ]


def request_of(values: dict) -> Request:
    """The Request of a node's parameter values (``rt_priority``, ``cpu_affinity``)."""
    return Request(int(values['rt_priority']), tuple(int(c) for c in values['cpu_affinity'] or ()))


def fallback_nice(priority: int) -> int:
    """The nice value claimed where real time is refused (supervision's CONTROL_NICE for the
    robot's priorities, OPERATOR_NICE for the operator station's, 0 for the normal policy)."""
    if priority >= CONTROL_RT_PRIORITY:
        return CONTROL_NICE
    return OPERATOR_NICE if priority > 0 else 0


def thread_ids() -> list[int]:
    """The kernel thread ids of this process (Linux /proc)."""
    try:
        return sorted(int(t) for t in os.listdir('/proc/self/task'))
    except OSError:
        return [threading.get_native_id()]


def thread_name(tid: int) -> str:
    """The kernel's name of thread ``tid`` of this process ('' when gone)."""
    try:
        with open(f'/proc/self/task/{tid}/comm') as f:
            return f.read().strip()
    except OSError:
        return ''


def name_thread(name: str) -> None:
    """Name the calling thread for the kernel (ps, top, /proc; at most 15 characters)."""
    if sys.platform.startswith('linux'):
        libc = ctypes.CDLL(ctypes.util.find_library('c') or 'libc.so.6', use_errno=True)
        libc.prctl(_PR_SET_NAME, name.encode()[:15], 0, 0, 0)


def middleware_threads() -> list[int]:
    """The thread ids of the DDS middleware's delivery threads now (:data:`MIDDLEWARE_THREADS`)."""
    return [tid for tid in thread_ids() if thread_name(tid).startswith(MIDDLEWARE_THREADS)]


def input_threads() -> list[int]:
    """The thread ids of the threads named :data:`INPUT_THREAD` ``*`` now."""
    return [tid for tid in thread_ids() if thread_name(tid).startswith(INPUT_THREAD)]


def _usable_cpus(cpus: tuple[int, ...]) -> tuple[set[int], str]:
    allowed = os.sched_getaffinity(0)
    if not cpus:
        return allowed, ''
    usable = set(cpus) & allowed
    missing = sorted(set(cpus) - allowed)
    if not usable:
        return allowed, f'CPUs {list(cpus)} not available (this process may use {sorted(allowed)})'
    return usable, f'CPUs {missing} not available' if missing else ''


def claim(request: Request, tids: list[int] | None = None) -> Granted:
    """Give threads ``tids`` (default: the calling thread) the ``request`` as permitted; what they got.

    Real time where permitted, else the nice value of :func:`fallback_nice` where permitted (a lower nice value than
    the thread's is kept), else the normal policy as it was; the CPU set in each case. Ids that are not (or no longer)
    threads of this process are skipped."""
    own = set(thread_ids())
    tids = [threading.get_native_id()] if tids is None else [t for t in tids if t in own]
    if not hasattr(os, 'sched_setscheduler'):
        return Granted(NORMAL, 0, 0, (), len(tids), f'no real-time scheduling on {sys.platform}')
    cpus, refused = _usable_cpus(request.cpus)
    nice = fallback_nice(request.priority)
    realtime = request.priority > 0
    done = 0
    for tid in tids:
        try:
            os.sched_setaffinity(tid, cpus)
        except ProcessLookupError:
            continue
        except OSError as exc:
            refused = refused or f'CPU affinity: {exc.strerror}'
        if realtime:
            try:
                _set_realtime(tid, request.priority)
            except ProcessLookupError:
                continue
            except OSError as exc:  # EPERM without CAP_SYS_NICE, above an RLIMIT_RTPRIO allowance
                realtime = _within_allowance(tid, request.priority)
                why = f'SCHED_RR {request.priority}: {exc.strerror}' + (
                    f' (RLIMIT_RTPRIO: SCHED_RR {_rtprio_limit()})' if realtime else '')
                if why not in refused:
                    refused = f'{why}; {refused}' if refused else why
        if not realtime:
            if os.sched_getscheduler(tid) & ~_RESET_ON_FORK != os.SCHED_OTHER:
                os.sched_setscheduler(tid, os.SCHED_OTHER, os.sched_param(0))
            try:
                if nice < os.getpriority(os.PRIO_PROCESS, tid):  # never lower what a launcher gave
                    os.setpriority(os.PRIO_PROCESS, tid, nice)
            except ProcessLookupError:
                continue
            except OSError as exc:
                why = f'nice {nice}: {exc.strerror}'
                refused += '' if why in refused else f'{"; " if refused else ""}{why}'
        done += 1
    got = scheduling_of_thread(tids[0] if done else threading.get_native_id())
    return Granted(got.policy, got.priority, got.nice, got.cpus, done, refused)


def _set_realtime(tid: int, priority: int) -> None:
    os.sched_setscheduler(tid, _RT_POLICY | _RESET_ON_FORK, os.sched_param(priority))


def _rtprio_limit() -> int:
    """The soft RLIMIT_RTPRIO of this process (the priority it may claim without CAP_SYS_NICE)."""
    import resource
    return int(resource.getrlimit(resource.RLIMIT_RTPRIO)[0])


def _within_allowance(tid: int, priority: int) -> bool:
    """After a refusal of ``priority``: the highest priority RLIMIT_RTPRIO allows, if any (a
    container's ``--ulimit rtprio``); whether it was granted."""
    allowed = min(_rtprio_limit(), priority - 1)
    if allowed < 1:
        return False
    try:
        _set_realtime(tid, allowed)
    except OSError:
        return False
    return True


def claim_thread(request: Request, name: str = '') -> Granted:
    """:func:`claim` for the calling thread, named ``name`` first (for ps, top and /proc)."""
    if name:
        name_thread(name)
    return claim(request)


def background(name: str = '') -> Granted:
    """The calling thread at the normal policy and nice 0, on every CPU of the process: a thread
    off the command path (a worker) that a real-time thread started."""
    if name:
        name_thread(name)
    tid = threading.get_native_id()
    if hasattr(os, 'sched_setscheduler'):
        try:
            if os.sched_getscheduler(tid) & ~_RESET_ON_FORK != os.SCHED_OTHER:
                os.sched_setscheduler(tid, os.SCHED_OTHER, os.sched_param(0))
            if os.getpriority(os.PRIO_PROCESS, tid) < 0:
                os.setpriority(os.PRIO_PROCESS, tid, 0)
        except OSError:  # a thread may always lower its own priority; nothing else to do
            pass
    return scheduling_of_thread(tid)


def demote(tids: list[int]) -> None:
    """Threads ``tids`` of this process to the normal policy (started by a real-time thread,
    they inherited its policy; a library's helper threads that only pass work along)."""
    for tid in tids:
        try:
            if os.sched_getscheduler(tid) & ~_RESET_ON_FORK != os.SCHED_OTHER:
                os.sched_setscheduler(tid, os.SCHED_OTHER, os.sched_param(0))
        except OSError:  # gone meanwhile
            pass


def scheduling_of_thread(tid: int) -> Granted:
    """How thread ``tid`` of this process is scheduled now."""
    policy = os.sched_getscheduler(tid) & ~_RESET_ON_FORK
    name = {os.SCHED_OTHER: NORMAL, getattr(os, 'SCHED_RR', -1): 'SCHED_RR',
            getattr(os, 'SCHED_FIFO', -1): 'SCHED_FIFO'}.get(policy, f'policy {policy}')
    priority = os.sched_getparam(tid).sched_priority if name != NORMAL else 0
    return Granted(name, priority, os.getpriority(os.PRIO_PROCESS, tid),
                   tuple(sorted(os.sched_getaffinity(tid))), 1)


_process: tuple[Request, Granted] | None = None


def set_process_scheduling(request: Request, granted: Granted) -> None:
    """Record what this process' command path asked for and got (every node's diagnostics
    reports it; a thread that takes over the spinning claims the same)."""
    global _process
    _process = (request, granted)


def process_scheduling() -> Granted | None:
    """What this process' command path got, or None when no node claimed any."""
    return None if _process is None else _process[1]


def process_request() -> Request | None:
    """What this process' command path asked for, or None when no node claimed any."""
    return None if _process is None else _process[0]
