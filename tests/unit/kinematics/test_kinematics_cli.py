"""The rrps-kinematics command: every subcommand, JSON output, and one-line errors with status 2."""

import json
import shutil
import subprocess

import numpy as np
import pytest
import yaml

from rrps_description.geometry import load_robot, robot_path
from rrps_kinematics import forward_kinematics, inverse_kinematics
from rrps_kinematics.backend import numba_enabled
from rrps_kinematics.cli import run
from rrps_testing.ci import require


def _run(capsys, *argv):
    code = run(list(argv))
    out, err = capsys.readouterr()
    return code, out, err


def _json(capsys, *argv):
    code, out, err = _run(capsys, *argv, '--json')
    assert code == 0, err
    return json.loads(out)


def test_info_text_names_anchors_stroke_and_margins(capsys):
    code, out, err = _run(capsys, 'info', '--robot', 'frame_climber')
    assert code == 0 and err == ''
    g = load_robot('frame_climber')
    assert 'robot: frame_climber' in out
    for i in range(1, 7):
        assert f'leg_{i} ' in out
    assert f'{g.min_length:.4f} .. {g.max_length:.4f} m' in out
    assert 'within limits: yes' in out and 'extra ring DOF on ring_a, ring_b' in out


def test_info_json_matches_the_library(capsys):
    data = _json(capsys, 'info')
    g = load_robot('pole_climber')
    assert data['name'] == 'pole_climber'
    np.testing.assert_allclose(data['home_lengths'], g.home_lengths)
    np.testing.assert_allclose(data['ring_a_anchors'], g.ring_a_anchors)
    assert data['margins_at_home']['within_limits'] is True


def test_ik_matches_the_library_and_accepts_negative_numbers(capsys):
    g = load_robot('pole_climber')
    p, q = np.array([-0.02, 0.01, 0.41]), np.array([0.0, -0.03, 0.05, 1.0])
    data = _json(capsys, 'ik', '--robot', 'pole_climber', '--position', '-0.02,0.01,0.41',
                 '--quaternion', '0,-0.03,0.05,1')
    np.testing.assert_allclose(data['lengths'], inverse_kinematics(g, p, q).lengths, atol=1e-15)
    assert data['margins']['within_limits'] is True
    code, out, _ = _run(capsys, 'ik', '--position', '-0.02,0.01,0.41')
    assert code == 0 and 'lengths: ' in out and 'within limits: yes' in out


def test_ik_out_of_limits_names_the_violation(capsys):
    code, out, _ = _run(capsys, 'ik', '--position', '0,0,0.75')
    assert code == 0 and 'within limits: no' in out and '> max_length' in out


def test_fk_round_trip_through_the_command_line(capsys):
    g = load_robot('master_robot')
    p, q = g.home_position + [0.004, -0.003, 0.006], np.array([0.02, 0.01, -0.04, 1.0])
    L = inverse_kinematics(g, p, q).lengths
    lengths = ','.join(repr(float(x)) for x in L)
    data = _json(capsys, 'fk', '--robot', 'master_robot', '--lengths', lengths)
    assert data['converged'] is True and data['singular'] is False
    np.testing.assert_allclose(data['position'], p, atol=1e-9)
    seed = ','.join(str(x) for x in [*p, *q])
    seeded = _json(capsys, 'fk', '--robot', 'master_robot', '--lengths', lengths, '--seed', seed)
    assert seeded['iterations'] <= 1
    code, out, _ = _run(capsys, 'fk', '--robot', 'master_robot', '--lengths', lengths)
    assert code == 0 and out.splitlines()[1].startswith('converged in')


def test_fk_without_solution_exits_1_and_says_so(capsys):
    code, out, err = _run(capsys, 'fk', '--lengths', '0.05,1.5,0.42,0.42,0.42,0.42')
    assert code == 1 and 'NOT converged' in out and err == ''


def test_modes_lists_every_assembly_mode(capsys):
    g = load_robot('pole_climber')
    lengths = ','.join(repr(float(x)) for x in g.home_lengths)
    data = _json(capsys, 'modes', '--lengths', lengths)
    assert data['count'] == len(data['modes']) >= 2
    first = data['modes'][0]
    np.testing.assert_allclose(first['position'], g.home_position, atol=1e-9)
    assert first['within_limits'] is True
    for mode in data['modes']:
        L = inverse_kinematics(g, mode['position'], mode['quaternion_xyzw']).lengths
        np.testing.assert_allclose(L, g.home_lengths, atol=1e-9)
    code, out, _ = _run(capsys, 'modes', '--lengths', lengths)
    assert code == 0 and f'{data["count"]} real assembly modes' in out
    if numba_enabled():
        assert data['method'] == 'continuation' and data['certified'] is True and data['paths_failed'] == 0
        assert 'certified complete (all 40 paths ended)' in out
    multistart = _json(capsys, 'modes', '--lengths', lengths, '--method', 'multistart')
    assert multistart['method'] == 'multistart' and multistart['certified'] is False
    assert multistart['count'] == data['count'] and multistart['seeds'] == 20000


