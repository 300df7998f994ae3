"""The scheduling of a node process' command path, claimed from its nodes' parameters.

Each node of the command path declares ``rt_priority`` and ``cpu_affinity``
(:func:`rrps_runtime.scheduling.scheduling_parameters`). Once a process has built its nodes,
:func:`claim_command_path` merges their requests (the highest priority, the CPUs of all) and
claims them for the thread that spins the executor and for the middleware's delivery threads:
the threads through which every command of the process passes. Threads the nodes started for
other work keep the normal policy. Every node logs one line with what was granted, and its
status on /diagnostics carries it (:class:`rrps_interfaces.status.SchedulingStatus`).
"""

from __future__ import annotations

import sys
import threading
from functools import reduce
from typing import Sequence

from rclpy.node import Node

from rrps_runtime.scheduling import (
    Granted,
    Request,
    claim,
    middleware_threads,
    name_thread,
    request_of,
    set_process_scheduling,
)

__all__ = ['claim_command_path', 'SWITCH_INTERVAL']

#: [s] The interpreter's switch interval in a process with a real-time command path: a
#: real-time thread that asks for the GIL gets it within this time of a running holder
#: (Python's default, 5 ms, is a fifth of a 25 ms budget).
SWITCH_INTERVAL = 5e-4


def _request(node: Node) -> Request | None:
    if not (node.has_parameter('rt_priority') and node.has_parameter('cpu_affinity')):
        return None
    return request_of({'rt_priority': node.get_parameter('rt_priority').value,
                       'cpu_affinity': node.get_parameter('cpu_affinity').value})


def claim_command_path(nodes: Sequence[Node], *, thread_id: int | None = None) -> Granted | None:
    """Claim the scheduling the ``nodes`` ask for, for the executor's thread (``thread_id``,
    default the calling thread) and the middleware's threads; what was granted (None when no
    node asks). Logs one line per node."""
    requests = [r for r in map(_request, nodes) if r is not None]
    if not requests:
        return None
    request = reduce(Request.merged, requests)
    if thread_id is None:
        name_thread('rrps-executor')
        thread_id = threading.get_native_id()
    granted = claim(request, [thread_id, *middleware_threads()])
    if granted.realtime:
        sys.setswitchinterval(min(sys.getswitchinterval(), SWITCH_INTERVAL))
    set_process_scheduling(granted)
    asked = f'SCHED_RR {request.priority}' if request.priority else 'the normal policy'
    for node in nodes:
        node.get_logger().info(f'command path scheduling: {granted.text()} (asked {asked})')
    return granted
