"""replay_node: publishes a recording again, with its QoS, at any rate, with pause and seek.

A recording (a bag folder, ``rrps-record``'s or ``ros2 bag record -s mcap``'s, or MCAP files) is published on
its recorded names, the CDR bytes as recorded, with the reliability and durability its publishers offered
(:func:`rrps_recording.storage.qos.offer_for_replay`), at the recorded pace times ``rate``; a topic whose type
is not installed is skipped and named in the status. Safety: a replay never feeds a live robot: the command
streams go under ``<namespace>/<remap_prefix>/`` unless ``allow_commands``. ``/clock`` is the recording's time
where the replay is, for nodes with ``use_sim_time:=true``; the replay itself is paced by the steady clock.
``rate``, ``paused`` and ``seek`` are set at run time (the viewer's timeline); ``replay/status`` (values
:class:`ReplayStatus`) says where the replay is. See docs/recording.md, 'Replay'.

    replay_node --ros-args -p files:=[recordings/session] -p rate:=2.0
"""

from __future__ import annotations

import threading
import time

import rclpy
from diagnostic_msgs.msg import DiagnosticStatus, KeyValue
from rclpy.clock import Clock as NodeClock
from rclpy.clock_type import ClockType
from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy
from rosgraph_msgs.msg import Clock

from rrps_interfaces.recording import CLOCK, REPLAY_PREFIX, REPLAY_STATUS, ReplayStatus
from rrps_recording.storage.qos import offer_for_replay
from rrps_recording.storage.schemas import message_class
from rrps_recording.transport.replay import RecordingSet, ReplayClock, is_command_topic, replay_topic
from rrps_runtime.diagnostics import OBSERVER, OK, STALE, WARN, Diagnostics
from rrps_runtime.parameter_schema import NodeParameters, Parameter
from rrps_runtime.parameters import declare_parameters
from rrps_runtime.process import run_nodes
from rrps_runtime.qos import CLOCK_QOS, STATE_QOS

__all__ = ['ReplayNode', 'main']

#: replay_node's parameters (descriptors, the shipped file and the docs' table come from here).
PARAMETERS = NodeParameters('replay_node', 'rrps_recording', [
    Parameter('files', ('',), 'a bag folder or the MCAP file(s) of one recording'),
    Parameter('rate', 1.0, 'replay speed (1.0 = as recorded)', range=(0.01, 100.0), dynamic=True),
    Parameter('paused', False, 'hold the replay where it is', dynamic=True),
    Parameter('seek', -1.0, 'set to a time from the start to jump there', unit='s', range=(-1.0, 1e9),
              dynamic=True),
    Parameter('start', 0.0, 'start this far into the recording', unit='s', range=(0.0, 1e9)),
    Parameter('loop', False, 'start again at the end', dynamic=True),
    Parameter('allow_commands', False, 'publish the command streams on their live names (default: under '
              'remap_prefix)'),
    Parameter('remap_prefix', REPLAY_PREFIX, 'where the command streams go unless allow_commands'),
    Parameter('topics', ('',), "recorded topics to replay ('' = all)"),
    Parameter('status_rate', 10.0, 'replay/status rate', unit='Hz', range=(0.5, 100.0)),
    Parameter('exit_at_end', False, 'shut down when the recording ends (no loop)'),
    Parameter('clock_rate', 40.0, "rate of /clock, the recording's time (0: no /clock)", unit='Hz',
              range=(0.0, 1000.0)),
])


