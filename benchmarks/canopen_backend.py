"""The CANopen backend's timing against the simulated backend's, in the same run, under load.

Each backend runs as the demo runs it (SCHED_RR where permitted): driver_node in a process of
its own (``publish_on_command``: a command is written to the hardware when it arrives), and for
``canopen`` the drive simulator (``rrps-drive-sim``, a loopback bus of its own, no lag in the
legs). This process sends ``actuators/command`` at ``--rate`` Hz, every leg on a sine of
:data:`AMPLITUDE` at :data:`FREQUENCY` (a smooth stream, as teleop's), and records when each
arrives where. The driver's jerk-limited setpoints follow a stream one command period behind
(they interpolate between commands), so a command's length reaches the drive about one period
after the command: each latency is also given from the next command's sending (``after the
next``), which the setpoints need before they can reach a command's length; both counted where
leg_1 moves (:func:`rrps_testing.command_trace.drive_target_times`):

* **SYNC period**: the drives' receipt times of the SYNCs (the simulator's clock), their
  deviation from the bus' period (p50, p99, max);
* **command -> its first SYNC**: from the driver's receipt of a command to the SYNC cycle that
  sends the first setpoint computed from it, as the driver reports it (``target_latency_*`` of
  its status, 10 s windows: the worst window's p99 and the largest; canopen only);
* **command -> drive target**: from publishing a command to the SYNC whose leg_1 target
  reaches its length (canopen only: the simulated backend has no drive);
* **drive target - stream**: leg_1's target at each SYNC against the commanded sine the
  setpoints' lag earlier (the lag that fits best): whether the setpoints stay on the stream;
* **drive actual -> actuators/state**: from a SYNC at which the drive's actual position is a
  value to the receipt of an ``actuators/state`` that shows it (canopen only);
* **command -> actuators/state**: from publishing a command to the first state that reaches its
  length, both backends;
* **CPU**: of the driver and of the simulator over the run (/proc), per drive for canopen.

Targets: p99 SYNC jitter <= 1 ms and command -> its first SYNC <= one period at p99, with
``rrps_testing.load`` running (a busy core and a DDS flood; ``--no-load``: without). Prints a
table and MET or MISSED for each target. All clocks are this machine's CLOCK_MONOTONIC.

    python benchmarks/canopen_backend.py [--seconds 20] [--rate 200] [--no-load]
"""

from __future__ import annotations

import argparse
import gc
import os
import sys
import time

os.environ.setdefault('ROS_AUTOMATIC_DISCOVERY_RANGE', 'LOCALHOST')
os.environ.setdefault('ROS_DOMAIN_ID', str(100 + os.getpid() % 50))

import numpy as np  # noqa: E402

from rrps_description.geometry import load_robot  # noqa: E402
from rrps_runtime.supervision import stop_children  # noqa: E402
from rrps_testing.canopen_rig import DriveSim, driver_process  # noqa: E402
from rrps_testing.command_trace import drive_target_times, percentiles  # noqa: E402
from rrps_testing.load import Load  # noqa: E402
from rrps_testing.processes import cpu_seconds  # noqa: E402

NAMESPACE = '/rrps_bench'
ROBOT = load_robot('pole_climber')
PERIOD = ROBOT.bus.sync_period
#: The commanded sine of every leg: amplitude [m] and frequency [Hz] (6 mm/s at most).
AMPLITUDE, FREQUENCY = 0.002, 0.5
#: [s] a value not seen this long after it was sent counts as lost, not as late.
LOST_AFTER = 1.0
PARAMS = ('auto_activate:=true', 'publish_on_command:=true', 'time_constant:=0.0', 'limit_speed:=false',
          'timeout:=1.0')


