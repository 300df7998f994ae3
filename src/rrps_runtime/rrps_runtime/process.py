"""A node process: executors, spinning until shutdown, and the Jazzy ``main()`` of every node."""

from __future__ import annotations

import faulthandler
import signal
import sys
import threading
from typing import Callable, Sequence

import rclpy
from rclpy.exceptions import ParameterException
from rclpy.executors import ExternalShutdownException, SingleThreadedExecutor
from rclpy.node import Node
from rclpy.signals import SignalHandlerOptions
from rclpy.task import Future

from rrps_description.geometry import RobotDescriptionError
from rrps_runtime.collector import freeze_startup_objects, thaw
from rrps_runtime.command_path import claim_command_path
from rrps_runtime.supervision import SHUTDOWN_DEADLINE, exit_with_parent

__all__ = ['SHUTDOWN_DEADLINE', 'make_executor', 'spin_until_shutdown', 'run_nodes']


def make_executor(context, kind: str = 'events'):
    """An EventsExecutor (the default: lower latency, docs/measurements.md) or a SingleThreadedExecutor."""
    if kind == 'events':
        from rclpy.experimental import EventsExecutor
        return EventsExecutor(context=context)
    if kind == 'single':
        return SingleThreadedExecutor(context=context)
    raise ValueError(f"executor kind must be 'events' or 'single', got {kind!r}")


def spin_until_shutdown(executor, context, stop: threading.Event | None = None, *,
                        period: float = 0.1) -> None:
    """Spin until the context shuts down, ``stop`` is set, or Ctrl-C, in slices of ``period`` s: rclpy 7.1's
    EventsExecutor.spin() blocks in C++, never sees SIGINT and hangs when shut down from another thread."""
    never = Future()
    while context.ok() and not (stop is not None and stop.is_set()):
        executor.spin_until_future_complete(never, timeout_sec=period)


def run_nodes(factories: Sequence[Callable[..., Node]], args=None, *, executor_kind: str = 'events') -> None:
    """Jazzy ``main()`` pattern: init, spin the nodes (classes taking ``context=``) in one executor, clean shutdown.

    A node that cannot start (an invalid robot description or parameter) prints one line and exits with status 2.
    SIGINT, SIGTERM and the supervisor's death end the spin between callbacks; a second signal does not cut the
    shutdown short (:func:`_finishing`). The spinning thread claims the nodes' scheduling
    (:func:`rrps_runtime.command_path.claim_command_path`).
    """
    stop = _StopRequest()
    exit_with_parent(stop.request)
    context = rclpy.Context()
    rclpy.init(args=args, context=context, signal_handler_options=SignalHandlerOptions.NO)
    previous = {sig: signal.signal(sig, stop.request) for sig in (signal.SIGINT, signal.SIGTERM)}
    nodes: list[Node] = []
    try:
        try:
            for factory in factories:
                nodes.append(factory(context=context))
        except (RobotDescriptionError, ValueError, ParameterException) as exc:
            print(f'error: {exc}', file=sys.stderr)
            raise SystemExit(2) from None
        executor = make_executor(context, executor_kind)
        for node in nodes:
            executor.add_node(node)
        freeze_startup_objects()
        claim_command_path(nodes, executor)
        spin_until_shutdown(executor, context, stop.event)
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    finally:
        stop.request()   # the deadline, if no request armed it: until the process ends
        for sig in previous:  # until the process ends: the interpreter's own exit takes a while too
            signal.signal(sig, _finishing)
        for node in nodes:
            node.destroy_node()
        rclpy.try_shutdown(context=context)
        thaw()


class _StopRequest:
    """A node process' stop: :meth:`request` (a signal, the supervisor's death) sets :attr:`event`, and from the
    first request on the process ends within :data:`SHUTDOWN_DEADLINE` s whatever its main thread does (every
    thread's traceback printed, exit status 1): a node blocked in its start-up still ends with its supervisor."""

    def __init__(self):
        self.event = threading.Event()
        self._unarmed = threading.Lock()

    def request(self, *_) -> None:
        self.event.set()
        if self._unarmed.acquire(blocking=False):   # armed once: later requests do not extend it
            faulthandler.dump_traceback_later(SHUTDOWN_DEADLINE, exit=True)


def _finishing(signum, _frame) -> None:
    """A SIGINT or SIGTERM during the shutdown (Ctrl-C pressed again, ``ros2 launch``'s SIGTERM after its
    SIGINT): the shutdown goes on, so that the nodes close what they hold (a recording, the hardware's state);
    :data:`SHUTDOWN_DEADLINE` still bounds it, SIGKILL still ends it at once."""
    print(f'{signal.Signals(signum).name} while shutting down: finishing the shutdown (at most '
          f'{SHUTDOWN_DEADLINE:.0f} s; SIGKILL ends it now)', file=sys.stderr, flush=True)
