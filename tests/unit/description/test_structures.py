"""Structure models: centrelines, grip frames, junctions, facades, meshes, bad input."""

from __future__ import annotations

import numpy as np
import pytest

from rrps_description.rotations import matrix_to_quat_xyzw, quat_xyzw_to_rotation_vector
from rrps_description.structures import BeamFrame, Tube, facade, make_structure, palm_trunk, pole, structural_frame


def _orthonormal(R):
    assert np.allclose(R.T @ R, np.eye(3), atol=1e-9)
    assert np.isclose(np.linalg.det(R), 1.0)


def test_pole_frames_follow_the_axis():
    p = pole(length=2.0, radius=0.1)
    assert p.length == pytest.approx(2.0, abs=1e-6)
    for s in (0.0, 0.7, 2.0):
        pos, R = p.grip_frame(s)
        assert np.allclose(pos, [0.0, 0.0, s], atol=1e-6)
        assert np.allclose(R, np.eye(3), atol=1e-6)
    assert np.allclose(p.radius([0.0, 1.0, 2.0]), 0.1)


def test_palm_trunk_is_curved_with_radius_within_20_percent():
    t = palm_trunk()
    assert 3.0 <= t.length < 3.1  # 3 m tall, a little longer along its lean
    r = t.radius(np.linspace(0.0, t.length, 400))
    assert r.min() >= 0.15 * 0.8 - 1e-3 and r.max() <= 0.15 * 1.2 + 1e-3
    assert r.min() < 0.15 * 0.82 and r.max() > 0.15 * 1.18  # the variation is really there
    tilts = [np.degrees(np.arccos(t.grip_frame(s)[1][2, 2])) for s in np.linspace(0, t.length, 13)]
    assert max(tilts) > 3.0  # a curved trunk, not a pole


def test_tube_grip_frames_are_tangent_and_twist_free():
    t = palm_trunk()
    ds = 1e-3
    for s in np.linspace(0.1, t.length - 0.1, 9):
        p0, R0 = t.grip_frame(s)
        p1, R1 = t.grip_frame(s + ds)
        _orthonormal(R0)
        tangent = (p1 - p0) / np.linalg.norm(p1 - p0)
        assert np.allclose(R0[:, 2], tangent, atol=2e-3)
        # Rotation-minimising: no rotation about the tangent between neighbouring frames.
        w = quat_xyzw_to_rotation_vector(matrix_to_quat_xyzw(R0.T @ R1)) / ds
        assert abs(w[2]) < 1e-2


def test_tube_swing_slides_along_the_centreline():
    t = palm_trunk()
    pos, rot = t.swing(0.5, 0.8, spacing=0.01)
    assert len(pos) >= 31
    assert np.allclose(pos[0], t.grip_frame(0.5)[0]) and np.allclose(pos[-1], t.grip_frame(0.8)[0])
    assert np.max(np.linalg.norm(np.diff(pos, axis=0), axis=1)) <= 0.0101
    pts, radii = t.clearance_points(0.5, 0.8)
    assert len(pts) == len(radii) and len(pts) > 20


def test_frame_junction_turns_the_section_and_is_forbidden():
    f = structural_frame(junction_twist_deg=90.0, node_clearance=0.1)
    assert f.length == pytest.approx(4.0)
    assert f.junctions == (pytest.approx(2.0),)
    assert not f.grip_allowed(2.0) and not f.grip_allowed(1.95) and f.grip_allowed(1.85)
    _, R_low = f.grip_frame(1.5)
    p_high, R_high = f.grip_frame(2.5)
    assert np.allclose(p_high, [0.0, 0.0, 2.5])
    assert np.allclose(R_low[:, 2], R_high[:, 2])           # collinear members (a splice)
    assert abs(R_low[:, 0] @ R_high[:, 0]) < 1e-9          # the web turned by 90 degrees
    bent = structural_frame(bend_deg=30.0)
    _, R = bent.grip_frame(3.0)
    assert np.degrees(np.arccos(R[2, 2])) == pytest.approx(30.0)


@pytest.mark.parametrize('out_of_plane', [False, True])
def test_a_frame_node_bends_its_member_in_the_web_plane_or_normal_to_it(out_of_plane):
    f = make_structure('frame', junction_deg=90.0, out_of_plane=out_of_plane)
    _, R0 = f.grip_frame(1.0)
    _, R1 = f.grip_frame(3.0)
    bend = [0.0, 1.0, 0.0] if out_of_plane else [1.0, 0.0, 0.0]
    assert np.allclose(R0[:, 2], [0.0, 0.0, 1.0]) and np.allclose(R1[:, 2], bend)
    assert f.junctions == (pytest.approx(2.0),)
    off = [np.cross(R1[:, 2], f.nodes[k] - f.nodes['J']) for k in ('east', 'north')]
    assert np.allclose(off[0], 0.0)                                   # in the bend's plane, opposite
    assert abs(np.dot(f.nodes['north'] - f.nodes['J'], np.cross(R0[:, 2], R1[:, 2]))) == pytest.approx(1.5)
    with pytest.raises(ValueError, match='junction_deg'):
        make_structure('frame', junction_deg=120.0)