def run_backend(hardware: str, *, seconds: float, rate: float) -> dict:
    import rclpy
    from sensor_msgs.msg import JointState

    from rrps_runtime.messages import joint_state_msg
    from rrps_testing.driver_probe import DriverProbe
    from rrps_testing.ros_harness import Spinner, wait_for

    sim = DriveSim('pole_climber', time_constant=0.0) if hardware == 'canopen' else None
    driver = driver_process(sim.port if sim else 0, *PARAMS, namespace=NAMESPACE, hardware=hardware)
    context = rclpy.Context()
    rclpy.init(context=context)
    try:
        probe = DriverProbe(context=context, namespace=NAMESPACE)
        states = probe.states
        pub = probe.publisher(JointState, 'actuators/command', command=True)
        with Spinner(context, [probe]):
            assert wait_for(lambda: states and pub.get_subscription_count() > 0), driver.poll()
            time.sleep(1.0)
            home = np.round(np.array(states[-1][1].position[:6]), 6)
            if sim:
                sim.ask(cmd='syncs')
                sim.ask(cmd='trace', on=True)
            pids = [driver.pid] + ([sim.process.pid] if sim else [])
            # The probe's own garbage collections (its growing lists of states) stopped its stream
            # and its receipt stamps for up to 180 ms: none while it measures.
            gc.disable()
            cpu0, t0 = [cpu_seconds([p]) for p in pids], time.monotonic()
            sent = []
            k = 0
            while time.monotonic() - t0 < seconds:
                now = time.monotonic()
                lengths = home + AMPLITUDE * np.sin(2.0 * np.pi * FREQUENCY * (now - t0))
                sent.append((now, float(lengths[0])))
                pub.publish(joint_state_msg(probe.get_clock().now().to_msg(), lengths))
                k += 1
                time.sleep(max(0.0, t0 + k / rate - time.monotonic()))
            time.sleep(0.2)
            gc.enable()
            elapsed = time.monotonic() - t0
            cpu = [(cpu_seconds([p]) - c) / elapsed for p, c in zip(pids, cpu0)]
            received = [(t, round(m.position[0], 7)) for t, m in list(states) if t >= t0]
            trace = sim.ask(cmd='trace', on=False)['trace'] if sim else []
            syncs = sim.ask(cmd='syncs')['syncs'] if sim else []
            windows = [(s.target_latency_p99_ms, s.target_latency_max_ms) for t, _, _, s in list(probe.statuses)
                       if t0 + 10.0 <= t <= t0 + elapsed and s.target_latency_p99_ms is not None]
    finally:
        rclpy.try_shutdown(context=context)
        stop_children([driver])
        if sim:
            sim.stop()
    return analyse(sent, received, trace, syncs, cpu) | {'windows': windows}


def first_after(times, values, t, value) -> float | None:
    """The first time in [t, t + LOST_AFTER] at which ``values`` equals ``value`` (None: none; a
    drive that took a newer target before this one's SYNC never shows it)."""
    i, j = np.searchsorted(times, t), np.searchsorted(times, t + LOST_AFTER)
    hits = np.flatnonzero(np.abs(values[i:j] - value) < 5e-7)
    return float(times[i + hits[0]]) if hits.size else None


def _latencies(commands: np.ndarray, series: np.ndarray) -> tuple[list, list]:
    """From each command's sending, and from the next one's, to the first sample of ``series``
    (rows of time, leg_1) that reaches its length [s]."""
    if not len(series):
        return [], []
    rows = drive_target_times(commands, series)
    return (rows[:, 1] - rows[:, 0]).tolist(), (rows[:, 1] - rows[:, 2])[np.isfinite(rows[:, 2])].tolist()


def tracking(sent: np.ndarray, targets: np.ndarray) -> tuple[float, np.ndarray]:
    """The lag [s] (0-30 ms) at which the targets (rows of time, leg_1) fit the sent stream (rows
    of time, leg_1) best, and their deviations [m] from it so delayed, where the stream is known."""
    inside = (targets[:, 0] - 0.03 >= sent[0, 0]) & (targets[:, 0] <= sent[-1, 0])
    t, x = targets[inside, 0], targets[inside, 1]
    lags = np.arange(0.0, 0.030, 0.00025)
    rms = [np.sqrt(np.mean((x - np.interp(t - lag, sent[:, 0], sent[:, 1])) ** 2)) for lag in lags]
    lag = float(lags[int(np.argmin(rms))])
    return lag, x - np.interp(t - lag, sent[:, 0], sent[:, 1])


