"""The scheduling of a node process' command path, claimed from its nodes' ``rt_priority`` and ``cpu_affinity``.

:func:`claim_command_path` merges the nodes' requests and claims them for the threads every command passes through:
the executor's, its timer threads, the middleware's delivery threads and those a node named as its operator's input
(:data:`~rrps_runtime.scheduling.INPUT_THREAD`; docs/deployment.md, "Process layout and priorities"). Threads
started later keep the normal policy; each node logs and reports what was granted.
"""

from __future__ import annotations

import sys
import threading
from functools import reduce
from typing import Sequence

from rclpy.exceptions import ParameterUninitializedException
from rclpy.node import Node
from rclpy.task import Future

from rrps_runtime.scheduling import (
    Granted,
    Request,
    claim,
    input_threads,
    middleware_threads,
    name_thread,
    process_request,
    request_of,
    set_process_scheduling,
    thread_ids,
)

__all__ = ['claim_command_path', 'claim_executor', 'claim_spinning_thread', 'SWITCH_INTERVAL']

#: [s] The interpreter's switch interval in a process with a real-time command path: a
#: real-time thread that asks for the GIL gets it within this time of a running holder
#: (Python's default, 5 ms, is a fifth of a 25 ms budget).
SWITCH_INTERVAL = 5e-4


def _request(node: Node) -> Request | None:
    if not (node.has_parameter('rt_priority') and node.has_parameter('cpu_affinity')):
        return None
    try:
        cpus = node.get_parameter('cpu_affinity').value
    except ParameterUninitializedException:  # left unset: every CPU
        cpus = None
    return request_of({'rt_priority': node.get_parameter('rt_priority').value, 'cpu_affinity': cpus})


def claim_command_path(nodes: Sequence[Node], executor) -> Granted | None:
    """Claim the scheduling the ``nodes`` ask for, for the calling thread (the one that spins
    ``executor``, which holds the nodes), the executor's timer threads, the middleware's threads
    and the operator's input threads; what was granted (None when no node asks). Logs one line
    per node."""
    requests = [r for r in map(_request, nodes) if r is not None]
    if not requests:
        return None
    request = reduce(Request.merged, requests)
    granted = claim_executor(request, executor)
    if granted.realtime:
        sys.setswitchinterval(min(sys.getswitchinterval(), SWITCH_INTERVAL))
    set_process_scheduling(request, granted)
    asked = f'SCHED_RR {request.priority}' if request.priority else 'the normal policy'
    for node in nodes:
        node.get_logger().info(f'command path scheduling: {granted.text()} (asked {asked})')
    return granted


def claim_executor(request: Request, executor) -> Granted:
    """``request`` for the calling thread (the one that spins ``executor``), the threads the
    executor starts for its timers (spun once here, so that they exist), the middleware's and the
    operator's input threads."""
    name_thread('rrps-executor')
    before = set(thread_ids())
    executor.spin_until_future_complete(Future(), timeout_sec=0.0)  # its timer threads start
    started = sorted(set(thread_ids()) - before)
    return claim(request, [threading.get_native_id(), *started, *middleware_threads(), *input_threads()])


def claim_spinning_thread() -> Granted | None:
    """The calling thread, which takes over spinning the executor of a process whose command path
    was claimed, with the same scheduling (None when none was claimed)."""
    request = process_request()
    if request is None:
        return None
    name_thread('rrps-executor')
    return claim(request)
