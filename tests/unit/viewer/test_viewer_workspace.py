"""The viewer's reachable workspace (viewer._workspace): its boundary, and its recomputation in
the background when the slave's orientation changes (paper section 3.1: the operator sees the
reachable space before moving there). How long a recomputation takes is in
benchmarks/workspace.py (the target is 0.5 s), not here."""

from __future__ import annotations

import time

import numpy as np
import pytest

from rrps_description.geometry import load_robot
from rrps_description.rotations import rotation_angle_between, rotation_vector_to_quat_xyzw
from rrps_kinematics.workspace import UNREACHABLE, reachable_workspace
from rrps_viewer._workspace import WorkspaceView, boundary_points

POLE = load_robot('pole_climber')
DEADLINE = 60.0


def _wait_for_version(view: WorkspaceView, version: int):
    deadline = time.monotonic() + DEADLINE
    while time.monotonic() < deadline:
        snapshot = view.latest()
        if snapshot is not None and snapshot.version >= version:
            return snapshot
        time.sleep(0.01)
    raise AssertionError(f'no workspace of version {version} within {DEADLINE} s')


def test_the_boundary_is_the_reachable_points_next_to_unreachable_ones():
    ws = reachable_workspace(POLE, [0, 0, 0, 1], resolution=0.03)
    shell, singular = boundary_points(ws)
    assert len(shell) > 0 and len(singular) == 0  # the pole climber has no near-singular point
    index = np.rint((shell - ws.origin) / ws.spacing).astype(int)
    inside = ws.labels != UNREACHABLE
    assert inside[tuple(index.T)].all()
    padded = np.pad(inside, 1, constant_values=False)
    neighbours = [padded[tuple((index + 1 + d).T)] for d in
                  np.array([[1, 0, 0], [-1, 0, 0], [0, 1, 0], [0, -1, 0], [0, 0, 1], [0, 0, -1]])]
    assert (~np.all(neighbours, axis=0)).all()  # each has an unreachable face neighbour
    # every reachable point with all six neighbours reachable is not on the boundary
    assert len(shell) < np.count_nonzero(inside)


def test_the_view_computes_at_the_orientation_asked_and_tells_the_distance_to_the_boundary():
    view = WorkspaceView(POLE, resolution=0.03)
    assert view.latest() is None
    view.request(POLE.home_quaternion_xyzw)
    snapshot = _wait_for_version(view, 1)
    assert rotation_angle_between(snapshot.quaternion_xyzw, POLE.home_quaternion_xyzw) < 1e-12
    assert snapshot.distance(POLE.home_position) > 0.0  # home is inside
    assert snapshot.distance(POLE.home_position + [0.0, 0.0, 2.0]) < 0.0  # 2 m up is not
    assert snapshot.seconds > 0.0 and len(snapshot.boundary) > 0


def test_a_new_orientation_recomputes_a_small_change_does_not_and_the_newest_wins():
    view = WorkspaceView(POLE, resolution=0.03, angle_step=0.03)
    view.request(POLE.home_quaternion_xyzw)
    first = _wait_for_version(view, 1)
    view.request(rotation_vector_to_quat_xyzw(np.array([0.0, 0.0, 0.01])))  # below angle_step
    time.sleep(0.2)
    assert view.latest() is first
    turns = [rotation_vector_to_quat_xyzw(np.array([0.0, 0.0, a])) for a in (0.1, 0.2, 0.3)]
    for q in turns:  # faster than the worker: the ones in between may be skipped
        view.request(q)
    deadline = time.monotonic() + DEADLINE
    while rotation_angle_between(view.latest().quaternion_xyzw, turns[-1]) > 1e-12:
        assert time.monotonic() < deadline, 'the newest orientation was never computed'
        time.sleep(0.01)
    last = view.latest()
    assert 2 <= last.version <= 1 + len(turns)
    # the workspace at a yaw of 0.3 rad is that orientation's, not home's
    expected = reachable_workspace(POLE, turns[-1], resolution=0.03)
    assert np.array_equal(last.workspace.labels, expected.labels)


def test_a_payload_recomputes_the_load_feasible_workspace_within_the_reachable_one():
    on_wall = rotation_vector_to_quat_xyzw(np.array([np.pi / 2, 0.0, 0.0]))
    view = WorkspaceView(POLE, resolution=0.03)
    view.request(POLE.home_quaternion_xyzw, on_wall)
    unloaded = _wait_for_version(view, 1)
    view.request(POLE.home_quaternion_xyzw, on_wall)          # the same request: no recomputation
    view.set_payload(40.0)
    loaded = _wait_for_version(view, 2)
    assert loaded.version == 2 and loaded.payload == 40.0 and unloaded.payload == 0.0
    inside = loaded.workspace.labels != UNREACHABLE
    assert not np.any(inside & (unloaded.workspace.labels == UNREACHABLE))
    assert 0.0 < loaded.workspace.volume < unloaded.workspace.volume <= loaded.reachable_volume
    assert 'load-feasible with 40 kg payload' in loaded.describe(POLE.home_position)
    with pytest.raises(ValueError, match='payload'):
        view.set_payload(-1.0)