def analyse(sent, received, trace, syncs, cpu) -> dict:
    commands = np.array([(t, t, v) for t, v in sent]).reshape(-1, 3)   # sent = stamped = received here
    states = np.array(received, dtype=float).reshape(-1, 2)
    result = {'cpu': cpu, 'to_drive': [], 'to_drive_next': [], 'to_state': [], 'jitter': [], 'deviation': [],
              'lag': float('nan')}
    result['round_trip'], result['round_trip_next'] = _latencies(commands, states)
    if syncs:
        result['jitter'] = np.abs(np.diff(syncs) - PERIOD).tolist()
    if trace:
        targets = np.array([(row[0], row[1][0]) for row in trace])
        result['to_drive'], result['to_drive_next'] = _latencies(commands, targets)
        result['lag'], deviation = tracking(commands[:, [0, 2]], targets)
        result['deviation'] = np.abs(deviation).tolist()
        for t, value in ((row[0], round(row[2][0], 7)) for row in trace[::10]):   # the drive's actual
            shown = first_after(states[:, 0], states[:, 1], t, value)
            if shown is not None:
                result['to_state'].append(shown - t)
    return result


def main() -> int:
    p = argparse.ArgumentParser(description=__doc__.split('\n')[0])
    p.add_argument('--seconds', type=float, default=20.0)
    p.add_argument('--rate', type=float, default=200.0, help='actuators/command rate [Hz]')
    p.add_argument('--no-load', action='store_true')
    args = p.parse_args()
    loader = None if args.no_load else Load(busy=1, flood_rate=2000.0, quiet=True)
    results = {}
    try:
        if loader:
            loader.start()
        for hardware in ('simulated', 'canopen'):
            results[hardware] = run_backend(hardware, seconds=args.seconds, rate=args.rate)
    finally:
        if loader:
            loader.stop()
    ms = 1e3
    print(f'\nCANopen backend vs simulated, {args.seconds:.0f} s each, commands at {args.rate:.0f} Hz, '
          f'{"with" if loader else "without"} load; SYNC period {PERIOD * ms:.1f} ms')
    print(f'{"figure [ms]":<34}{"simulated p50/p99/p99.9/max":>32}{"canopen p50/p99/p99.9/max":>32}')
    windows = results['canopen']['windows']
    worst = (max(w[0] for w in windows), max(w[1] for w in windows)) if windows else (float('nan'),) * 2
    print(f'{"command -> its first SYNC (driver)":<34}{"n/a":>32}'
          f'{f"p99 {worst[0]:.2f} (worst of {len(windows)} 10-s windows), max {worst[1]:.2f}":>32}')
    for key, label in (('jitter', 'SYNC jitter (drives\' clock)'), ('to_drive', 'command -> drive target'),
                       ('to_drive_next', '  after the next'),
                       ('deviation', f'|target - stream| [mm], lag {1e3 * results["canopen"]["lag"]:.2f} ms'),
                       ('to_state', 'drive actual -> actuators/state'),
                       ('round_trip', 'command -> actuators/state'), ('round_trip_next', '  after the next')):
        cells = []
        for hardware in ('simulated', 'canopen'):
            values = results[hardware][key]
            figures = (ms * x for x in percentiles(values)[1:])
            cells.append('n/a' if not values else '{:.2f} / {:.2f} / {:.2f} / {:.2f}'.format(*figures))
        print(f'{label:<34}{cells[0]:>32}{cells[1]:>32}')
    sim_cpu, can_cpu = results['simulated']['cpu'], results['canopen']['cpu']
    print(f'{"CPU [% of a core]":<34}{f"driver {100 * sim_cpu[0]:.0f}":>32}'
          f'{f"driver {100 * can_cpu[0]:.0f}, drives {100 * can_cpu[1]:.0f}":>32}')
    print(f'{"CPU per drive [% of a core]":<34}{"":>32}'
          f'{f"driver {100 * (can_cpu[0] - sim_cpu[0]) / 6:.1f}, simulator {100 * can_cpu[1] / 6:.1f}":>32}')
    jitter99 = percentiles(results['canopen']['jitter'])[2]
    met = True
    for text, value, target in (('p99 SYNC jitter <= 1 ms', jitter99, 1e-3),
                                (f'command -> its first SYNC p99 <= one period ({PERIOD * ms:.0f} ms)',
                                 worst[0] / ms, PERIOD)):
        ok = bool(value <= target)
        met &= ok
        print(f'{"MET" if ok else "MISSED"}: {text}: {value * ms:.2f} ms')
    return 0 if met else 1


if __name__ == '__main__':
    sys.exit(main())
