"""What the robot did during a fault, from the records of rrps_testing.netns_agent (pure Python and NumPy): a
fault at ``t0`` (``time.time()``) is compared with the records' receipt times and stamps, on the host's one wall
clock; status values are read through their typed contracts, never their human text."""

from __future__ import annotations

import math

import numpy as np

from rrps_interfaces.climb import ClimbStatus
from rrps_interfaces.teleop import TeleopStatus

__all__ = ['teleop', 'climb', 'length_change', 'pose_change', 'gripper_openings', 'both_open',
           'last_stamp', 'in_window', 'first']


def teleop(record: dict) -> TeleopStatus:
    """The typed teleop/status of a record."""
    return TeleopStatus.from_values(record['values'])


def climb(record: dict) -> ClimbStatus:
    """The typed climb/status of a record."""
    return ClimbStatus.from_values(record['values'])


def in_window(records: list[dict], start: float, end: float, by: str = 't') -> list[dict]:
    """The records whose ``by`` time (receipt ``t`` or ``stamp``) lies in [start, end]."""
    return [r for r in records if start <= r.get(by, -math.inf) <= end]


def first(records: list[dict], predicate, start: float = -math.inf) -> dict | None:
    """The first record received at or after ``start`` that satisfies ``predicate``."""
    for r in records:
        if r['t'] >= start and predicate(r):
            return r
    return None


def _at(records: list[dict], t: float, by: str) -> dict | None:
    """The last record at or before ``t``."""
    before = [r for r in records if r.get(by, math.inf) <= t]
    return before[-1] if before else None


def length_change(states: list[dict], start: float, end: float) -> float:
    """Largest change [m] of any leg length between ``start`` and any sample up to ``end``
    (actuators/state samples by their stamps; the reference is the last sample at or before
    ``start``, else the first one after it). NaN without samples."""
    window = in_window(states, start, end, by='stamp')
    ref = _at(states, start, 'stamp') or (window[0] if window else None)
    if ref is None or not window:
        return math.nan
    base = np.asarray(ref['lengths'])
    return float(max(np.max(np.abs(np.asarray(r['lengths']) - base)) for r in window))


def pose_change(poses: list[dict], start: float, end: float) -> float:
    """Largest displacement [m] of the measured pose from its value at ``start`` (by stamps)."""
    window = in_window(poses, start, end, by='stamp')
    ref = _at(poses, start, 'stamp') or (window[0] if window else None)
    if ref is None or not window:
        return math.nan
    base = np.asarray(ref['p'])
    return float(max(np.linalg.norm(np.asarray(r['p']) - base) for r in window))


def gripper_openings(grippers: list[dict], start: float, end: float) -> int:
    """How many times a ring's gripper went from closed to open in [start, end] (receipts),
    counting from the state before ``start``."""
    state = _at(grippers, start, 't')
    previous = dict(state['closed']) if state else None
    count = 0
    for r in in_window(grippers, start, end):
        if previous is not None:
            count += sum(1 for ring, closed in r['closed'].items()
                         if previous.get(ring, True) and not closed)
        previous = dict(r['closed'])
    return count


def both_open(grippers: list[dict]) -> bool:
    """Whether grippers/state ever showed both rings open (the robot let go)."""
    return any(not any(r['closed'].values()) for r in grippers)


def last_stamp(records: list[dict], start: float, end: float) -> float | None:
    """The newest header stamp among the records received in [start, end]."""
    stamps = [r['stamp'] for r in in_window(records, start, end) if 'stamp' in r]
    return max(stamps) if stamps else None
