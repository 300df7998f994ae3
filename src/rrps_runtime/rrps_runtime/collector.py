"""The garbage collector kept off a process's command path: its long-lived objects frozen out of
the collector's reach (``gc.freeze``). Pure Python, no ROS import."""

from __future__ import annotations

import gc

__all__ = ['freeze_startup_objects', 'freeze_new_objects', 'thaw']


def freeze_startup_objects() -> None:
    """Move every object alive now out of the garbage collector's reach, once a process has started its nodes or
    its devices: a full collection would walk them all with the GIL held (docs/measurements.md)."""
    gc.collect()
    gc.freeze()


def freeze_new_objects() -> None:
    """Move the objects built since the last freeze out of the collector's reach too, without a collection: a
    driver calls it once its hardware built a bus, its threads and its devices (docs/measurements.md, CANopen)."""
    gc.freeze()


def thaw() -> None:
    """Put the frozen objects back in the collector's reach when a process ends, so that the
    interpreter's end frees them (an extension's objects still alive then, as Ruckig's, are
    reported as leaks)."""
    gc.unfreeze()
