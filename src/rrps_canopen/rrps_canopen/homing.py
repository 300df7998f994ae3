"""Homing the drives of a bus as CiA 402 specifies it, and checking where it left the legs.

:func:`set_mode` writes a mode (0x6060) and waits until the drive shows it (0x6061); :func:`home`
homes the drives that need it (the sequence: docs/connecting-a-robot.md, 'Homing') while the others
stay disabled; :func:`check_positions` checks home position, stroke and forward kinematics. A
failed or implausible homing is a fault (:attr:`FaultKind.HOMING`) that leaves every drive
disabled (:func:`refuse`). Pure Python, no ROS import.
"""

from __future__ import annotations

import time

import numpy as np

from rrps_canopen.cia402 import HomingStatus, Mode, homing_status
from rrps_canopen.drive import ConfigureError, RemoteDrive, mode_text, object_text
from rrps_description.bus import DriveConfig
from rrps_description.geometry import RobotGeometry
from rrps_hardware.interface import FaultKind
from rrps_kinematics.forward import forward_kinematics
from rrps_kinematics.limits import pose_margins

__all__ = ['set_mode', 'home', 'check_positions', 'refuse', 'homing_timeout']

#: [s] more than the longest stroke at the homing speed that a homing may take.
HOMING_SLACK = 2.0
#: How far below zero a pose margin (joint cones [rad], interference [m], conditioning) may be
#: and the pose still count as within the limits after homing (rounding at a limit).
MARGIN_TOLERANCE = 1e-6
#: One solve at activation: the NumPy backend answers in a millisecond, where loading the numba
#: kernels into the driver's process would hold the first activation for seconds.
CHECK_BACKEND = 'numpy'


def homing_timeout(drives: list[RemoteDrive]) -> float:
    """[s] the longest a homing of ``drives`` may take: a stroke and back at the homing speed, and
    the slack."""
    return max((2.0 * (d.config.max_position - d.config.min_position) / d.config.homing_speed for d in drives),
               default=0.0) + HOMING_SLACK


def set_mode(drive_set, drives: list[RemoteDrive], mode: Mode) -> str:
    """Write ``mode`` to each drive's 0x6060 and wait until its 0x6061 shows it (within
    ``bus.mode_timeout``); '' or why not, naming the drives."""
    timeout = drive_set.bus.mode_timeout
    try:
        for d in drives:
            d.write_object(0x6060, None, int(mode))
        deadline = time.monotonic() + timeout
        shown = {d.name: d.read_object(0x6061) for d in drives}
        while any(m != int(mode) for m in shown.values()) and time.monotonic() <= deadline:
            time.sleep(drive_set.period)
            shown = {d.name: m if m == int(mode) else d.read_object(0x6061) for d, m in zip(drives, shown.values())}
    except ConfigureError as exc:
        return str(exc)
    late = [f'{d} still shows {mode_text(shown[d.name])}' for d in drives if shown[d.name] != int(mode)]
    if late:
        return (f'{"; ".join(late)} in {object_text(0x6061)} {timeout:g} s after {mode_text(int(mode))} was written '
                '(bus.mode_timeout)')
    return ''


def _fresh_after(drive_set, t0: float) -> float | None:
    """The time of the second SYNC sent after ``t0`` (a statusword after it answers the start
    bit), or None when it has not gone out yet."""
    with drive_set.lock:
        after = []
        for t in reversed(drive_set.sync_times):
            if t <= t0:
                break
            after.append(t)
    return after[-2] if len(after) >= 2 else None


