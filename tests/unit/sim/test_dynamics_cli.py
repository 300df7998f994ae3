"""The ``rrps-dynamics`` command: simulate, statics, inverse, report; usage errors exit with
status 2, failed computations with 1, bugs with 3 and their traceback."""

import csv
import json
import shutil
import subprocess
import sys

import numpy as np
import pytest
import yaml

from rrps_description.geometry import load_robot, robot_path
from rrps_description.loads import Payload, ToolWrench
from rrps_kinematics import inverse_kinematics
from rrps_loads.inverse_dynamics import inverse_dynamics
from rrps_loads.loads import static_solution
from rrps_loads.statics import holding_forces
from rrps_sim import cli
from rrps_sim.cli import SIMULATION_COLUMNS, run
from rrps_sim.cli_world import REACTION_COLUMNS
from rrps_sim.dynamics import MultibodyDynamics, simulate
from rrps_sim.figures import climb_poses

GEOM = load_robot('pole_climber')
POSITION = np.array([0.01, -0.02, 0.41])
QUAT = np.array([0.02, -0.01, 0.03, 1.0]) / np.linalg.norm([0.02, -0.01, 0.03, 1.0])
POS_ARG = ','.join(map(str, POSITION))
QUAT_ARG = ','.join(map(str, QUAT))


def read_csv(path):
    with open(path, newline='') as fh:
        rows = list(csv.reader(fh))
    return rows[0], np.array(rows[1:], dtype=float)


def test_simulate_writes_the_documented_csv_and_plot(tmp_path, capsys):
    forces = MultibodyDynamics(GEOM).holding_forces(POSITION, QUAT) + 2.0
    out, png = tmp_path / 'out.csv', tmp_path / 'out.png'
    status = run(['simulate', '--robot', 'pole_climber', '--position', POS_ARG,
                  '--quaternion', QUAT_ARG, '--forces', ','.join(map(str, forces)),
                  '--duration', '0.05', '--dt', '0.001', '--method', 'partitioning',
                  '--csv', str(out), '--plot', str(png)])
    captured = capsys.readouterr()
    assert status == 0
    assert 'simulate (partitioning) 100 %' in captured.err
    header, data = read_csv(out)
    assert header == SIMULATION_COLUMNS
    assert header[:14] == ['t', 'x', 'y', 'z', 'qx', 'qy', 'qz', 'qw',
                           'L1', 'L2', 'L3', 'L4', 'L5', 'L6']
    assert data.shape == (51, len(SIMULATION_COLUMNS))
    ref = simulate(GEOM, POSITION, QUAT, forces, duration=0.05, dt=0.001, method='partitioning')
    np.testing.assert_allclose(data[:, 1:4], ref.position, atol=1e-14)
    np.testing.assert_allclose(data[:, 8:14], ref.lengths, atol=1e-14)
    assert png.stat().st_size > 10_000 and png.read_bytes()[:4] == b'\x89PNG'
    assert 'real time' in captured.out


def test_simulate_hold_keeps_the_pose(tmp_path, capsys):
    out = tmp_path / 'hold.csv'
    assert run(['simulate', '--position', POS_ARG, '--quaternion', QUAT_ARG, '--forces', 'hold',
                '--duration', '0.02', '--dt', '0.002', '--output-every', '5',
                '--csv', str(out)]) == 0
    _, data = read_csv(out)
    assert data.shape[0] == 3
    np.testing.assert_allclose(data[:, 1:4], np.tile(POSITION, (3, 1)), atol=1e-12)


