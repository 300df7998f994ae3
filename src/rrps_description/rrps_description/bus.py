"""The robot YAML's optional ``bus`` section: the fieldbus that carries the robot's drives.

A CANopen bus with one CiA 402 drive per leg, the grippers' digital I/O (a CiA 401 module or the
drives' own) and, for a master robot, its force output's limits; a drive's keys not given take
``drive_defaults``, then the defaults below. Every error names its key. Every key and an example:
docs/connecting-a-robot.md. Pure Python, no ROS import.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Mapping

from rrps_description.names import LEG_NAMES, RINGS
from rrps_description.robot_parts import RobotDescriptionError, as_scalar

__all__ = ['HOMING_ABSOLUTE', 'HOMING_METHODS', 'GRIPPER_IO', 'DriveConfig', 'homing_end', 'GripperChannel',
           'GripperIoConfig', 'ForceOutputConfig', 'BusConfig', 'bus_from']

#: ``homing: absolute``: the drive's encoder is absolute; its position is the offset's, no homing.
HOMING_ABSOLUTE = 'absolute'
#: The CiA 402 homing methods (0x6098) rrps runs, and what each one finds (in the count direction:
#: a leg with ``direction: -1`` counts down as it extends, so its negative limit switch is at the
#: extended end).
HOMING_METHODS = {
    1: 'the negative limit switch, then the first index pulse back inside the stroke',
    2: 'the positive limit switch, then the first index pulse back inside the stroke',
    17: 'the negative limit switch',
    18: 'the positive limit switch',
    35: 'the current position',
    37: 'the current position',
}
#: The methods that home at a limit switch, and the sign of the count direction towards it.
_SWITCH_SIDE = {1: -1, 2: 1, 17: -1, 18: 1}
#: The methods whose home only the YAML can say (``home_position`` required), and where it is.
_HOME_GIVEN = {1: 'an index pulse', 2: 'an index pulse', 35: 'the current position', 37: 'the current position'}
#: Where the grippers' valves and clamp sensors are wired: a CiA 401 I/O module or the drives.
GRIPPER_IO = ('cia401', 'drive')

_BUS_KEYS = {'interface', 'channel', 'bitrate', 'options', 'sync_period', 'heartbeat_period', 'heartbeat_timeout',
             'sdo_timeout', 'sdo_retries', 'boot_timeout', 'mode_timeout', 'drive_defaults', 'drives', 'grippers',
             'force_output'}
_DRIVE_KEYS = {'node_id', 'eds', 'counts_per_metre', 'direction', 'offset', 'min_position', 'max_position',
               'homing', 'home_position', 'homing_speed', 'following_error', 'following_error_time', 'rated_force'}


@dataclass(frozen=True, kw_only=True)
class DriveConfig:
    """One CiA 402 drive of a leg: ``counts = direction * counts_per_metre * length + offset``, soft
    limits [m], ``homing`` 'absolute' or a method of :data:`HOMING_METHODS`, the following-error window
    [m, s], ``rated_force`` [N] and ``given`` (the YAML's keys, whose objects must be written); see
    docs/connecting-a-robot.md (Units, Optional objects, Homing)."""

    actuator: str
    node_id: int
    eds: str
    counts_per_metre: float
    direction: int = 1
    offset: int = 0
    min_position: float
    max_position: float
    homing: str | int = HOMING_ABSOLUTE
    home_position: float = 0.0
    homing_speed: float = 0.01
    following_error: float = 0.005
    following_error_time: float = 0.02
    rated_force: float | None = None
    given: frozenset[str] = frozenset()


def homing_end(method: str | int, direction: int) -> str | None:
    """The end of the stroke (``'retracted'`` or ``'extended'``) a homing method finds for a leg
    counting in ``direction``, or None (a method that homes where the leg stands, or absolute)."""
    side = _SWITCH_SIDE.get(method) if isinstance(method, int) else None
    if side is None:
        return None
    return 'extended' if side * direction > 0 else 'retracted'


@dataclass(frozen=True, kw_only=True)
class GripperChannel:
    """One ring's gripper: the digital ``output`` bit that closes it and the ``sensor`` input bit
    that reads it closed; with ``io: drive`` the ``drive`` (a leg name) whose I/O carries them."""

    output: int
    sensor: int
    drive: str = ''


@dataclass(frozen=True, kw_only=True)
class GripperIoConfig:
    """The grippers' I/O: ``io`` (``cia401``: a module at ``node_id`` with ``eds``; ``drive``: the
    drives' own digital I/O), one :class:`GripperChannel` per ring, and ``sensor_timeout`` [s]
    after which a sensor that disagrees with its command is a fault."""

    io: str
    rings: Mapping[str, GripperChannel]
    node_id: int = 0
    eds: str = ''
    sensor_timeout: float = 1.0


@dataclass(frozen=True, kw_only=True)
class ForceOutputConfig:
    """A master robot's force output on its legs (cyclic synchronous torque): at most ``limit``
    [N] per leg, with a ``damping`` [N s/m] that makes it dissipative."""

    limit: float
    damping: float


@dataclass(frozen=True, kw_only=True)
class BusConfig:
    """The ``bus`` section: the CAN link, the drives (one per leg, in leg order), the grippers' I/O
    and, for a master, its force output. ``base_dir``: the YAML file's folder (relative EDS paths)."""

    interface: str
    channel: str
    bitrate: int = 1_000_000
    options: Mapping[str, Any] = field(default_factory=dict)
    sync_period: float = 0.002
    heartbeat_period: float = 0.05
    heartbeat_timeout: float = 0.25
    sdo_timeout: float = 0.3
    sdo_retries: int = 2
    boot_timeout: float = 5.0
    mode_timeout: float = 1.0
    drives: tuple[DriveConfig, ...] = ()
    grippers: GripperIoConfig | None = None
    force_output: ForceOutputConfig | None = None
    base_dir: str = ''

    def node_ids(self) -> dict[str, int]:
        """{device: node id} of every node on the bus (the drives, then the I/O module)."""
        ids = {d.actuator: d.node_id for d in self.drives}
        if self.grippers is not None and self.grippers.io == 'cia401':
            ids['gripper_io'] = self.grippers.node_id
        return ids


def _mapping(value: Any, key: str) -> Mapping[str, Any]:
    if not isinstance(value, Mapping):
        raise RobotDescriptionError(f'{key}: expected a mapping, got {value!r}')
    return value


def _integer(value: Any, key: str, lo: int, hi: int) -> int:
    if isinstance(value, bool) or not isinstance(value, int) or not lo <= value <= hi:
        raise RobotDescriptionError(f'{key}: must be an integer in {lo}..{hi}, got {value!r}')
    return value


def _unknown(section: Mapping[str, Any], known: set[str], key: str) -> None:
    extra = sorted(set(section) - known)
    if extra:
        raise RobotDescriptionError(f'{key}: unknown keys {extra}')


def _drive(actuator: str, sec: Mapping[str, Any], stroke: tuple[float, float]) -> DriveConfig:
    key = f'bus.drives.{actuator}'
    _unknown(sec, _DRIVE_KEYS, key)
    for required in ('node_id', 'eds', 'counts_per_metre'):
        if required not in sec:
            raise RobotDescriptionError(f'{key}.{required}: missing (give it here or in bus.drive_defaults)')
    direction = sec.get('direction', 1)
    if direction not in (1, -1) or isinstance(direction, bool):
        raise RobotDescriptionError(f'{key}.direction: must be 1 or -1, got {direction!r}')
    lo = as_scalar(sec.get('min_position', stroke[0]), f'{key}.min_position')
    hi = as_scalar(sec.get('max_position', stroke[1]), f'{key}.max_position')
    if stroke[0] < stroke[1] and not stroke[0] <= lo < hi <= stroke[1]:  # a bad stroke is the legs' error
        raise RobotDescriptionError(f'{key}: soft limits [{lo}, {hi}] m must be increasing and within the '
                                    f'stroke [{stroke[0]}, {stroke[1]}] m')
    homing = _homing_method(sec.get('homing', HOMING_ABSOLUTE), f'{key}.homing')
    end = homing_end(homing, direction)
    if homing in _HOME_GIVEN and 'home_position' not in sec:
        raise RobotDescriptionError(f'{key}.home_position: missing: homing method {homing} homes at '
                                    f'{_HOME_GIVEN[homing]}; give the leg\'s length there [m]')
    home = as_scalar(sec.get('home_position', {'retracted': lo, 'extended': hi}.get(end, lo)), f'{key}.home_position')
    if homing != HOMING_ABSOLUTE and not lo <= home <= hi:
        raise RobotDescriptionError(f'{key}.home_position: {home} m is outside the soft limits [{lo}, {hi}] m: '
                                    'the leg stands there after homing')
    if end is not None and abs(home - (stroke[0] if end == 'retracted' else stroke[1])) > 0.5 * (stroke[1] - stroke[0]):
        raise RobotDescriptionError(
            f'{key}.home_position: homing method {homing} finds {HOMING_METHODS[homing]}, which for direction '
            f'{direction} is the {end} end of the stroke; {home} m is nearer the other end')
    cpm = as_scalar(sec['counts_per_metre'], f'{key}.counts_per_metre', positive=True)
    offset = _integer(sec.get('offset', 0), f'{key}.offset', -2**31, 2**31 - 1)
    for edge in (lo, hi):
        if abs(direction * cpm * edge + offset) >= 2**31:
            raise RobotDescriptionError(f'{key}: {edge} m is outside a 32-bit position in counts')
    return DriveConfig(
        actuator=actuator, node_id=_integer(sec['node_id'], f'{key}.node_id', 1, 127), eds=str(sec['eds']),
        counts_per_metre=cpm, direction=direction, offset=offset, min_position=lo, max_position=hi, homing=homing,
        home_position=home,
        homing_speed=as_scalar(sec.get('homing_speed', 0.01), f'{key}.homing_speed', positive=True),
        following_error=as_scalar(sec.get('following_error', 0.005), f'{key}.following_error', positive=True),
        following_error_time=as_scalar(sec.get('following_error_time', 0.02), f'{key}.following_error_time',
                                       nonnegative=True),
        rated_force=(as_scalar(sec['rated_force'], f'{key}.rated_force', positive=True) if 'rated_force' in sec
                     else None), given=frozenset(sec))


def _homing_method(value: Any, key: str) -> str | int:
    if value == HOMING_ABSOLUTE or (isinstance(value, int) and not isinstance(value, bool) and value in HOMING_METHODS):
        return value
    offered = '; '.join(f'{m}: {what}' for m, what in HOMING_METHODS.items())
    raise RobotDescriptionError(f"{key}: must be 'absolute' or a CiA 402 homing method rrps runs ({offered}), "
                                f'got {value!r}')


def _grippers(sec: Mapping[str, Any], drives: tuple[DriveConfig, ...]) -> GripperIoConfig:
    _unknown(sec, {'io', 'node_id', 'eds', 'sensor_timeout', *RINGS}, 'bus.grippers')
    io = sec.get('io', 'cia401')
    if io not in GRIPPER_IO:
        raise RobotDescriptionError(f'bus.grippers.io: must be one of {GRIPPER_IO}, got {io!r}')
    rings = {}
    for ring in RINGS:
        key = f'bus.grippers.{ring}'
        channel = _mapping(sec.get(ring), key)
        _unknown(channel, {'output', 'sensor', 'drive'}, key)
        drive = str(channel.get('drive', ''))
        if io == 'drive' and drive not in {d.actuator for d in drives}:
            raise RobotDescriptionError(f'{key}.drive: must name a drive of bus.drives, got {drive!r}')
        for bit in ('output', 'sensor'):
            if bit not in channel:
                raise RobotDescriptionError(f'{key}.{bit}: missing')
        rings[ring] = GripperChannel(output=_integer(channel['output'], f'{key}.output', 0, 31),
                                     sensor=_integer(channel['sensor'], f'{key}.sensor', 0, 31), drive=drive)
    node_id, eds = 0, ''
    if io == 'cia401':
        if 'node_id' not in sec or 'eds' not in sec:
            raise RobotDescriptionError('bus.grippers: io cia401 needs node_id and eds')
        node_id, eds = _integer(sec['node_id'], 'bus.grippers.node_id', 1, 127), str(sec['eds'])
    return GripperIoConfig(io=io, rings=rings, node_id=node_id, eds=eds,
                           sensor_timeout=as_scalar(sec.get('sensor_timeout', 1.0), 'bus.grippers.sensor_timeout',
                                                    positive=True))


def bus_from(sec: Any, *, min_length: float, max_length: float, source: str = '') -> BusConfig:
    """The ``bus`` section of a robot YAML, checked (``min_length``/``max_length``: the legs'
    stroke [m], the soft limits' default and bound; ``source``: the YAML file)."""
    sec = _mapping(sec, 'bus')
    _unknown(sec, _BUS_KEYS, 'bus')
    for required in ('interface', 'channel', 'drives'):
        if required not in sec:
            raise RobotDescriptionError(f'bus.{required}: missing')
    if not math.isfinite(max_length):
        raise RobotDescriptionError('bus: the drives need a finite stroke (legs.max_length)')
    defaults = _mapping(sec.get('drive_defaults', {}), 'bus.drive_defaults')
    _unknown(defaults, _DRIVE_KEYS - {'node_id'}, 'bus.drive_defaults')
    drives_sec = _mapping(sec['drives'], 'bus.drives')
    _unknown(drives_sec, set(LEG_NAMES), 'bus.drives')
    missing = [leg for leg in LEG_NAMES if leg not in drives_sec]
    if missing:
        raise RobotDescriptionError(f'bus.drives: no drive for {missing}')
    drives = tuple(_drive(leg, {**defaults, **_mapping(drives_sec[leg], f'bus.drives.{leg}')},
                          (min_length, max_length)) for leg in LEG_NAMES)
    ids = [d.node_id for d in drives]
    grippers = _grippers(_mapping(sec['grippers'], 'bus.grippers'), drives) if 'grippers' in sec else None
    if grippers is not None and grippers.io == 'cia401':
        ids.append(grippers.node_id)
    if len(set(ids)) != len(ids):
        raise RobotDescriptionError(f'bus: node ids must be unique, got {ids}')
    force = None
    if 'force_output' in sec:
        fo = _mapping(sec['force_output'], 'bus.force_output')
        _unknown(fo, {'limit', 'damping'}, 'bus.force_output')
        force = ForceOutputConfig(limit=as_scalar(fo.get('limit'), 'bus.force_output.limit', positive=True),
                                  damping=as_scalar(fo.get('damping', 0.0), 'bus.force_output.damping',
                                                    nonnegative=True))
    options = _mapping(sec.get('options', {}), 'bus.options')
    period = as_scalar(sec.get('sync_period', 0.002), 'bus.sync_period', positive=True)
    heartbeat = as_scalar(sec.get('heartbeat_period', 0.05), 'bus.heartbeat_period', positive=True)
    timeout = as_scalar(sec.get('heartbeat_timeout', 0.25), 'bus.heartbeat_timeout', positive=True)
    if timeout <= heartbeat:
        raise RobotDescriptionError(f'bus.heartbeat_timeout: must exceed heartbeat_period ({heartbeat} s)')
    return BusConfig(
        interface=str(sec['interface']), channel=str(sec['channel']),
        bitrate=_integer(sec.get('bitrate', 1_000_000), 'bus.bitrate', 10_000, 8_000_000), options=dict(options),
        sync_period=period, heartbeat_period=heartbeat, heartbeat_timeout=timeout,
        sdo_timeout=as_scalar(sec.get('sdo_timeout', 0.3), 'bus.sdo_timeout', positive=True),
        sdo_retries=_integer(sec.get('sdo_retries', 2), 'bus.sdo_retries', 0, 10),
        boot_timeout=as_scalar(sec.get('boot_timeout', 5.0), 'bus.boot_timeout', positive=True),
        mode_timeout=as_scalar(sec.get('mode_timeout', 1.0), 'bus.mode_timeout', positive=True),
        drives=drives, grippers=grippers, force_output=force,
        base_dir=str(Path(source).parent) if source else '')