class ReplayNode(Node):
    """Replays a recording; see the module docstring."""

    def __init__(self, **kwargs):
        super().__init__('replay_node', **kwargs)
        values = declare_parameters(self, PARAMETERS)
        files = values['files']
        rate, paused, start = values['rate'], values['paused'], values['start']
        self.loop = values['loop']
        self.allow_commands = values['allow_commands']
        prefix = values['remap_prefix']
        topics = [t for t in values['topics'] if t]
        self.exit_at_end = values['exit_at_end']
        files = [f for f in files if f]
        if not files:
            raise ValueError('files: give the recording to replay (-p files:=[bag_folder])')
        self.recording = RecordingSet(files)
        self.files = files
        self.clock = ReplayClock(self.recording.start_ns, self.recording.end_ns, rate=rate,
                                 paused=paused, now=time.monotonic())
        if start > 0.0:
            self.clock.seek(self.recording.start_ns + int(start * 1e9), time.monotonic())
        self._cond = threading.Condition()
        self.published = 0
        self.finished = False
        self.skipped: dict[str, str] = {}
        self.remapped: dict[str, str] = {}
        self._replay_publishers: dict[str, object] = {}
        for name, topic in self.recording.topics.items():
            if topics and not any(name == t or name.startswith(t.rstrip('/') + '/')
                                  for t in topics):
                continue
            if name.endswith('/' + REPLAY_STATUS):
                continue  # a recorded replay's status is not this replay's
            try:
                cls = message_class(topic.type)
            except (ImportError, AttributeError, ValueError) as exc:
                self.skipped[name] = f'{topic.type} is not installed ({exc})'
                continue
            out = replay_topic(name, allow_commands=self.allow_commands, prefix=prefix)
            if out != name:
                self.remapped[name] = out
            spec = offer_for_replay(list(topic.offered_qos))
            qos = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=spec.depth,
                             reliability=ReliabilityPolicy(spec.reliability),
                             durability=DurabilityPolicy(spec.durability))
            self._replay_publishers[name] = self.create_publisher(cls, out, qos)
        if self.allow_commands and any(is_command_topic(n) for n in self._replay_publishers):
            self.get_logger().warning('allow_commands: the recorded command streams go to '
                                      'their live names; a driver listening will act on them')
        self._status_pub = self.create_publisher(DiagnosticStatus, REPLAY_STATUS, STATE_QOS)
        self._diag = Diagnostics(self, 'replay', hardware_id=OBSERVER, rate_hz=1.0)
        self.add_post_set_parameters_callback(self._apply_parameters)
        steady = NodeClock(clock_type=ClockType.STEADY_TIME)
        self.create_timer(1.0 / values['status_rate'], self._report, clock=steady)
        if values['clock_rate'] > 0.0:
            self._clock_pub = self.create_publisher(Clock, CLOCK, CLOCK_QOS)
            self.create_timer(1.0 / values['clock_rate'], self._publish_clock, clock=steady)
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, name='replay', daemon=True)
        self._thread.start()
        self.get_logger().info(
            f'replaying {", ".join(files)} ({self.recording.duration:.1f} s, '
            f'{len(self._replay_publishers)} topics) at {rate:g}x'
            + (f'; commands under {prefix}/: {", ".join(self.remapped.values())}'
               if self.remapped else '')
            + (f'; skipped: {", ".join(sorted(self.skipped))}' if self.skipped else ''))

    # --- control -------------------------------------------------------------------------------

    def _apply_parameters(self, parameters) -> None:
        """``rate``, ``paused``, ``seek`` and ``loop`` take effect at once."""
        now = time.monotonic()
        with self._cond:
            for p in parameters:
                if p.name == 'rate':
                    self.clock.set_rate(float(p.value), now)
                elif p.name == 'paused':
                    self.clock.set_paused(bool(p.value), now)
                elif p.name == 'seek' and float(p.value) >= 0.0:
                    self.clock.seek(self.recording.start_ns + int(float(p.value) * 1e9), now)
                    self.finished = False
                elif p.name == 'loop':
                    self.loop = bool(p.value)
            self._cond.notify_all()

    def status(self) -> ReplayStatus:
        """Where the replay is now."""
        with self._cond:
            now = time.monotonic()
            return ReplayStatus(
                time=self.clock.elapsed(now), duration=self.recording.duration,
                rate=self.clock.rate, paused=self.clock.paused, finished=self.finished,
                file=self.files[0], published=self.published,
                remapped=tuple(sorted(self.remapped.values())), skipped=tuple(sorted(self.skipped)))

    def _publish_clock(self) -> None:
        """/clock: the recording's time where the replay is now."""
        with self._cond:
            ns = self.clock.position(time.monotonic())
        msg = Clock()
        msg.clock.sec, msg.clock.nanosec = divmod(ns, 1_000_000_000)
        self._clock_pub.publish(msg)

    def _report(self) -> None:
        status = self.status()
        level = STALE if status.finished else WARN if self.skipped else OK
        message = ('finished' if status.finished else 'paused' if status.paused
                   else f'replaying at {status.rate:g}x')
        msg = DiagnosticStatus(level=level, name=f'{self.get_name()}: replay', message=message,
                               hardware_id=OBSERVER)
        msg.values = [KeyValue(key=k, value=v) for k, v in status.to_values().items()]
        self._status_pub.publish(msg)
        self._diag.report(level, message, status)

    # --- the publishing thread ----------------------------------------------------------------

    def _run(self) -> None:
        while not self._stop.is_set():
            with self._cond:
                epoch = self.clock.epoch
                start = self.clock.read_from
            restarted = False
            for topic, t, data in self.recording.messages(start, list(self._replay_publishers)):
                with self._cond:
                    while not self._stop.is_set() and self.clock.epoch == epoch:
                        wait = self.clock.wait(t, time.monotonic())
                        if wait <= 0.0:
                            break
                        self._cond.wait(min(wait, 0.1))
                    if self._stop.is_set():
                        return
                    if self.clock.epoch != epoch:
                        restarted = True
                        break
                publisher = self._replay_publishers.get(topic)
                if publisher is not None:
                    try:
                        publisher.publish(data)
                    except Exception as exc:  # the context went away during shutdown
                        if self._stop.is_set() or not self.context.ok():
                            return
                        raise exc
                    self.published += 1
            if restarted:
                continue
            with self._cond:
                if self.clock.epoch != epoch:
                    continue
                if self.loop:
                    self.clock.seek(self.recording.start_ns, time.monotonic())
                    continue
                self.finished = True
                self.clock.seek(self.recording.end_ns, time.monotonic())
                epoch = self.clock.epoch
            if self.exit_at_end:
                self.get_logger().info(f'finished: {self.published} messages published')
                self._report()
                rclpy.try_shutdown(context=self.context)
                return
            with self._cond:
                while not self._stop.is_set() and self.clock.epoch == epoch:
                    self._cond.wait(0.2)

    def destroy_node(self) -> None:
        self._stop.set()
        with self._cond:
            self._cond.notify_all()
        self._thread.join(timeout=5.0)
        super().destroy_node()


def main(args=None) -> None:
    run_nodes([ReplayNode], args)


if __name__ == '__main__':
    main()