def test_robot_yaml_path(capsys, tmp_path):
    path = tmp_path / 'my_robot.yaml'
    shutil.copy(robot_path('facade_climber'), path)
    data = _json(capsys, 'info', '--robot', str(path))
    assert data['name'] == 'facade_climber'


@pytest.mark.parametrize('argv,message', [
    ([], 'the following arguments are required'),
    (['walk'], "invalid choice: 'walk'"),
    (['ik'], 'the following arguments are required: --position'),
    (['ik', '--position', '1,2'], 'argument --position: expected 3 numbers, got 2'),
    (['ik', '--position', '0,0,nan'], 'values must be finite'),
    (['ik', '--position', '0,0,0.4', '--quaternion', '0,0,0,0'], 'quaternion has zero norm'),
    (['fk', '--lengths', '1,a,3,4,5,6'], "expected 6 comma-separated numbers, got '1,a,3,4,5,6'"),
    (['fk', '--lengths', '0.4,0.4,0.4,0.4,0.4,0.4', '--seed', '0,0,0.4'], 'expected 7 numbers'),
    (['modes', '--lengths', '0.4,0.4,0.4,0.4,0.4,-0.4'], 'lengths must be positive'),
    (['modes', '--lengths', '0.4,0.4,0.4,0.4,0.4,0.4', '--method', 'guess'], "invalid choice: 'guess'"),
    (['info', '--robot', 'spider'], "unknown robot 'spider'"),
    (['info', '--bogus'], 'unrecognized arguments: --bogus'),
])
def test_bad_arguments_give_one_line_and_status_2(capsys, argv, message):
    code, out, err = _run(capsys, *argv)
    assert code == 2 and out == ''
    assert len(err.strip().splitlines()) == 1
    assert err.startswith('rrps-kinematics: error: ') and message in err


def test_malformed_robot_file_names_the_key(capsys, tmp_path):
    data = yaml.safe_load(robot_path('pole_climber').read_text())
    data['legs']['min_length'] = 0.9
    path = tmp_path / 'broken.yaml'
    path.write_text(yaml.safe_dump(data))
    code, out, err = _run(capsys, 'info', '--robot', str(path))
    assert code == 2 and len(err.strip().splitlines()) == 1
    assert 'broken.yaml: legs.min_length (0.9) must be < legs.max_length' in err


def test_console_script_help_and_error_status():
    exe = shutil.which('rrps-kinematics')
    require(exe is not None, 'rrps-kinematics is not on PATH (package not installed)')
    out = subprocess.run([exe, '--help'], capture_output=True, text=True, timeout=60)
    assert out.returncode == 0 and 'usage: rrps-kinematics' in out.stdout
    assert 'pole_climber' in out.stdout
    bad = subprocess.run([exe, 'ik', '--position', 'x'], capture_output=True, text=True, timeout=60)
    assert bad.returncode == 2 and len(bad.stderr.strip().splitlines()) == 1


def test_fk_command_equals_library_result(capsys):
    g = load_robot('pole_climber')
    L = g.home_lengths * 1.02
    data = _json(capsys, 'fk', '--lengths', ','.join(repr(float(x)) for x in L))
    fk = forward_kinematics(g, L)
    np.testing.assert_allclose(data['position'], fk.position, atol=1e-15)
    assert data['iterations'] == fk.iterations


def test_a_failed_computation_exits_1_and_a_bug_exits_3_with_its_traceback(capsys, monkeypatch):
    from rrps_kinematics import cli
    from rrps_kinematics.errors import SingularPoseError

    def singular(*args, **kwargs):
        raise SingularPoseError('the pose is singular: a leg has zero length')

    monkeypatch.setattr(cli, '_info', singular)
    assert cli.run(['info']) == 1
    err = capsys.readouterr().err
    assert err.strip() == 'rrps-kinematics: error: the pose is singular: a leg has zero length'

    def bug(*args, **kwargs):
        raise KeyError('leg_7')

    monkeypatch.setattr(cli, '_info', bug)
    assert cli.run(['info']) == 3
    err = capsys.readouterr().err
    assert 'Traceback' in err and "KeyError: 'leg_7'" in err and 'internal error' in err