def home(drive_set, drives: list[RemoteDrive], timeout: float) -> tuple[str, dict[str, HomingStatus] | None]:
    """Home ``drives`` (see the module docstring); ('' or why not, each drive's last homing status
    seen, None when homing did not start). They are left enabled in homing mode with the start
    bit low."""
    reason = set_mode(drive_set, drives, Mode.HOMING) or drive_set.enable(drives=drives)
    if reason:
        return reason, None
    names = {d.name for d in drives}
    with drive_set.lock:
        drive_set.homing_start.update(names)
        t0 = time.monotonic()
    fresh: list[float | None] = [None]
    statuses: dict[str, HomingStatus] = {}

    def missing() -> str | None:
        if fresh[0] is None:
            fresh[0] = _fresh_after(drive_set, t0)
            if fresh[0] is None:
                return 'the start bit is not out yet'
        for d in drives:
            data = drive_set.data[d.name]
            if data.tpdo_time is not None and data.tpdo_time > fresh[0]:
                statuses[d.name] = homing_status(data.statusword)
        busy = [f'{d} {statuses[d.name].value if d.name in statuses else "has sent no statusword since the start"}'
                for d in drives if statuses.get(d.name) not in (HomingStatus.COMPLETED, HomingStatus.ERROR)]
        return ', '.join(busy) or None

    reason = drive_set.wait(missing, timeout, 'homing')
    with drive_set.lock:
        drive_set.homing_start.difference_update(names)
        drive_set.hold()  # the targets in the homed count, before any mode that follows them
    failed = [str(d) for d in drives if statuses.get(d.name) is HomingStatus.ERROR]
    if failed:
        reason = f'homing error (statusword bit 13) on {", ".join(failed)}' + (f'; {reason}' if reason else '')
    return reason, statuses


def check_positions(geometry: RobotGeometry, drives: tuple[DriveConfig, ...], lengths: np.ndarray,
                    homed: set[str]) -> dict[str, str]:
    """{leg: why it cannot be where its drive says} ({} when every leg can be there) of the legs
    of ``drives`` at ``lengths`` [m]; ``homed``: the legs homed just now (see the module
    docstring). The tolerance is each drive's following-error window: the distance the drive
    itself lets its axis be off."""
    problems: dict[str, str] = {}
    for c, x in zip(drives, lengths):
        tol = c.following_error
        if c.actuator in homed and abs(x - c.home_position) > tol:
            problems[c.actuator] = (f'homed at {x:.4f} m, not at its home position {c.home_position:.4f} m '
                                    f'(bus.drives.{c.actuator}.home_position): the drive did not take '
                                    f'{object_text(0x607C)}, or its homing method finds another place')
        elif not geometry.min_length - tol <= x <= geometry.max_length + tol:
            problems[c.actuator] = (f'reads {x:.4f} m, outside the stroke [{geometry.min_length}, '
                                    f'{geometry.max_length}] m: not homed, or a wrong offset or counts_per_metre')
    if problems:
        return problems
    fk = forward_kinematics(geometry, lengths, tolerance=1e-9, backend=CHECK_BACKEND)
    lengths_text = ', '.join(f'{x:.4f}' for x in lengths)
    if not bool(fk.converged) or bool(fk.singular):
        return {c.actuator: f'the six lengths [{lengths_text}] m assemble no pose of the robot (forward kinematics '
                            'did not converge): a leg is not where its drive says' for c in drives}
    if homed:  # the stroke is checked above, leg by leg
        margins = pose_margins(geometry, fk.position, fk.quaternion_xyzw, backend=CHECK_BACKEND).minimum
        broken = ', '.join(f'{kind} margin {m:.4g}' for kind, m in margins.items()
                           if kind != 'stroke' and not m >= -MARGIN_TOLERANCE)
        if broken:
            return {c.actuator: f'the six lengths [{lengths_text}] m put the robot outside its limits ({broken})'
                    for c in drives}
    return {}


def refuse(drive_set, problems: dict[str, str], *, fault: bool) -> str:
    """Disable every drive (nothing moves), then, with ``fault``, latch a homing fault on each
    drive of ``problems``; the refusal's text."""
    why = drive_set.disable()
    if fault:
        now = time.monotonic()
        for name, detail in problems.items():
            drive_set.latch(name, FaultKind.HOMING, detail, now)
    groups: dict[str, list[str]] = {}
    for name, detail in problems.items():
        groups.setdefault(detail, []).append(name)
    text = '; '.join(f'{", ".join(names)}: {detail}' for detail, names in groups.items())
    return text + (f' (and {why})' if why else '')
