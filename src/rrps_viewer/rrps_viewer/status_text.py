"""The viewer's status panel: the operator's text, rendered from typed statuses only (:mod:`rrps_interfaces.teleop`,
``.driver``, ``.kinematics``), never from another node's message text. Pure Python, no rclpy, no viser.
"""

from __future__ import annotations

import math

import numpy as np

from rrps_interfaces.climb import ClimbPreview, ClimbStatus
from rrps_interfaces.driver import DriverStatus
from rrps_interfaces.kinematics import FkStatus
from rrps_interfaces.teleop import TeleopStatus

__all__ = ['SLOW_ROUND_TRIP', 'HOLD_ROUND_TRIP', 'teleop_line', 'climb_line', 'preview_line', 'driver_line',
           'round_trip_line', 'grippers_line', 'slave_lines', 'feedback_line', 'fk_line',
           'translation_scale', 'driven_robot', 'robot_line']

#: Round trips [s] above which the teleop node (defaults of its slow_latency, hold_latency)
#: scales speeds down and holds the robot; the panel names them.
SLOW_ROUND_TRIP = 0.2
HOLD_ROUND_TRIP = 0.3
#: The teleop translation scale assumed until teleop/status says (its default).
DEFAULT_SCALE = 4.0

_LEVEL_NAMES = {0: 'OK', 1: 'WARN', 2: 'ERROR', 3: 'STALE'}


def _level(status) -> str:
    level = status.level
    level = level[0] if isinstance(level, (bytes, bytearray)) else int(level)
    return _LEVEL_NAMES.get(level, str(level))


def _typed(status, contract):
    """(the status' typed values by ``contract.from_key_values``, None), or (None, why there are
    none: '—' when no status came, 'unreadable (...)' when it does not parse)."""
    if status is None:
        return None, '—'
    try:
        return contract.from_key_values(status.values), None
    except ValueError as exc:
        return None, f'unreadable ({exc})'


def teleop_line(status) -> str:
    """teleop/status: code, level, mapping and whether the clutch is engaged."""
    t, why = _typed(status, TeleopStatus)
    if t is None:
        return why
    return (f'{t.code.name} ({_level(status)}, mode {t.mode}, scale {t.scale:g}, '
            f'engaged {"yes" if t.engaged else "no"})')


def climb_line(status) -> str:
    """climb/status: state, the pause reason and where the climb is."""
    c, why = _typed(status, ClimbStatus)
    if c is None:
        return why
    where = f', step {c.step}, phase {c.phase}' if c.action is not None else ''
    paused = f': {c.pause_reason.value}, press Resume climb' if c.pause_reason is not None else ''
    if c.previewing:
        paused = ': previewing the step'
    elif c.refusal is not None and c.state.value == 'idle':
        paused = f': step refused ({c.refusal.value})'
    return f'{c.state.value}{paused} ({_level(status)}{where})'


def preview_line(status) -> str:
    """climb/preview: the last step's predicted peak actuator force, gripper reaction and
    smallest holding margin, and whether the preview accepted it."""
    p, why = _typed(status, ClimbPreview)
    if p is None:
        return why
    if p.peak_leg == 0:
        return p.detail or ('accepted' if p.accepted else 'refused')
    verdict = 'accepted' if p.accepted else f'REFUSED ({p.limit.value if p.limit else "failed"})'
    margin = '—' if math.isnan(p.min_margin) else f'{p.min_margin:.2f} ({p.min_margin_ring})'
    return (f'{verdict}: peak force {p.peak_force:.0f} N (leg_{p.peak_leg}, max {p.max_force:.0f} N), '
            f'gripper reaction {p.peak_reaction_force:.0f} N / {p.peak_reaction_moment:.0f} N m, '
            f'holding margin {margin}')


def driver_line(status) -> str:
    """The driver's lifecycle state (from its /diagnostics status)."""
    d, why = _typed(status, DriverStatus)
    if d is None:
        return 'not heard yet' if status is None else why
    return ('active' if d.active else 'INACTIVE: press Activate driver') + f' ({d.mode.value})'