@pytest.mark.parametrize('every', [1, 7])
def test_simulate_csv_is_the_library_run_to_the_last_bit(tmp_path, every):
    """Every value as repr writes the library's (it reads back exactly), CRLF rows as before,
    rows at t = 0, every N-th step and the last (50 steps: 51 rows, or 0, 7, ..., 49, 50)."""
    forces = MultibodyDynamics(GEOM).holding_forces(POSITION, QUAT) + [2.0, -1.0, 0.5, 1.0, -2.0, 0.0]
    out = tmp_path / 'run.csv'
    assert run(['simulate', '--position', POS_ARG, '--quaternion', QUAT_ARG,
                '--forces', ','.join(map(repr, forces.tolist())), '--duration', '0.05', '--dt', '0.001',
                '--output-every', str(every), '--csv', str(out)]) == 0
    ref = simulate(GEOM, POSITION, QUAT / np.linalg.norm(QUAT), forces, duration=0.05, dt=0.001,
                   output_every=every)
    lines = out.read_bytes().decode('ascii').split('\r\n')
    assert lines[0] == ','.join(SIMULATION_COLUMNS) and lines[-1] == ''
    rows = [line.split(',') for line in lines[1:-1]]
    assert len(rows) == 1 + -(-50 // every) == len(ref.t)
    timed = SIMULATION_COLUMNS.index('step_seconds')     # the wall time differs from run to run
    for row, expected in zip(rows, cli.simulation_rows(ref).tolist()):
        assert len(row) == len(SIMULATION_COLUMNS)
        assert row[:timed] == [repr(v) for v in expected[:timed]]
        assert repr(float(row[timed])) == row[timed]
    assert float(rows[-1][0]) == ref.t[-1] == pytest.approx(0.05)
    assert float(rows[-2][0]) == pytest.approx(0.049)


@pytest.mark.parametrize('reactions', [False, True])
def test_simulate_npz_holds_every_column_of_the_library_run_to_the_bit(tmp_path, reactions):
    """The bulk output: one float64 array per CSV column, named as its header, equal to the
    library's values (the wall time per step aside); with --csv too, the same rows in the CSV."""
    forces = MultibodyDynamics(GEOM).holding_forces(POSITION, QUAT) + [2.0, -1.0, 0.5, 1.0, -2.0, 0.0]
    npz, out = tmp_path / 'run.npz', tmp_path / 'run.csv'
    argv = ['simulate', '--position', POS_ARG, '--quaternion', QUAT_ARG, '--forces',
            ','.join(map(repr, forces.tolist())), '--duration', '0.02', '--dt', '0.001', '--npz', str(npz),
            '--csv', str(out)]
    assert run(argv + (['--reactions'] if reactions else [])) == 0
    ref = simulate(GEOM, POSITION, QUAT / np.linalg.norm(QUAT), forces, duration=0.02, dt=0.001,
                   reactions=reactions)
    expected = cli.simulation_rows(ref)
    columns = list(SIMULATION_COLUMNS)
    if reactions:
        expected, columns = np.column_stack([expected, cli.reaction_rows(ref)]), columns + list(cli.REACTION_COLUMNS)
    archive = np.load(npz)
    assert list(archive.files) == columns
    header, data = read_csv(out)
    assert header == columns
    for k, name in enumerate(columns):
        assert archive[name].dtype == np.float64 and archive[name].shape == (len(ref.t),)
        np.testing.assert_array_equal(archive[name], data[:, k])
        if name != 'step_seconds':                      # the wall time differs from run to run
            np.testing.assert_array_equal(archive[name], expected[:, k])


def test_statics_prints_the_six_holding_forces(capsys):
    assert run(['statics', '--position', POS_ARG, '--quaternion', QUAT_ARG]) == 0
    lines = capsys.readouterr().out.strip().splitlines()
    assert [line.split(':')[0] for line in lines[:6]] == [f'leg_{i}' for i in range(1, 7)]
    printed = np.array([float(line.split()[1]) for line in lines[:6]])
    np.testing.assert_allclose(printed, holding_forces(GEOM, POSITION, QUAT), atol=1e-6)
    np.testing.assert_allclose(printed, MultibodyDynamics(GEOM).holding_forces(POSITION, QUAT),
                               atol=1e-5)


def test_inverse_reads_a_trajectory_and_writes_forces(tmp_path):
    t = np.linspace(0.0, 0.5, 26)
    positions = POSITION + np.outer(0.02 * np.sin(2 * np.pi * t), [0.0, 0.0, 1.0])
    quats = np.tile(QUAT, (len(t), 1))
    traj = tmp_path / 'traj.csv'
    with open(traj, 'w', newline='') as fh:
        w = csv.writer(fh)
        w.writerow(['t', 'x', 'y', 'z', 'qx', 'qy', 'qz', 'qw', 'extra'])
        for k in range(len(t)):
            w.writerow([t[k], *positions[k], *quats[k], 7])
    out = tmp_path / 'forces.csv'
    assert run(['inverse', '--trajectory', str(traj), '--csv', str(out)]) == 0
    header, data = read_csv(out)
    assert header == ['t', 'F1', 'F2', 'F3', 'F4', 'F5', 'F6']
    np.testing.assert_allclose(data[:, 0], t)
    np.testing.assert_allclose(data[:, 1:], inverse_dynamics(GEOM, t, positions, quats),
                               rtol=1e-12)


def test_inverse_takes_optional_velocity_and_acceleration_columns(tmp_path):
    t = np.linspace(0.0, 0.5, 26)
    w = 2 * np.pi
    s, ds, dds = np.sin(w * t), w * np.cos(w * t), -w**2 * np.sin(w * t)
    axis = np.array([0.0, 0.0, 0.02])
    positions = POSITION + np.outer(s, axis)
    quats = np.tile(QUAT, (len(t), 1))
    twist = np.column_stack([np.outer(ds, axis), np.zeros((len(t), 3))])
    twist_dot = np.column_stack([np.outer(dds, axis), np.zeros((len(t), 3))])
    traj = tmp_path / 'traj.csv'
    with open(traj, 'w', newline='') as fh:
        w = csv.writer(fh)
        w.writerow(['t', 'x', 'y', 'z', 'qx', 'qy', 'qz', 'qw', 'vx', 'vy', 'vz', 'wx', 'wy', 'wz',
                    'ax', 'ay', 'az', 'dwx', 'dwy', 'dwz'])
        for k in range(len(t)):
            w.writerow([t[k], *positions[k], *quats[k], *twist[k], *twist_dot[k]])
    out = tmp_path / 'forces.csv'
    assert run(['inverse', '--trajectory', str(traj), '--csv', str(out)]) == 0
    _, data = read_csv(out)
    exact = inverse_dynamics(GEOM, t, positions, quats, twist=twist, twist_dot=twist_dot)
    np.testing.assert_allclose(data[:, 1:], exact, rtol=1e-12)
    # differentiated from 26 samples, the forces differ by far more: the columns were used
    assert np.abs(inverse_dynamics(GEOM, t, positions, quats) - exact).max() > 1e-6
    partial = tmp_path / 'partial.csv'
    partial.write_text(traj.read_text().replace('wz,', 'omega_z,', 1))
    assert run(['inverse', '--trajectory', str(partial), '--csv', str(out)]) == 2


def test_report_reproduces_figures_6_and_7(tmp_path, capsys):
    assert run(['report', '--out-dir', str(tmp_path), '--duration', '0.02', '--dt', '0.002']) == 0
    out = capsys.readouterr().out
    assert (tmp_path / 'figure6_direct_kinematics.png').stat().st_size > 10_000
    assert (tmp_path / 'figure7_direct_dynamics.png').stat().st_size > 10_000
    rows = [line.split() for line in out.splitlines() if line.strip()[:2].strip().isdigit()]
    assert len(rows) == 11
    for r in rows:
        assert r[5] == 'yes' and float(r[6]) < 1e-9 and float(r[7]) < 1e-9 and r[8] == '1'
        assert 1 <= int(r[2]) <= 8 and float(r[3]) > 0
    assert 'Figure 7' in out and 'real time' in out


def test_climb_is_800_mm_in_11_phases():
    positions, quats, world, moved = climb_poses()
    assert positions.shape == (12, 3) and len(moved) == 11
    travelled = np.sum(np.linalg.norm(np.diff(world, axis=0), axis=2))
    assert travelled == pytest.approx(0.8, abs=2e-3)     # chords of the curved trunk
    lengths = inverse_kinematics(GEOM, positions, quats).lengths
    assert np.all(lengths > GEOM.min_length) and np.all(lengths < GEOM.max_length)
    assert moved[0] == 'ring_b' and moved[1] == 'ring_a'


@pytest.mark.parametrize('argv, message', [
    (['simulate', '--csv', 'x.csv'], '--forces'),
    (['simulate', '--forces', '1,2,3', '--csv', 'x.csv'], 'expected 6 numbers'),
    (['simulate', '--forces', 'hold', '--method', 'euler', '--csv', 'x.csv'], 'invalid choice'),
    (['simulate', '--forces', 'hold', '--dt', '0.1', '--duration', '0.01', '--csv', 'x.csv'],
     'must not exceed'),
    (['simulate', '--forces', 'hold', '--dt', '-1', '--csv', 'x.csv'], 'positive'),
    (['simulate', '--forces', 'hold'], 'give the output: --npz and/or --csv'),
    (['statics', '--robot', 'no_such_robot'], 'unknown robot'),
    (['statics', '--quaternion', '0,0,0,0'], 'zero quaternion'),
    (['inverse', '--trajectory', '/nonexistent/traj.csv', '--csv', 'f.csv'], 'cannot read'),
    (['statics', '--support', 'ring_c'], 'invalid choice'),
    (['statics', '--support-quaternion', '0,0,0,2'], '--support-quaternion: quaternion norm 2 is not 1'),
    (['statics', '--gravity', '0,-9.81'], 'expected 3 numbers'),
    (['statics', '--payload-com', '0,0,0.1'], '--payload-com and --payload-ring need --payload-mass'),
    (['statics', '--payload-mass', '-2'], 'payload.mass: must be >= 0'),
    (['statics', '--robot', 'facade_climber', '--tool-force', '0,0,-30'], 'there is no tool section'),
    (['statics', '--tool-force', '0,0,-30', '--tool-frame', 'ring_b'], 'invalid choice'),
    (['frobnicate'], 'invalid choice'),
])
def test_bad_arguments_give_one_line_and_status_2(argv, message, capsys, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    assert run(argv) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith('rrps-dynamics: error:') and message in err
    assert len(err.splitlines()) == 1


def test_trajectory_with_missing_columns_is_rejected(tmp_path, capsys):
    traj = tmp_path / 'bad.csv'
    traj.write_text('t,x,y\n0,0,0\n')
    assert run(['inverse', '--trajectory', str(traj), '--csv', str(tmp_path / 'f.csv')]) == 2
    assert 'missing columns' in capsys.readouterr().err


@pytest.mark.parametrize('rows, message', [
    ('0,0,0,0.4,0,0,0,1\n0.1,0,0,0.4,0,0,x,1\n', 'line 3'),
    ('0,0,0,0.4,0,0,0,1\n0,0,0,0.4,0,0,0,1\n0.1,0,0,0.4,0,0,0,1\n0.2,0,0,0.4,0,0,0,1\n',
     'strictly increasing'),
    ('0,0,0,0.4,0,0,0,1\n0.1,0,0,0.4,0,0,0,1\n', 'at least 4'),
    ('0,0,0,0.4,0,0,0,1\n0.1,0,0,0.4,0,0,0,0\n0.2,0,0,0.4,0,0,0,1\n0.3,0,0,0.4,0,0,0,1\n',
     'zero quaternion'),
])
def test_a_malformed_trajectory_is_a_usage_error(rows, message, tmp_path, capsys):
    traj = tmp_path / 'bad.csv'
    traj.write_text('t,x,y,z,qx,qy,qz,qw\n' + rows)
    assert run(['inverse', '--trajectory', str(traj), '--csv', str(tmp_path / 'f.csv')]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith('rrps-dynamics: error:') and message in err
    assert len(err.splitlines()) == 1


def pointed_robot(tmp_path):
    """The pole climber with every spherical joint at ring_b's origin: singular everywhere."""
    data = yaml.safe_load(robot_path('pole_climber').read_text())
    data['name'] = 'pointed'
    data['ring_b']['anchors'] = [[0.0, 0.0, 0.0]] * 6
    path = tmp_path / 'pointed.yaml'
    path.write_text(yaml.safe_dump(data))
    return path


def test_a_singular_pose_is_a_failed_computation_with_status_1(tmp_path, capsys):
    assert run(['statics', '--robot', str(pointed_robot(tmp_path))]) == 1
    err = capsys.readouterr().err.strip()
    assert err.startswith('rrps-dynamics: error: singular pose')
    assert len(err.splitlines()) == 1


def test_no_convergence_is_a_failed_computation_with_status_1(tmp_path, capsys):
    # 3 kN per leg throws ring_b far out of the stroke; the partitioned Newton solve gives up.
    status = run(['simulate', '--forces', '3000,3000,3000,-3000,-3000,-3000', '--duration', '0.1',
                  '--method', 'partitioning', '--csv', str(tmp_path / 'x.csv')])
    assert status == 1
    errors = [line for line in capsys.readouterr().err.splitlines() if 'error' in line]
    assert len(errors) == 1 and errors[0].startswith('rrps-dynamics: error: no convergence at t =')


def test_a_bug_shows_its_traceback_with_status_3(monkeypatch, capsys):
    def broken(g, args):
        return [str(1 / 0)]

    monkeypatch.setitem(cli.COMMANDS, 'statics', broken)
    assert run(['statics']) == 3
    err = capsys.readouterr().err
    assert 'Traceback (most recent call last)' in err and 'ZeroDivisionError' in err
    assert err.strip().splitlines()[-1].startswith('rrps-dynamics: internal error')


def test_console_script(tmp_path):
    exe = shutil.which('rrps-dynamics') or sys.executable
    prefix = [] if exe.endswith('rrps-dynamics') else ['-m', 'rrps_sim.cli']
    ok = subprocess.run([exe, *prefix, 'statics'], capture_output=True, text=True, timeout=120)
    assert ok.returncode == 0 and ok.stdout.count('leg_') == 6
    bad = subprocess.run([exe, *prefix, 'statics', '--position', '1,2'], capture_output=True,
                         text=True, timeout=120)
    assert bad.returncode == 2 and len(bad.stderr.strip().splitlines()) == 1
    failed = subprocess.run([exe, *prefix, 'statics', '--robot', str(pointed_robot(tmp_path))],
                            capture_output=True, text=True, timeout=120)
    assert failed.returncode == 1 and len(failed.stderr.strip().splitlines()) == 1
    assert 'singular pose' in failed.stderr


WALL = '0.70710678,0,0,0.70710678'


@pytest.mark.parametrize('robot,support', [('facade_climber', 'ring_a'), ('facade_climber', 'ring_b'),
                                           ('pole_climber', 'ring_b')])
def test_statics_on_either_ring_in_the_world(robot, support, capsys):
    geom = load_robot(robot)
    assert run(['statics', '--robot', robot, '--support', support, '--support-quaternion', WALL]) == 0
    lines = capsys.readouterr().out.strip().splitlines()
    sol = static_solution(geom, (geom.home_position, geom.home_quaternion_xyzw), support=support,
                          world_q_support=np.array([0.70710678, 0, 0, 0.70710678]))
    printed = {line.split(':')[0]: line.split(':', 1)[1] for line in lines}
    forces = np.array([float(printed[f'leg_{i}'].split()[0]) for i in range(1, 7)])
    np.testing.assert_allclose(forces, sol.actuator_forces, atol=1e-6)
    assert printed['support'].startswith(f" {support}; vectors in {support}'s frame")
    for name, values in (('universal', sol.universal_reactions), ('spherical', sol.spherical_reactions)):
        for i in range(6):
            np.testing.assert_allclose(np.array(printed[f'{name}_{i + 1}'].replace(' N', '').split(','), float),
                                       values[i], atol=1e-6)
    np.testing.assert_allclose(np.array(printed['support_force'].replace(' N', '').split(','), float),
                               sol.support_wrench[:3], atol=1e-6)
    assert float(printed['holding_margin']) == pytest.approx(float(sol.holding_margin), abs=1e-6)


def test_statics_json_has_everything_and_the_load_flags_load_the_robot(capsys):
    argv = ['statics', '--json', '--support', 'ring_b', '--support-quaternion', WALL, '--gravity', '0,0,-9.8',
            '--payload-mass', '2.0', '--payload-com', '0.1,-0.05,0.02', '--payload-ring', 'ring_a',
            '--tool-force', '0,-5,40', '--tool-torque', '0.5,0,-1', '--tool-frame', 'world']
    assert run(argv) == 0
    out = json.loads(capsys.readouterr().out)
    loaded = GEOM.with_(payload=Payload(ring='ring_a', mass=2.0, com=np.array([0.1, -0.05, 0.02])),
                        tool_wrench=ToolWrench(force=np.array([0.0, -5.0, 40.0]),
                                               torque=np.array([0.5, 0.0, -1.0]), frame='world'))
    sol = static_solution(loaded, (GEOM.home_position, GEOM.home_quaternion_xyzw), support='ring_b',
                          world_q_support=np.array([0.70710678, 0, 0, 0.70710678]), gravity=[0, 0, -9.8])
    assert out['support'] == out['frame'] == 'ring_b' and out['robot'] == 'pole_climber'
    np.testing.assert_allclose(out['gravity_in_support'], [0.0, -9.8, 0.0], atol=1e-6)
    np.testing.assert_allclose(list(out['actuator_forces'].values()), sol.actuator_forces, atol=1e-9)
    np.testing.assert_allclose(list(out['universal_reactions'].values()), sol.universal_reactions, atol=1e-9)
    np.testing.assert_allclose(out['support_wrench']['moment'], sol.support_wrench[3:], atol=1e-9)
    assert out['holding_margin'] == pytest.approx(float(sol.holding_margin))
    # the payload rides on ring_a, which hangs on the legs: the forces change
    assert np.abs(sol.actuator_forces - holding_forces(GEOM, GEOM.home_position, GEOM.home_quaternion_xyzw,
                                                       support='ring_b', world_q_support=[0.70710678, 0, 0,
                                                                                          0.70710678])).max() > 1.0


def test_simulate_writes_the_reactions_and_holds_on_ring_b(tmp_path, capsys):
    out = tmp_path / 'reactions.csv'
    assert run(['simulate', '--forces', 'hold', '--support', 'ring_b', '--support-quaternion', WALL,
                '--duration', '0.02', '--dt', '0.002', '--output-every', '5', '--reactions',
                '--csv', str(out)]) == 0
    header, data = read_csv(out)
    assert header == SIMULATION_COLUMNS + REACTION_COLUMNS and data.shape == (3, len(header))
    np.testing.assert_allclose(data[:, 1:4], np.tile(GEOM.home_position, (3, 1)), atol=1e-12)
    sol = static_solution(GEOM, (GEOM.home_position, GEOM.home_quaternion_xyzw), support='ring_b',
                          world_q_support=np.array([0.70710678, 0, 0, 0.70710678]))
    columns = {name: data[:, k] for k, name in enumerate(header)}
    np.testing.assert_allclose(columns['U3y'], sol.universal_reactions[2, 1], atol=1e-6)
    np.testing.assert_allclose(columns['S6z'], sol.spherical_reactions[5, 2], atol=1e-6)
    np.testing.assert_allclose(columns['support_mx'], sol.support_wrench[3], atol=1e-6)


def test_inverse_takes_the_world(tmp_path):
    t = np.linspace(0.0, 0.5, 26)
    positions = POSITION + np.outer(0.02 * np.sin(2 * np.pi * t), [0.0, 0.0, 1.0])
    quats = np.tile(QUAT, (len(t), 1))
    traj, out = tmp_path / 'traj.csv', tmp_path / 'forces.csv'
    with open(traj, 'w', newline='') as fh:
        w = csv.writer(fh)
        w.writerow(['t', 'x', 'y', 'z', 'qx', 'qy', 'qz', 'qw'])
        w.writerows(np.column_stack([t, positions, quats]))
    assert run(['inverse', '--trajectory', str(traj), '--csv', str(out), '--support', 'ring_b',
                '--support-quaternion', WALL]) == 0
    _, data = read_csv(out)
    expected = inverse_dynamics(GEOM, t, positions, quats, support='ring_b',
                                world_q_support=np.array([0.70710678, 0, 0, 0.70710678]))
    np.testing.assert_allclose(data[:, 1:], expected, atol=1e-9)
