"""A transform tree as the tests read it: a frame's pose in an ancestor frame. Pure, no rclpy."""

from __future__ import annotations

from typing import Iterable

from rrps_description.pose import Pose

__all__ = ['pose_in']


def pose_in(transforms: Iterable[tuple[str, str, Pose]], frame: str, root: str) -> Pose:
    """root_T_frame from (parent, child, parent_T_child) triples: the chain from ``frame`` up to
    ``root``. KeyError when ``frame`` does not hang from ``root``; ValueError on a loop."""
    parents = {child: (parent, pose) for parent, child, pose in transforms}
    out, seen = Pose(), set()
    while frame != root:
        if frame in seen:
            raise ValueError(f'the transforms loop through {frame!r}')
        seen.add(frame)
        frame, pose = parents[frame]
        out = pose @ out
    return out