def round_trip_line(round_trip: float | None) -> str:
    """The operator's round trip [s] and what the teleop node does about it."""
    if round_trip is None:
        return '—'
    text = f'{round_trip * 1e3:.0f} ms'
    if round_trip > HOLD_ROUND_TRIP:
        return text + f' (robot holds above {HOLD_ROUND_TRIP * 1e3:.0f} ms)'
    if round_trip > SLOW_ROUND_TRIP:
        return text + f' (slowed above {SLOW_ROUND_TRIP * 1e3:.0f} ms)'
    return text


def grippers_line(grippers: dict[str, float | None]) -> str:
    """Closedness per ring (1 closed, 0 open, None unknown)."""
    return ', '.join(f'{ring} {"?" if v is None else "closed" if v >= 0.5 else "open"}'
                     for ring, v in grippers.items())


def slave_lines(figure, *, min_conditioning: float) -> list[str]:
    """Conditioning, the smallest margin of each kind and the leg lengths of the slave
    (a :class:`~rrps_kinematics.scene.RobotFigure`)."""
    m = figure.margins
    mins = m.minimum
    f = figure.fractions
    return [f'**Conditioning:** 1/cond {float(m.inverse_condition):.3f} '
            f'(min {min_conditioning:.3f})',
            f'**Margins:** stroke {float(mins["stroke"]) * 1e3:.1f} mm, '
            f'U-joint {math.degrees(float(mins["universal"])):.1f}°, '
            f'S-joint {math.degrees(float(mins["spherical"])):.1f}°, '
            f'interference {float(mins["interference"]) * 1e3:.1f} mm, '
            f'force {100.0 * float(np.min(f["force"])):.0f} %',
            '**Legs:** ' + ' '.join(f'{i + 1}:{length * 1e3:.0f}mm'
                                    for i, length in enumerate(figure.lengths))]


def feedback_line(teleop_status) -> str | None:
    """The force the limits push back on the master with (None: no teleop status)."""
    t, _ = _typed(teleop_status, TeleopStatus)
    if t is None:
        return None
    if t.feedback_force > 0.0 and t.feedback_limit:
        return f'{t.feedback_force:.1f} N, {t.feedback_limit} limit near'
    return 'none'


def fk_line(fk_status) -> str:
    """fk_node's last solve: its message, iterations and residual."""
    try:
        fk = FkStatus.from_key_values(fk_status.values)
    except ValueError as exc:
        return f'unreadable status ({exc})'
    return f'{fk_status.message or "—"}, iterations {fk.iterations}, residual {fk.residual:.3g} m'


def translation_scale(teleop_status) -> float:
    """The teleop mapping's translation scale (its default until teleop/status says)."""
    t, _ = _typed(teleop_status, TeleopStatus)
    return DEFAULT_SCALE if t is None else t.scale


def driven_robot(teleop_status) -> tuple[str | None, bool]:
    """The namespace of the robot the teleop node drives (None: not known) and whether its
    clutch is engaged."""
    t, _ = _typed(teleop_status, TeleopStatus)
    if t is None:
        return None, False
    return t.robot or None, t.engaged


def robot_line(name: str, *, selected: bool, driven: bool, engaged: bool, driver, climb,
               grippers: dict[str, float | None], heard: float | None) -> str:
    """One robot of a fleet: whether the master drives it, its driver, climb and grippers, and
    how long ago [s] anything of it was heard."""
    role = 'driven, engaged' if engaged else 'driven' if driven else 'holds'
    age = 'never heard' if heard is None else f'heard {heard:.1f} s ago'
    mark = '▶ ' if selected else ''
    return (f'{mark}**{name}** ({role}): driver {driver_line(driver)}; climb {climb_line(climb)}; '
            f'{grippers_line(grippers)}; {age}')
