"""The load-feasible workspace (rrps_loads.load_workspace): a subset of the reachable workspace that
shrinks as the payload grows, whose points agree with the NumPy statics one by one, alike with
the compiled kernel and the NumPy path."""

from __future__ import annotations

import numpy as np
import pytest

from rrps_description.geometry import load_robot
from rrps_description.loads import Payload
from rrps_description.rotations import rotation_vector_to_quat_xyzw
from rrps_kinematics.backend import use_numba
from rrps_kinematics.workspace import UNREACHABLE, reachable_workspace
from rrps_loads.load_workspace import load_workspace
from rrps_loads.loads import static_solution
from rrps_testing.ci import require
from rrps_testing.virtual_work import quaternion_matrix, virtual_work_forces

WALL = rotation_vector_to_quat_xyzw(np.array([np.pi / 2, 0.0, 0.0]))
RESOLUTION = 0.02        # the viewer's
MASSES = (0.0, 20.0, 40.0, 80.0, 120.0, 200.0)


def _payload(mass):
    return Payload(ring='ring_b', mass=mass, com=np.array([0.15, 0.0, 0.1]))


@pytest.fixture(scope='module')
def pole():
    geom = load_robot('pole_climber')
    plain = reachable_workspace(geom, geom.home_quaternion_xyzw, resolution=RESOLUTION)
    loaded = {m: load_workspace(geom, plain=plain, world_q_support=WALL, payload=_payload(m)) for m in MASSES}
    return geom, plain, loaded


def test_the_load_feasible_set_is_within_the_reachable_one_and_shrinks_with_the_payload(pole):
    geom, plain, loaded = pole
    reachable = plain.labels != UNREACHABLE
    previous = reachable
    for m in MASSES:
        inside = loaded[m].labels != UNREACHABLE
        assert not np.any(inside & ~previous), f'{m} kg: a point the lighter payload could not hold'
        np.testing.assert_array_equal(loaded[m].labels[inside], plain.labels[inside])
        counts = loaded[m].excluded_by
        assert counts['actuator_force'] + counts['holding'] == int(reachable.sum() - inside.sum())
        previous = inside
    volumes = [loaded[m].volume for m in MASSES]
    assert volumes[0] > 0.0 and volumes[-1] < 0.5 * volumes[0] and volumes == sorted(volumes, reverse=True)
    assert plain.volume >= volumes[0]


def test_sampled_points_agree_with_the_numpy_statics(pole):
    geom, plain, loaded = pole
    rng = np.random.default_rng(25)
    points = plain.reachable[rng.choice(len(plain.reachable), 60, replace=False)]
    q = geom.home_quaternion_xyzw
    for m in (40.0, 80.0):
        ws, heavy = loaded[m], geom.with_(payload=_payload(m))
        index = np.rint((points - ws.origin) / ws.spacing).astype(int)
        sol = static_solution(heavy, (points, np.tile(q, (len(points), 1))), support='ring_a', world_q_support=WALL)
        feasible = (np.abs(sol.actuator_forces).max(axis=1) <= heavy.max_force) & ~(sol.holding_margin < 0.0)
        got = ws.labels[index[:, 0], index[:, 1], index[:, 2]] != UNREACHABLE
        np.testing.assert_array_equal(got, feasible)
        assert 0 < feasible.sum() < len(points)
        # the forces independently, by virtual work (rrps_testing.virtual_work)
        gravity = quaternion_matrix(WALL).T @ np.array([0.0, 0.0, -9.81])
        for k in range(0, len(points), 10):
            ref = virtual_work_forces(geom, points[k], quaternion_matrix(q), gravity, payload_mass=m,
                                      payload_com=_payload(m).com)
            np.testing.assert_allclose(sol.actuator_forces[k], ref, rtol=1e-5, atol=1e-6 * 9.81 * heavy.total_mass)


def test_the_compiled_and_the_numpy_paths_agree_on_either_support():
    require(use_numba('auto'), 'numba is not in use')
    geom = load_robot('facade_climber')
    for support in ('ring_a', 'ring_b'):
        kwargs = dict(resolution=0.04, support=support, world_q_support=WALL, payload=_payload(60.0))
        a, b = (load_workspace(geom, backend=backend, **kwargs) for backend in ('numba', 'numpy'))
        np.testing.assert_array_equal(a.labels, b.labels)
        assert a.excluded_by == b.excluded_by


def test_bad_arguments_are_refused_with_a_reason():
    geom = load_robot('pole_climber')
    with pytest.raises(ValueError, match='resolution'):
        load_workspace(geom)
    with pytest.raises(ValueError, match='support'):
        load_workspace(geom, resolution=0.05, support='ring_c')
    with pytest.raises(ValueError, match='payload.mass'):
        load_workspace(geom, resolution=0.05, payload=Payload(mass=-1.0))