def test_frame_swing_interpolates_across_the_junction():
    f = structural_frame()
    pos, rot = f.swing(1.8, 2.2)
    for R in rot:
        _orthonormal(R)
    assert np.allclose(rot[-1], f.grip_frame(2.2)[1])
    angles = [np.degrees(np.linalg.norm(quat_xyzw_to_rotation_vector(matrix_to_quat_xyzw(a.T @ b))))
              for a, b in zip(rot[:-1], rot[1:])]
    assert max(angles) <= 1.0 + 1e-6


def test_facade_frames_and_lift():
    f = facade(length=3.0)
    p, R = f.grip_frame(1.0)
    assert np.allclose(R[:, 2], [0.0, -1.0, 0.0]) and np.allclose(R[:, 0], [1.0, 0.0, 0.0])
    pos, _ = f.swing(1.0, 1.3)
    off_wall = -(pos[:, 1])
    assert off_wall.max() == pytest.approx(f.lift) and off_wall[0] == 0.0 and off_wall[-1] == 0.0
    assert np.allclose(pos[-1], f.grip_frame(1.3)[0])


@pytest.mark.parametrize('structure', [pole(), palm_trunk(), structural_frame(), facade()])
def test_meshes_are_valid(structure):
    verts, faces = structure.mesh()
    assert verts.ndim == 2 and verts.shape[1] == 3 and np.all(np.isfinite(verts))
    assert faces.ndim == 2 and faces.shape[1] == 3
    assert faces.min() >= 0 and faces.max() < len(verts)
    area = np.linalg.norm(np.cross(verts[faces[:, 1]] - verts[faces[:, 0]],
                                   verts[faces[:, 2]] - verts[faces[:, 0]]), axis=1)
    assert np.all(area > 0.0)


def test_make_structure_is_long_enough():
    for name in ('pole', 'palm_trunk', 'frame', 'facade'):
        assert make_structure(name, 5.0).length >= 5.0 - 1e-9
    with pytest.raises(ValueError, match='unknown structure'):
        make_structure('tower')


def test_a_leaning_pole_turns_its_grip_frames_about_x():
    """A pole leaning 30 deg: each grip frame is the vertical pole's turned by 30 deg about the
    world x axis (built here from the angle), its centreline on the turned z axis."""
    lean = np.radians(30.0)
    turn = np.array([[1.0, 0.0, 0.0], [0.0, np.cos(lean), -np.sin(lean)], [0.0, np.sin(lean), np.cos(lean)]])
    tilted, upright = make_structure('pole', lean_deg=30.0), pole()
    for s in (0.0, 0.7, 2.5):
        p, R = tilted.grip_frame(s)
        p0, R0 = upright.grip_frame(s)
        np.testing.assert_allclose(p, turn @ p0, atol=1e-9)
        np.testing.assert_allclose(R, turn @ R0, atol=1e-9)
    # gravity seen from a grip frame: (0, -sin 30, -cos 30) g
    np.testing.assert_allclose(tilted.grip_frame(1.0)[1].T @ [0.0, 0.0, -1.0], [0.0, -0.5, -np.sqrt(3) / 2],
                               atol=1e-9)
    with pytest.raises(ValueError, match='pole only'):
        make_structure('facade', lean_deg=10.0)
    with pytest.raises(ValueError, match='lean_deg'):
        pole(lean_deg=95.0)


def test_bad_input_is_refused():
    with pytest.raises(ValueError, match='points'):
        Tube([[0.0, 0.0, 0.0]], [0.1])
    with pytest.raises(ValueError, match='radii'):
        Tube([[0, 0, 0], [0, 0, 1]], [0.1, -0.1])
    with pytest.raises(ValueError, match='off the pole'):
        pole(2.0).grip_frame(2.5)
    with pytest.raises(ValueError, match='no beam'):
        BeamFrame({'a': (0, 0, 0), 'b': (0, 0, 1), 'c': (0, 0, 2)}, [('a', 'b')], ['a', 'b', 'c'])
    with pytest.raises(ValueError):
        pole(length=-1.0)
