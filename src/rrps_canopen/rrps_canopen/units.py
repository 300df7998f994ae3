"""The one conversion between the stack's SI units and a drive's: ``counts = direction *
counts_per_metre * length + offset`` (:class:`rrps_description.bus.DriveConfig`), counts/s, and
forces in per mille of the rated force (0x6071 / 0x6077 against 0x6076). Pure Python."""

from __future__ import annotations

import math

from rrps_description.bus import DriveConfig

__all__ = ['AxisScale', 'INT32', 'REST_COUNTS']

#: The range of a CiA 402 position or velocity (INTEGER32).
INT32 = (-2**31, 2**31 - 1)
#: A drive's velocity (0x606C) of a still axis dithers by about this many counts per sample: an
#: encoder at rest flickers by one count each way, and the drive differentiates the count.
REST_COUNTS = 2


class AxisScale:
    """Metres <-> counts of one drive, its soft limits and its force scale."""

    def __init__(self, drive: DriveConfig, rated_force: float = 1000.0):
        self.drive = drive
        self.gain = drive.direction * drive.counts_per_metre  # counts per metre, signed
        self.offset = drive.offset
        self.min_position, self.max_position = drive.min_position, drive.max_position
        self.rated_force = float(rated_force)  # [N] = 1000 per mille

    def counts(self, position: float) -> int:
        """The encoder count of a length [m] (rounded, within INTEGER32)."""
        return int(min(max(round(self.gain * position + self.offset), INT32[0]), INT32[1]))

    def position(self, counts: int) -> float:
        """The length [m] of an encoder count."""
        return (counts - self.offset) / self.gain

    def velocity(self, counts_per_second: int) -> float:
        """A speed [m/s] of counts/s."""
        return counts_per_second / self.gain

    def counts_per_second(self, speed: float) -> int:
        """counts/s of a speed [m/s] (magnitude when the drive takes an unsigned speed)."""
        return int(round(self.gain * speed))

    def distance_counts(self, distance: float) -> int:
        """A distance [m] (a window, a tolerance) in counts, positive."""
        return max(1, int(round(abs(self.gain) * distance)))

    def limit_counts(self) -> tuple[int, int]:
        """The soft limits as the drive's min and max position limits (0x607D), in counts."""
        a, b = self.counts(self.min_position), self.counts(self.max_position)
        return min(a, b), max(a, b)

    def rest_speed(self, sample_period: float) -> float:
        """[m/s] the speed a still axis can read: :data:`REST_COUNTS` counts per ``sample_period``
        [s] (the drive's velocity sample time; the SYNC period bounds it from above)."""
        return REST_COUNTS / abs(self.gain) / sample_period

    def within_limits(self, position: float) -> bool:
        return self.min_position <= position <= self.max_position

    def per_mille(self, force: float) -> int:
        """A leg force [N] (positive pushes the rings apart) as target torque (INTEGER16)."""
        value = round(1000.0 * force * math.copysign(1.0, self.gain) / self.rated_force)
        return int(min(max(value, -32768), 32767))

    def force(self, per_mille: int) -> float:
        """The leg force [N] of an actual torque value."""
        return per_mille * self.rated_force * math.copysign(1.0, self.gain) / 1000.0

