"""The garbage collector kept off a process's command path: its long-lived objects frozen out of
the collector's reach (``gc.freeze``). Pure Python, no ROS import."""

from __future__ import annotations

import gc

__all__ = ['freeze_startup_objects', 'freeze_new_objects', 'thaw']


def freeze_startup_objects() -> None:
    """Move every object alive now (modules, compiled kernels, the nodes, a bus' devices) out of
    the garbage collector's reach, once a process has started its nodes or its devices.

    A full collection otherwise walks them all with the GIL held, which can take long enough for
    a 0.1 s command timeout to reject a message queued behind it, or a simulated drive to miss its
    SYNC (up to 70 ms: docs/measurements.md).
    """
    gc.collect()
    gc.freeze()


def freeze_new_objects() -> None:
    """Move the objects built since the last freeze out of the collector's reach too, without a
    collection (no pause now): a driver calls it once its hardware built a bus, its threads and its
    devices' object dictionaries. A full collection walked those with the GIL held for up to 70 ms,
    the bus' cycle stopped meanwhile (docs/measurements.md, CANopen)."""
    gc.freeze()


def thaw() -> None:
    """Put the frozen objects back in the collector's reach when a process ends, so that the
    interpreter's end frees them (an extension's objects still alive then, as Ruckig's, are
    reported as leaks)."""
    gc.unfreeze()
